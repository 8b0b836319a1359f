"""`flexhrc experiment`: a design runs end to end, its files, its config's faults, its folder."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import pytest
import yaml

from flexhrc.app import RunConfig, run_scenario
from flexhrc.app import experiment as ex
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError, FormatError

REPO = Path(__file__).resolve().parents[2]
GEARBOX = REPO / "examples" / "scenarios" / "gearbox.yaml"

TINY = f"""\
experiment: 1
name: tiny
scenarios:
  - ball_in_box
  - {GEARBOX}
  - name: gen
    generate: {{actions: 6, agents: 3, width: 2, seed: 1}}
profiles: [passive, reluctant]
policies: [paper]
seeds: 2
"""


def _write(tmp_path: Path, text: str, name: str = "exp.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def _csv(path: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(path.read_text())))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """The tiny design, run once in two processes (the pool's path)."""
    tmp = tmp_path_factory.mktemp("exp")
    config = _write(tmp, TINY)
    out = tmp / "out"
    seen: list[tuple[int, int]] = []
    report = ex.run_experiment(config, out, jobs=2, progress=lambda d, t: seen.append((d, t)))
    return report, out, seen


def test_a_tiny_design_writes_every_file_with_its_columns(tiny_run):
    report, out, seen = tiny_run
    assert sorted(p.name for p in out.iterdir()) == sorted([*ex.OUTPUT_FILES, "scenarios"])
    assert (out / "scenarios" / "gen.yaml").is_file()  # the generated task, to run again
    rows = _csv(out / "runs.csv")
    assert list(rows[0]) == list(ex.RUN_COLUMNS)
    assert len(rows) == 3 * 2 * 1 * 2 == report.json["runs"]
    assert [int(r["run"]) for r in rows] == list(range(1, 13))
    assert all(r["outcome"] == "solved" and not r["error"] for r in rows)
    for r in rows:
        busy, idle = json.loads(r["busy_by_agent"]), json.loads(r["idle_by_agent"])
        assert set(busy) == set(idle)
        for a in busy:  # busy + idle = makespan for every agent
            assert busy[a] + idle[a] == pytest.approx(float(r["makespan_s"]), abs=1e-5)
        assert 0 <= float(r["idle_share"]) <= 1 and 0 <= float(r["person_share"]) <= 1
        assert float(r["latency_p95_ms"]) >= float(r["latency_median_ms"]) > 0
    cells = _csv(out / "summary.csv")
    assert len(cells) == 3 * 2  # scenarios x profiles (x 1 policy x 1 utility)
    for m in ex.SUMMARY_METRICS:
        for suffix in ("median", "q1", "q3"):
            assert f"{m}_{suffix}" in cells[0]
    for c in cells:
        assert c["runs"] == "2" and c["solved"] == "2"
        assert float(c["makespan_s_q1"]) <= float(c["makespan_s_median"])
        assert float(c["makespan_s_median"]) <= float(c["makespan_s_q3"])
    md = (out / "summary.md").read_text()
    assert "| ball_in_box | passive | paper | 2/2 |" in md
    for png in ("makespan.png", "idle.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads((out / "experiment.json").read_text())
    assert doc == report.json
    assert doc["design"]["profiles"] == ["passive", "reluctant"]
    assert doc["cells"] == report.cells and doc["solved"] == 12
    assert seen[-1][0] == seen[-1][1] and seen[0][0] == 0  # the progress reached its end


def test_a_row_is_what_flexhrc_run_reports(tiny_run):
    report, _, _ = tiny_run
    row = next(
        r
        for r in report.rows
        if r["scenario"] == "ball_in_box" and r["seed"] == 1 and r["profile"] == "reluctant"
    )
    same = run_scenario(RunConfig("ball_in_box", human="reluctant", seed=1, quiet=True))
    assert row["makespan_s"] == pytest.approx(same.json["timing"]["total_s"], abs=1e-6)
    assert row["decisions"] == same.json["decisions"]
    declines = sum(1 for e in same.result.events if e["type"] == "human_declined")
    assert row["declines"] == declines


def test_busy_time_is_the_union_of_an_agents_actions():
    class Agent:
        def __init__(self, human):
            self.is_human = human

    class Domain:
        def __init__(self):
            self.agents = {"arm": Agent(False), "op": Agent(True)}

    class Sc:
        def __init__(self):
            self.domain = Domain()

    events = [
        {"type": "action_end", "agents": ["arm"], "start": 0.0, "t": 2.0},
        {"type": "action_end", "agents": ["arm"], "start": 1.0, "t": 3.0},  # overlaps
        {"type": "action_end", "agents": ["arm", "op"], "start": 5.0, "t": 6.0},  # joint
        {"type": "stop", "agent": "arm"},
        {"type": "abort"},
        {"type": "human_declined", "agent": "op"},
    ]
    summary = {"outcome": "solved", "timing": {"total_s": 10.0}, "decisions": 2}
    m = ex.metrics(summary, events, Sc(), {"median_s": 0.001, "p95_s": 0.002})
    assert m["busy_by_agent"] == {"arm": 4.0, "op": 1.0}
    assert m["arm_idle_s"] == 6.0 and m["person_idle_s"] == 9.0
    assert m["idle_share"] == pytest.approx(15 / 20)
    assert m["person_share"] == pytest.approx(1 / 5)
    assert (m["stops"], m["replans"], m["declines"]) == (1, 1, 1)
    assert (m["latency_median_ms"], m["latency_p95_ms"]) == (1.0, 2.0)


def test_a_failed_run_is_a_row_with_its_error(tmp_path, monkeypatch):
    import flexhrc.app.run as run_mod

    real = run_mod.run_scenario

    def flaky(config, **kw):
        if config.seed == 1:
            raise RuntimeError("the simulator fell over")
        return real(config, **kw)

    monkeypatch.setattr(run_mod, "run_scenario", flaky)
    config = _write(tmp_path, "experiment: 1\nscenarios: [ball_in_box]\nseeds: 2\n")
    report = ex.run_experiment(config, tmp_path / "out", jobs=1)
    rows = _csv(tmp_path / "out" / "runs.csv")
    assert [r["outcome"] for r in rows] == ["solved", "error"]
    assert "RuntimeError: the simulator fell over" in rows[1]["error"]
    assert report.cells[0]["runs"] == 2 and report.cells[0]["errors"] == 1
    assert any("seed 1" in n and "fell over" in n for n in report.notes)


def test_utilities_are_an_axis_of_the_design(tmp_path):
    config = _write(
        tmp_path,
        "experiment: 1\nscenarios: [ball_in_box]\nseeds: [3]\n"
        "utilities:\n  paper: null\n  fair: {success: 1, time: 1, workload: 2}\n",
    )
    report = ex.run_experiment(config, tmp_path / "out", jobs=1)
    assert [r["utility"] for r in report.rows] == ["paper", "fair"]
    assert all(r["outcome"] == "solved" for r in report.rows)
    assert "| utility |" in (tmp_path / "out" / "summary.md").read_text()


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("experiment: 2\nscenarios: [ball_in_box]\n", 1, "experiment: 1 is required"),
        ("experiment: 1\nscenarios: [ball_in_box]\nprofile: [passive]\n", 3, "unknown key"),
        ("experiment: 1\nscenarios: [ball_in_box]\nprofiles: [lazy]\n", 3, "unknown 'lazy'"),
        ("experiment: 1\nscenarios: [ball_in_box]\npolicies: [greedy]\n", 3, "unknown 'greedy'"),
        ("experiment: 1\nscenarios: [ball_in_box]\nseeds: 0\n", 3, "seeds must be a count"),
        ("experiment: 1\nscenarios: [ball_in_box]\nseeds: [1, 1]\n", 3, "listed twice"),
        ("experiment: 1\nscenarios:\n  - nowhere.yaml\n", 3, "no shipped scenario"),
        (
            "experiment: 1\nscenarios:\n  - generate: {actions: 4, agents: 3, width: 9}\n",
            3,
            "width must be a whole number in 1..4",
        ),
        ("experiment: 1\nscenarios:\n  - generate: {actions: 4}\n", 3, "needs agents, width"),
        ("experiment: 1\nscenarios:\n  - {file: ball_in_box, colour: red}\n", 3, "unknown key"),
        ("experiment: 1\nscenarios: [ball_in_box, ball_in_box]\n", 2, "listed twice"),
        ("experiment: 1\nprofiles: [passive]\n", 1, "scenarios: is required"),
        (
            "experiment: 1\nscenarios:\n  - {name: ../x, file: ball_in_box}\n",
            3,
            "name must be a word",
        ),
        (
            "experiment: 1\nscenarios: [ball_in_box]\nutilities:\n  x: {speed: 1}\n",
            4,
            "unknown key 'speed'",
        ),
        (
            "experiment: 1\nscenarios: [ball_in_box]\nreference: {time_limit_s: -1}\n",
            3,
            "time_limit_s must be",
        ),
    ],
)
def test_a_bad_config_is_one_file_line_error_and_exit_2(tmp_path, capsys, text, line, words):
    config = _write(tmp_path, text)
    with pytest.raises(FormatError) as err:
        ex.read_config(config)
    assert err.value.line == line and words in str(err.value)
    assert main(["experiment", str(config), "-o", str(tmp_path / "out")]) == 2
    msg = capsys.readouterr().err.strip()
    assert msg.startswith(f"error: {config}:{line}: ") and words in msg
    assert len(msg.splitlines()) == 1
    assert not (tmp_path / "out").exists()  # nothing was started


