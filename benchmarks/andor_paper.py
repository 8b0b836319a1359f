"""Reproduce the FlexHRC+ paper's Fig. 6 experiment on the authors' own graph files, and
measure flexhrc against the public C++ ANDOR side by side (issue 9, item 6).

Parity (first, unless ``--no-parity``): the C++ library built with ``g++ -O2``
(``../shared/anchors/andor-cpp/build.sh``; built on first use into ``~/.cache/flexhrc-cppref``)
and flexhrc run on the same files with the same random-client protocol, alternating, in one
run: per seed one fresh C++ process and one fresh ``python -m flexhrc graph play --json``
process, so flexhrc's offline time is a cold first call as ``graph play`` reports it. Both
sides time themselves from inside (process start-up is excluded on both). Medians over 5 seeds;
printed with the ratio flexhrc / C++ and the targets of issue 9. Without the C++ binary (or
``../shared``) the parity table says so and is skipped. flexhrc reads the ANDOR text files with
its compiled common case when the install has built it (the table says which reader ran);
``--pure-python`` measures the pure-Python reader instead.

For every file: offline time (load + validate + build, including the initial cost computation)
and online time per query, medians over 10 random traversals (the authors' random test client:
query 0 is empty, each later query reports one element drawn uniformly from the previous answer's
feasible nodes and hyper-arcs). Printed as a table beside the public C++ implementation (measured
on this kind of machine, ``../shared/anchors/andor-cpp-reference.md``) and the paper's published
figures, with the ratio and the target of issue #2; plotted to PNG on log scales.

    python benchmarks/andor_paper.py [--anchors DIR] [--runs 10] [--out out/andor_paper.png]
                                     [--json out/andor_paper.json] [--seeds 5]
                                     [--cpp PATH] [--no-parity] [--parity-only]
                                     [--pure-python]

Needs ``../shared/anchors/andor-graphs`` (or ``--anchors``); the plot needs matplotlib.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexhrc.representation import load  # noqa: E402
from flexhrc.representation.online import OnlineGraph  # noqa: E402
from flexhrc.representation.play import play  # noqa: E402

DEFAULT_ANCHORS = ROOT.parent / "shared" / "anchors" / "andor-graphs"
CPP_SOURCES = ROOT.parent / "shared" / "anchors" / "andor-cpp"
CPP_BINARY = Path.home() / ".cache" / "flexhrc-cppref" / "andor_bench"

# Issue 9, item 6: (label, file under the anchors, metric, target ratio flexhrc / C++).
PARITY: list[tuple[str, str, str, float]] = [
    ("kitchen", "TRO-IKEAKitchenAssembly/KitchenAssembly.txt", "offline_s", 1.5),
    ("kitchen", "TRO-IKEAKitchenAssembly/KitchenAssembly.txt", "online_s_per_query_median", 1.0),
    (
        "hierarchical 10 legs",
        "TRO-TableAssembly/10Leg/TableAssembly_hierarchical.txt",
        "online_s_per_query_median",
        3.0,
    ),
    ("ball FOL (7 nodes)", "TRO-BallBoxPlacement/FOL_BallPlacment.txt", "offline_s", 5.0),
]
METRIC = {"offline_s": "offline", "online_s_per_query_median": "per query"}

# C++ ANDOR (commit 1499895, g++ -O2, this kind of machine): offline s, per-query median s.
# From ../shared/anchors/andor-cpp-reference.md. None: not measured / did not finish.
CPP: dict[str, tuple[float | None, float | None]] = {
    "FOL 1 leg": (3.8e-5, 1.8e-6),
    "FOL 4 legs": (4.4e-4, 1.2e-5),
    "FOL 5 legs": (2.6e-3, 4.5e-5),
    "FOL 6 legs": (0.034, 2.5e-4),
    "FOL 7 legs": (0.447, 1.2e-3),
    "FOL 8 legs": (8.31, 0.016),
    "FOL 9 legs": (215.6, 0.079),
    "FOL 10 legs": (5400.0, None),  # not finished; ~1.5 h extrapolated
    "hierarchical 1 leg": (4.4e-5, 1.9e-6),
    "hierarchical 5 legs": (9.1e-5, 1.6e-6),
    "hierarchical 9 legs": (1.5e-4, 1.5e-6),
    "hierarchical 10 legs": (1.6e-4, 1.5e-6),
    "PL 3 legs": (5.2e-4, 8.9e-6),
    "PL 4 legs": (0.056, 1.6e-4),
    "PL 5 legs": (26.6, 0.018),
    "kitchen": (1.7e-3, 1.3e-5),
    "ball FOL": (2.4e-5, 1.3e-6),
    "ball PL": (3.5e-5, 2.7e-6),
}
# The paper's own figures (i7-4790, ROS): offline s, online total s.
PAPER: dict[str, tuple[float, float]] = {
    "hierarchical 9 legs": (7.6e-4, 1.9e-3),
    "FOL 9 legs": (1.98e3, 17.0),
    "PL 5 legs": (349.0, 3.1),
    "kitchen": (5.1e-3, 0.146),
}
# Targets of issue #2: offline s, per-query s.
TARGETS: dict[str, tuple[float | None, float | None]] = {
    "kitchen": (10e-3, 50e-6),
    "hierarchical 10 legs": (None, 20e-6),
    "FOL 9 legs": (5e-3, None),
    "FOL 10 legs": (5e-3, 50e-6),
    "PL 5 legs": (20e-3, 100e-6),
}


def corpus(anchors: Path) -> list[tuple[str, Path]]:
    files: list[tuple[str, Path]] = []
    for n in range(1, 11):
        files.append(
            (
                f"FOL {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-TableAssembly/{n}Leg/TableAssembly.txt",
            )
        )
    for n in range(1, 11):
        files.append(
            (
                f"hierarchical {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-TableAssembly/{n}Leg/TableAssembly_hierarchical.txt",
            )
        )
    for n in range(1, 6):
        files.append(
            (
                f"PL {n} leg{'s' if n > 1 else ''}",
                anchors / f"TRO-PL_FOL-TableAssembly/{n}Leg/TableAssemblyPL.txt",
            )
        )
    files.append(("kitchen", anchors / "TRO-IKEAKitchenAssembly/KitchenAssembly.txt"))
    files.append(("ball FOL", anchors / "TRO-BallBoxPlacement/FOL_BallPlacment.txt"))
    files.append(("ball PL", anchors / "TRO-BallBoxPlacement/PL_BallPlacement.txt"))
    return [(label, p) for label, p in files if p.is_file()]


@dataclass
class Row:
    label: str
    size: int  # instantiated nodes + hyper-arcs
    queries: int
    offline_s: float
    online_total_s: float
    per_query_s: float


def measure(label: str, path: Path, runs: int) -> Row:
    offline, totals, per_query, queries = [], [], [], []
    for seed in range(runs):
        report = play(path, "random", seed)
        if report.outcome != "solved":
            raise SystemExit(f"{path}: random traversal {seed} ended {report.outcome}")
        offline.append(report.offline_s)
        totals.append(report.online_s_total)
        per_query.append(report.online_s_per_query_median)
        queries.append(report.queries)
    online = OnlineGraph(load(path))
    return Row(
        label,
        len(online.elements()),
        int(statistics.median(queries)),
        statistics.median(offline),
        statistics.median(totals),
        statistics.median(per_query),
    )


def fmt(x: float | None) -> str:
    if x is None:
        return "–"
    if x >= 1:
        return f"{x:.3g} s"
    if x >= 1e-3:
        return f"{x * 1e3:.3g} ms"
    return f"{x * 1e6:.3g} µs"


def ratio(ours: float, ref: float | None) -> str:
    if ref is None:
        return "–"
    r = ref / ours
    return f"{r:.3g}x faster" if r >= 1 else f"{1 / r:.3g}x slower"


def check(value: float, target: float | None) -> str:
    if target is None:
        return ""
    return f"{'PASS' if value <= target else 'FAIL'} (<= {fmt(target)})"


def slope(rows: list[Row]) -> float:
    """Least-squares slope of log(per-query time) against log(graph size)."""
    xs = [math.log(r.size) for r in rows]
    ys = [math.log(r.per_query_s) for r in rows]
    mx, my = statistics.mean(xs), statistics.mean(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum(
        (x - mx) ** 2 for x in xs
    )


def plot(rows: list[Row], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 6), sharey=False)
    labels = [r.label for r in rows]
    y = range(len(rows))
    for ax, title, ours, cpp_i in (
        (axes[0], "offline (load + build)", [r.offline_s for r in rows], 0),
        (axes[1], "online, per query (median)", [r.per_query_s for r in rows], 1),
    ):
        cpp = [CPP.get(r.label, (None, None))[cpp_i] for r in rows]
        ax.scatter(ours, y, marker="o", color="tab:blue", label="flexhrc (Python, DP)", zorder=3)
        ax.scatter(
            [c for c in cpp if c is not None],
            [i for i, c in zip(y, cpp, strict=True) if c is not None],
            marker="s",
            color="tab:red",
            label="C++ ANDOR -O2 (path enumeration)",
            zorder=3,
        )
        if cpp_i == 0:
            pts = [(PAPER[r.label][0], i) for i, r in zip(y, rows, strict=True) if r.label in PAPER]
            ax.scatter(
                *zip(*pts, strict=True), marker="^", color="tab:green", label="paper (Fig. 6)"
            )
        ax.set_xscale("log")
        ax.set_yticks(list(y))
        ax.set_yticklabels(labels if cpp_i == 0 else [])
        ax.invert_yaxis()
        ax.set_xlabel("seconds (log scale)")
        ax.set_title(title)
        ax.grid(True, axis="x", which="both", alpha=0.3)
    axes[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(
        "AND/OR graph engine on the FlexHRC+ authors' files (medians of random traversals)"
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)


def find_cpp(explicit: Path | None, sources: Path = CPP_SOURCES) -> Path | None:
    """The C++ driver: --cpp, else the cache, else built from ../shared (g++ -O2)."""
    if explicit is not None:
        return explicit if explicit.is_file() else None
    if CPP_BINARY.is_file():
        return CPP_BINARY
    build = sources / "build.sh"
    if build.is_file() and shutil.which("g++"):
        print(f"building the C++ reference: {build}", file=sys.stderr, flush=True)
        proc = subprocess.run(["bash", str(build)], capture_output=True, text=True)
        if proc.returncode == 0 and CPP_BINARY.is_file():
            return CPP_BINARY
        print(f"C++ build failed: {proc.stderr.strip()[-400:]}", file=sys.stderr)
    return None


def _run_json(cmd: list[str], env: dict[str, str] | None = None) -> dict[str, float]:
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=600)
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(cmd)} failed: {proc.stderr.strip()[-400:]}")
    data: dict[str, float] = json.loads(proc.stdout)
    return data


def reader(pure_python: bool) -> str:
    """Which ANDOR text reader the flexhrc side uses: the compiled common case (built by the
    install) or, with ``--pure-python`` or when it is not built, the pure-Python one."""
    if pure_python:
        return "pure Python (FLEXHRC_PURE_PYTHON=1)"
    try:
        import flexhrc.representation.formats._andor_fast  # noqa: F401
    except ImportError:
        return "pure Python (the compiled reader is not built)"
    return "compiled common case (_andor_fast)"


def parity(
    anchors: Path, cpp: Path, seeds: int, pure_python: bool = False
) -> tuple[list[dict[str, object]], int]:
    """Both sides on the same files, alternating per seed; medians. Returns rows, failures."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), env.get("PYTHONPATH")) if p)
    env["FLEXHRC_PURE_PYTHON"] = "1" if pure_python else "0"
    files = sorted({rel for _, rel, _, _ in PARITY})
    ours: dict[str, list[dict[str, float]]] = {rel: [] for rel in files}
    theirs: dict[str, list[dict[str, float]]] = {rel: [] for rel in files}
    for seed in range(1, seeds + 1):
        for rel in files:
            path = str(anchors / rel)
            print(f"  seed {seed}: {rel}", file=sys.stderr, flush=True)
            theirs[rel].append(_run_json([str(cpp), path, "--seed", str(seed)]))
            ours[rel].append(
                _run_json(
                    [
                        sys.executable,
                        "-m",
                        "flexhrc",
                        "graph",
                        "play",
                        path,
                        "--policy",
                        "random",
                        "--seed",
                        str(seed),
                        "--json",
                    ],
                    env,
                )
            )
    rows: list[dict[str, object]] = []
    failures = 0
    for label, rel, metric, target in PARITY:
        a = statistics.median(r[metric] for r in ours[rel])
        b = statistics.median(r[metric] for r in theirs[rel])
        ratio_ = a / b
        ok = ratio_ <= target
        failures += not ok
        rows.append(
            {
                "graph": label,
                "metric": METRIC[metric],
                "flexhrc_s": a,
                "cpp_s": b,
                "ratio": ratio_,
                "target": target,
                "pass": ok,
            }
        )
    return rows, failures


