"""One scenario type: the ready-made tasks are builders of a Scenario, the older files convert
into one, and a scenario name (with --segments) means the same task in every command."""

from __future__ import annotations

import importlib
import json
from pathlib import Path
from typing import Any

import pytest

from flexhrc import scenario
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.scenario import Scenario
from flexhrc.scenario.builtin import BUILDERS, SEGMENTS, parallel_assembly, table_assembly

FAST = ["--simulator", "analytic", "--quiet", "--json"]


def _key(summary: dict[str, Any]) -> tuple[Any, ...]:
    return (
        [(x["hyperarc"], x["agent"]) for x in summary["solved_hyperarcs"]],
        summary["by_agent"],
        summary["timing"]["total_s"],
    )


def _cli(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, Any]:
    assert main(list(args)) == 0
    data: dict[str, Any] = json.loads(capsys.readouterr().out)
    return data


def _error(capsys: pytest.CaptureFixture[str], *args: str) -> str:
    assert main(list(args)) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    return err


# -- builders -----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("build", "roots"),
    [
        (lambda: table_assembly(), ("checked",)),
        (lambda: table_assembly(segments="legs"), ("connected_4",)),
        (lambda: table_assembly(segments="tabletop,legs"), ("connected_4",)),
        (lambda: table_assembly(segments=["legs", "check"]), ("checked",)),
        (lambda: table_assembly(segments="tabletop"), ("tabletop",)),
        (lambda: table_assembly(6, tabletop="0.6x0.6", human=False), ("connected_6",)),
        (lambda: table_assembly(2, unreachable_bolts=(2,), segments="legs"), ("connected_2",)),
        (lambda: parallel_assembly(3, 2, 5, human_legs=1), ("assembled",)),
        (lambda: parallel_assembly(2, 0, 4, chain=True), ("connected_4",)),
    ],
)
def test_every_builder_returns_a_scenario_that_validates_and_runs(build, roots) -> None:
    sc = build()
    assert isinstance(sc, Scenario)
    sc.graph.validate()
    assert str(sc.graph.top_graph.root) in roots
    assert sc.world() is not sc.world()  # fresh objects for every run
    result = scenario.run(sc, seed=1)
    assert result.summary["outcome"] == "solved", result.summary
    if sc.name == "table_assembly":
        assert sc.segments and set(sc.segments) <= set(SEGMENTS)


def test_the_builders_by_name() -> None:
    assert set(BUILDERS) == {"table_assembly", "parallel_assembly"}
    assert all(isinstance(b(), Scenario) for b in BUILDERS.values())


def test_the_default_table_is_the_shipped_file() -> None:
    built, shipped = table_assembly(), scenario.load("table_assembly")
    assert built.graph == shipped.graph
    for seed in (0, 3):
        a, b = scenario.run(built, seed=seed), scenario.run(shipped, seed=seed)
        assert _key(a.summary) == _key(b.summary)