def test_a_scenario_that_does_not_load_is_its_config_line(tmp_path, capsys):
    bad = _write(tmp_path, "flexhrc: 1\nname: broken\n", "broken.yaml")
    config = _write(tmp_path, f"experiment: 1\nscenarios:\n  - ok: 1\n  - file: {bad}\n")
    with pytest.raises(FormatError, match="unknown key 'ok'"):
        ex.read_config(config)
    config = _write(tmp_path, f"experiment: 1\nscenarios:\n  - file: {bad}\n")
    assert main(["experiment", str(config), "-o", str(tmp_path / "out")]) == 2
    assert f"{config}:3: scenario 'broken'" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_output_folder_is_checked_before_the_work(tmp_path, capsys, monkeypatch):
    def boom(task):
        raise AssertionError("a run started before the folder was checked")

    monkeypatch.setattr(ex, "run_one", boom)
    config = _write(tmp_path, "experiment: 1\nscenarios: [ball_in_box]\n")
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("mine")
    argv = ["experiment", str(config), "--jobs", "1", "-o"]
    assert main([*argv, str(full)]) == 2
    assert "folder is not empty (use --force" in capsys.readouterr().err
    assert (full / "keep.txt").read_text() == "mine"
    assert main([*argv, str(config)]) == 2
    assert "exists and is not a folder" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "no" / "such")]) == 2
    assert "does not exist" in capsys.readouterr().err
    with pytest.raises(FlexhrcError, match="--jobs"):
        ex.run_experiment(config, tmp_path / "new", jobs=0)


