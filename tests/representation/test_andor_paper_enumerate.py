"""Fig. 6, result and all (issue 21, item 7): ``benchmarks/andor_paper.py --enumerate`` times
flexhrc's path enumeration beside its DP (and the C++ when its binary is built) on the authors'
table graphs, prints a row per representation and method and draws the figure.

Runs on a tiny range (1..2 legs, one seed) so it is quick; no timing is asserted — the growth
the acceptance asks for is the benchmark's own printout (docs/andor.md).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

from tests.conftest import REPO, subprocess_env

BENCH = REPO / "benchmarks" / "andor_paper.py"
CPP = Path.home() / ".cache" / "flexhrc-cppref" / "andor_bench"


def _bench(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(BENCH), "--enumerate", *args],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        cwd=cwd,
        timeout=300,
    )


def _rows(stdout: str, title: str) -> dict[tuple[str, str], list[str]]:
    """The rows of one printed table: (representation, method) -> its cells (11 wide each,
    after the 29 of the names)."""
    block = stdout.split(f"Fig. 6, {title}:", 1)[1].split("\n\n", 1)[0]
    out = {}
    for line in block.splitlines()[3:]:
        rep, method = line[:29].split()
        cells = line[29:]
        out[rep, method] = [cells[i : i + 11].strip() for i in range(0, len(cells), 11)]
    return out


def test_enumerate_prints_and_plots_every_line(anchors_dir: Path, tmp_path: Path) -> None:
    cpp = ["--cpp", str(CPP)] if CPP.is_file() else ["--no-cpp"]
    fig, doc = tmp_path / "fig6.png", tmp_path / "fig6.json"
    tiny = ["--anchors", str(anchors_dir), "--legs", "2", "--seeds", "1", "--time-limit", "60"]
    proc = _bench([*tiny, "--out", str(fig), "--json", str(doc), *cpp], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    methods = ["enumeration", "DP"] + (["C++"] if CPP.is_file() else [])
    for title in ("offline", "online, per query"):
        rows = _rows(proc.stdout, title)
        assert set(rows) == {
            (rep, m) for rep in ("FOL", "standard", "hierarchical") for m in methods
        }
        for cells in rows.values():
            assert len(cells) == 2 and all(c.endswith(("µs", "ms", " s")) for c in cells), cells
    # progress per run, on stderr: one line per representation, method, legs and seed
    assert proc.stderr.count(", seed 1: offline ") == 3 * len(methods) * 2
    assert "(needs 4 and 8 legs" in proc.stdout
    points = json.loads(doc.read_text())["enumerate"]
    assert len(points) == 3 * len(methods) * 2
    assert all(p["offline_s"] is not None and p["capped"] is None for p in points)
    if importlib.util.find_spec("matplotlib") is not None:
        assert f"plot: {fig}" in proc.stdout
        assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert not [p for p in tmp_path.iterdir() if p.name.startswith(".fig6")]  # atomic


def test_enumerate_caps_each_run(anchors_dir: Path, tmp_path: Path) -> None:
    """A run past the time limit is killed and shown as such; the larger graphs of its line
    are not run."""
    tiny = ["--anchors", str(anchors_dir), "--legs", "2", "--seeds", "1", "--time-limit", "0.001"]
    proc = _bench([*tiny, "--no-cpp", "--out", str(tmp_path / "capped.png")], tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rows = _rows(proc.stdout, "offline")
    assert rows["FOL", "enumeration"] == ["> 0.001 s", "(capped)"]
    assert rows["hierarchical", "DP"] == ["> 0.001 s", "(capped)"]
    assert "past the time limit (0.001 s)" in proc.stderr


def test_enumerate_without_anchors_is_one_clear_error(tmp_path: Path) -> None:
    proc = _bench(["--anchors", str(tmp_path / "nowhere"), "--legs", "1"], tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().endswith("is not present (give --anchors)")
    assert "Traceback" not in proc.stderr