def test_the_old_shapes_are_gone() -> None:
    assert not hasattr(scenario, "CellScenario")
    for gone in ("flexhrc.scenarios", "flexhrc.scenario.table"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(gone)
    from flexhrc.scenario.builtin import parallel, table

    for module, name in (
        (table, "TableScenario"),
        (table, "TableTask"),
        (parallel, "ParallelScenario"),
    ):
        assert not hasattr(module, name)


def test_bad_segments_name_the_ones_there_are() -> None:
    with pytest.raises(FlexhrcError, match=r"'legz' is not a segment .* tabletop, legs, check"):
        table_assembly(segments="legz")
    with pytest.raises(FlexhrcError, match="check needs an operator"):
        table_assembly(human=False, segments="legs,check")
    with pytest.raises(FlexhrcError, match="'legz' is not a segment"):
        scenario.load_scenario("table_assembly", segments="legz")
    with pytest.raises(FlexhrcError, match="'ball_in_box' has no segments"):
        scenario.load_scenario("ball_in_box", segments="legs")
    assert table_assembly(human=False).segments == ("tabletop", "legs")  # all: no check


def test_load_scenario_selects_segments() -> None:
    legs = scenario.load_scenario("table", segments="legs")
    assert legs.segments == ("legs",) and str(legs.graph.top_graph.root) == "connected_4"
    whole = scenario.load_scenario("table_assembly", segments="all")
    assert whole.path == scenario.shipped_path("table_assembly")
    path = str(scenario.shipped_path("table_assembly"))
    assert scenario.load_scenario(path, segments="legs").segments == ("legs",)
    assert scenario.load_scenario("ball_in_box", segments="all").name == "ball_in_box"


# -- the older files: one converter, identical runs ---------------------------------------------
# The figures are those `flexhrc run FILE --simulator analytic --seed S --json` printed on main
# before the builders replaced TableScenario (commit 9dcf135).
LEGACY = {
    "only_right": (
        "scenario: table_assembly\nlegs: 2\nreachable_only_by: {leg1: right, leg2: right}\n",
        0,
        ([("robot_1", "right"), ("robot_2", "right")], {"human": 0, "left": 0, "right": 2}),
        22.179129,
    ),
    "takeover": (
        "scenario: table_assembly\nunreachable_bolts: [2]\nprofile: takeover\n",
        2,
        (
            [
                ("human_1", "human"),
                ("human_2", "human"),
                ("human_3", "human"),
                ("human_4", "human"),
            ],
            {"human": 4, "left": 0, "right": 0},
        ),
        # was 29.798116: since issue 21 the operator carries each leg to its bolt before
        # screwing it (taskmanager.kinds._human_screw), 2.05 s of travel over the four legs
        31.846209,
    ),
    "six_legs": (
        "scenario: table_assembly\nlegs: 6\ntabletop: [0.6, 0.6]\nseed: 3\nhuman: false\n",
        0,
        (
            [
                ("robot_1", "left"),
                ("robot_2", "right"),
                ("robot_3", "right"),
                ("robot_4", "left"),
                ("robot_5", "right"),
                ("robot_6", "right"),
            ],
            {"left": 2, "right": 4},
        ),
        66.18024,
    ),
}


@pytest.mark.parametrize("name", sorted(LEGACY))
def test_older_files_run_as_before(name, tmp_path, capsys) -> None:
    text, seed, (solved, by_agent), total = LEGACY[name]
    f = tmp_path / "s.yaml"
    f.write_text(text)
    data = _cli(capsys, "run", str(f), "--seed", str(seed), *FAST)
    assert _key(data) == (solved, by_agent, total)
    # the converter is the one every command reads the file with
    sc = scenario.load_scenario(str(f))
    assert sc.segments == ("legs",) and sc.path == f


def test_an_older_bench_file_runs_as_before_in_the_cell_and_now_in_run(tmp_path, capsys) -> None:
    f = tmp_path / "bench.yaml"
    f.write_text("scenario: parallel_assembly\narms: 3\nhumans: 2\nlegs: 5\nhuman_legs: 1\n")
    expected = (
        [
            ("human_1", "op1"),
            ("human_5", "op2"),
            ("robot_2", "arm2"),
            ("robot_4", "arm3"),
            ("robot_3", "arm1"),
        ],
        {"arm1": 1, "arm2": 1, "arm3": 1, "op1": 1, "op2": 1},
        10.92409,
    )  # `flexhrc cell FILE --json` on main
    assert _key(_cli(capsys, "cell", str(f), "--quiet", "--json")) == expected
    assert _key(_cli(capsys, "run", str(f), "--quiet", "--json")) == expected


@pytest.mark.parametrize(
    ("body", "line", "expected"),
    [
        ("legz: 3\n", 2, "unknown key 'legz' (allowed: human, leg_length"),
        ("legs: 2.5\n", 2, "legs: expected a whole number, got 2.5"),
    ],
)
def test_older_file_errors_name_file_and_line_everywhere(body, line, expected, tmp_path) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\n" + body)
    with pytest.raises(FormatError) as exc:
        scenario.load_scenario(str(f))
    assert str(exc.value).startswith(f"{f}:{line}: ") and expected in str(exc.value)


def test_an_older_bench_file_names_its_bad_key(tmp_path) -> None:
    f = tmp_path / "b.yaml"
    f.write_text("scenario: parallel_assembly\narms: 3\nhumans: 99\n")
    with pytest.raises(FormatError, match=r"b.yaml:3: humans must be in 0..64, got 99"):
        scenario.load_scenario(str(f))
    f.write_text("scenario: parallel_assembly\nlegz: 3\n")
    with pytest.raises(FormatError, match=r"b.yaml:2: unknown key 'legz'"):
        scenario.load_scenario(str(f))


# -- one name, one task, in every command -------------------------------------------------------
def test_a_name_means_the_same_task_in_every_command(capsys) -> None:
    for segments in ([], ["--segments", "legs"]):
        runs = [
            _cli(capsys, "run", "table_assembly", *segments, *FAST),
            _cli(capsys, "run", "table", *segments, *FAST),
            _cli(capsys, "demo", "table", *segments, *FAST),
            _cli(capsys, "cell", "table_assembly", *segments, "--quiet", "--json"),
        ]
        keys = [_key(r) for r in runs]
        assert all(k == keys[0] for k in keys), keys
        first = [h for h, _ in keys[0][0]]
        if segments:
            assert first == ["robot_1", "robot_2", "robot_3", "robot_4"]
        else:
            assert first[0] == "place_tabletop" and first[-1] == "check_connections"


def test_segments_on_an_older_file(tmp_path, capsys) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("scenario: table_assembly\nlegs: 2\n")
    data = _cli(capsys, "run", str(f), "--segments", "all", *FAST)
    hyperarcs = [x["hyperarc"] for x in data["solved_hyperarcs"]]
    assert hyperarcs[0] == "place_tabletop" and hyperarcs[-1] == "check_connections"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "table_assembly", "--segments", "legz"], "'legz' is not a segment"),
        (["demo", "table", "--segments", "check"], "check needs legs"),
        (["cell", "table", "--segments", "legz"], "it has tabletop, legs, check (or all)"),
        (["run", "ball_in_box", "--segments", "legs"], "'ball_in_box' has no segments"),
    ],
)
def test_a_bad_segment_is_one_clear_error(args, message, capsys) -> None:
    assert message in _error(capsys, *args, "--quiet")


def test_every_front_end_takes_segments() -> None:
    import argparse

    from flexhrc.cli import build_parser

    parser: argparse.ArgumentParser = build_parser()
    for argv in (
        ["run", "table", "--segments", "legs"],
        ["demo", "table", "--segments", "legs"],
        ["cell", "table", "--segments", "legs"],
        ["agent", "robot", "table", "--segments", "legs", "--arm", "left"],
        ["agent", "human", "table", "--segments", "legs", "--name", "human"],
        ["panel", "--segments", "legs", "--web", "127.0.0.1:0"],
        ["ros2", "cell", "table", "--segments", "legs"],
        ["ros2", "arm", "table", "--segments", "legs", "--arm", "left"],
        ["ros2", "human", "table", "--segments", "legs", "--name", "human"],
    ):
        assert parser.parse_args(argv).segments == "legs", argv


def test_the_package_data_moved_with_the_code() -> None:
    root = Path(scenario.__file__).parent / "builtin" / "data"
    for name in scenario.SHIPPED:
        assert scenario.shipped_path(name) == root / name / f"{name}.yaml"
    pyproject = Path(__file__).parents[2] / "pyproject.toml"
    if pyproject.exists():
        assert '"scenario/builtin/data/**/*"' in pyproject.read_text()