def test_force_writes_into_a_folder_with_files(tmp_path, capsys):
    config = _write(tmp_path, "experiment: 1\nscenarios: [ball_in_box]\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    code = main(["experiment", str(config), "-o", str(out), "--jobs", "1", "--force", "--json"])
    assert code == 0
    cap = capsys.readouterr()
    doc = json.loads(cap.out)
    assert doc["runs"] == 1 and doc["solved"] == 1
    assert (out / "notes.txt").read_text() == "mine"  # nothing else is touched
    assert "] 2/2 100%" in cap.err or "] 1/1 100%" in cap.err  # the progress bar, on stderr


def test_the_shipped_example_is_a_valid_4x2x2x10_design():
    config = ex.read_config(REPO / "examples" / "experiment.yaml")
    assert (len(config.scenarios), len(config.profiles), len(config.policies)) == (4, 2, 2)
    assert len(config.seeds) == 10 and config.runs == 160
    assert any(s.generate for s in config.scenarios)
    yaml.safe_load((REPO / "examples" / "experiment.yaml").read_text())


def test_the_progress_bar_prints_lines_when_not_a_terminal():
    buf = io.StringIO()
    bar = ex.ProgressBar(buf)
    for i in range(0, 21):
        bar(i, 20)
    lines = buf.getvalue().splitlines()
    assert 5 <= len(lines) <= 12  # about one per tenth, and the end
    assert lines[-1].startswith("runs [##############################] 20/20 100%")


def test_latency_figures():
    from flexhrc.cell.supervisor import latency_figures

    assert latency_figures([]) == {"n": 0, "median_s": None, "p95_s": None, "max_s": None}
    f = latency_figures([0.003, 0.001, 0.002, 0.004])
    assert f["n"] == 4 and f["median_s"] == pytest.approx(0.0025) and f["max_s"] == 0.004
    assert latency_figures([float(i) for i in range(1, 101)])["p95_s"] == 95.0


@pytest.mark.skipif(not ex.can_solve(), reason="flexhrc.planning cannot solve (no OR-tools)")
def test_the_cp_sat_optimum_is_the_reference_where_it_can_be_solved(tmp_path):
    config = _write(tmp_path, "experiment: 1\nscenarios: [ball_in_box, kitchen_drawer]\n")
    report = ex.run_experiment(config, tmp_path / "out", jobs=1)
    ref = report.json["reference"]["ball_in_box"]
    assert ref["status"] == "optimal" and ref["makespan_s"] > 0
    assert ref["makespan_s"] == pytest.approx(ref["bound"])
    cell = report.cells[0]
    assert cell["optimum_s"] == pytest.approx(ref["makespan_s"], abs=1e-4)
    assert cell["makespan_ratio"] == pytest.approx(
        cell["makespan_s_median"] / ref["makespan_s"], abs=1e-3
    )
    # a hierarchy of graphs (three layers) is planned through its lower instances
    drawer = report.json["reference"]["kitchen_drawer"]
    assert drawer["status"] == "optimal" and drawer["makespan_s"] > 0


@pytest.mark.skipif(not ex.can_solve(), reason="flexhrc.planning cannot solve (no OR-tools)")
def test_a_scenario_the_planner_cannot_model_has_no_line_and_the_notes_say_why(
    tmp_path, monkeypatch
):
    import flexhrc.planning
    from flexhrc.errors import FlexhrcError

    real = flexhrc.planning.solve

    def solve(scenario, **kw):
        if scenario.name == "kitchen_drawer":
            raise FlexhrcError("plan: not modelled yet")
        return real(scenario, **kw)

    monkeypatch.setattr(flexhrc.planning, "solve", solve)
    config = _write(tmp_path, "experiment: 1\nscenarios: [ball_in_box, kitchen_drawer]\n")
    report = ex.run_experiment(config, tmp_path / "out", jobs=1)
    assert report.json["reference"]["ball_in_box"]["status"] == "optimal"
    assert "kitchen_drawer" not in report.json["reference"]
    assert any(n.startswith("kitchen_drawer: no CP-SAT optimum") for n in report.notes)