def print_parity(rows: list[dict[str, object]], seeds: int, reader_: str = "") -> None:
    print(f"parity with the C++ ANDOR (g++ -O2), side by side, medians of {seeds} seeds")
    if reader_:
        print(f"flexhrc's ANDOR text reader: {reader_}")
    head = f"{'graph':<22}{'metric':<11}{'flexhrc':>10}{'C++':>10}{'ratio':>8}  target  verdict"
    print(head)
    print("-" * len(head))
    for r in rows:
        print(
            f"{r['graph']!s:<22}{r['metric']!s:<11}{fmt(float(r['flexhrc_s'])):>10}"  # type: ignore[arg-type]
            f"{fmt(float(r['cpp_s'])):>10}{float(r['ratio']):>7.2f}x  "  # type: ignore[arg-type]
            f"<= {float(r['target']):.1f}x  {'PASS' if r['pass'] else 'FAIL'}"  # type: ignore[arg-type]
        )
    print()


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--anchors", type=Path, default=DEFAULT_ANCHORS)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "andor_paper.png")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--seeds", type=int, default=5, help="seeds of the parity runs (default 5)")
    ap.add_argument("--cpp", type=Path, default=None, help="the C++ andor_bench binary")
    ap.add_argument("--no-parity", action="store_true", help="skip the side-by-side parity")
    ap.add_argument("--parity-only", action="store_true", help="only the parity table")
    ap.add_argument(
        "--pure-python",
        action="store_true",
        help="flexhrc without its compiled reader (FLEXHRC_PURE_PYTHON=1) in the parity runs",
    )
    args = ap.parse_args()
    if args.seeds < 1:
        ap.error("--seeds must be at least 1")
    parity_failures = 0
    parity_rows: list[dict[str, object]] = []
    if not args.no_parity:
        if not args.anchors.is_dir():
            print(f"parity: skipped, {args.anchors} is not present", file=sys.stderr)
        else:
            cpp = find_cpp(args.cpp, args.anchors.parent / "andor-cpp")
            if cpp is None:
                print(
                    "parity: skipped, no C++ reference binary (build it with "
                    "../shared/anchors/andor-cpp/build.sh, or give --cpp)",
                    file=sys.stderr,
                )
            else:
                print(f"parity: {cpp} against flexhrc, {args.seeds} seeds", file=sys.stderr)
                parity_rows, parity_failures = parity(
                    args.anchors, cpp, args.seeds, args.pure_python
                )
                print_parity(parity_rows, args.seeds, reader(args.pure_python))
    if args.parity_only:
        if args.json and parity_rows:
            args.json.parent.mkdir(parents=True, exist_ok=True)
            args.json.write_text(json.dumps({"parity": parity_rows}, indent=2))
        return 1 if parity_failures else 0
    files = corpus(args.anchors)
    if not files:
        print(f"no graph files under {args.anchors}", file=sys.stderr)
        return 2
    rows = []
    t0 = time.perf_counter()
    for i, (label, path) in enumerate(files, 1):
        print(f"[{i}/{len(files)}] {label} ...", file=sys.stderr, flush=True)
        rows.append(measure(label, path, args.runs))
    print(f"measured in {time.perf_counter() - t0:.1f} s", file=sys.stderr)

    head = (
        f"{'graph':<22}{'elements':>9}{'queries':>8}  {'offline':>9} {'C++':>9} {'ratio':>16}  "
        f"{'per query':>10} {'C++':>9} {'ratio':>16}  targets"
    )
    print(head)
    print("-" * len(head))
    failures = 0
    for r in rows:
        cpp_off, cpp_q = CPP.get(r.label, (None, None))
        t_off, t_q = TARGETS.get(r.label, (None, None))
        verdicts = " ".join(v for v in (check(r.offline_s, t_off), check(r.per_query_s, t_q)) if v)
        failures += verdicts.count("FAIL")
        print(
            f"{r.label:<22}{r.size:>9}{r.queries:>8}  {fmt(r.offline_s):>9} {fmt(cpp_off):>9} "
            f"{ratio(r.offline_s, cpp_off):>16}  {fmt(r.per_query_s):>10} {fmt(cpp_q):>9} "
            f"{ratio(r.per_query_s, cpp_q):>16}  {verdicts}"
        )
    print()
    print("paper (i7-4790, ROS)      offline      online total   | flexhrc offline  online total")
    for label, (off, onl) in PAPER.items():
        r = next((r for r in rows if r.label == label), None)
        if r:
            print(
                f"  {label:<22}  {fmt(off):>9}  {fmt(onl):>12}   |  {fmt(r.offline_s):>12}  "
                f"{fmt(r.online_total_s):>12}"
            )
    fol = [r for r in rows if r.label.startswith("FOL ")]
    hier = [r for r in rows if r.label.startswith("hierarchical ")]
    allr = rows
    print()
    print("growth of the per-query time with graph size (log-log slope; 1 = linear):")
    for name, group in (
        ("single-layer FOL 1-10 legs", fol),
        ("hierarchical 1-10 legs", hier),
        ("all files", allr),
    ):
        if len(group) >= 3:
            s = slope(group)
            verdict = "at most linear" if s <= 1.1 else "SUPERLINEAR"
            print(f"  {name:<28} slope {s:.2f}  ({verdict})")
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(
            json.dumps({"parity": parity_rows, "corpus": [r.__dict__ for r in rows]}, indent=2)
        )
    try:
        plot(rows, args.out)
        print(f"\nplot: {args.out}")
    except ImportError:
        print("\n(matplotlib not installed: no plot)", file=sys.stderr)
    return 1 if failures or parity_failures else 0


if __name__ == "__main__":
    sys.exit(main())
