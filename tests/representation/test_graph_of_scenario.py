"""Every `flexhrc graph` command takes a scenario file (its graph) as well as a graph file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from flexhrc import scenario
from flexhrc.cli import main
from flexhrc.errors import FormatError
from flexhrc.representation import load
from flexhrc.scenario.starter import STARTER

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def scenario_file(tmp_path: Path) -> Path:
    """The starter: a scenario file with an inline ``graphs:`` block."""
    path = tmp_path / "scenario.yaml"
    path.write_text(STARTER, encoding="utf-8")
    return path


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, object]:
    code = main([*argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def line_of(path: Path, needle: str) -> int:
    return next(i for i, t in enumerate(path.read_text().splitlines(), 1) if needle in t)


def test_graph_of_a_scenario_is_its_inline_graph(scenario_file):
    h = scenario.graph_of(scenario_file)
    assert h.top == "my_task"
    assert sorted(h.top_graph.nodes) == ["bracket_placed", "done", "parts_ready", "screw_placed"]
    assert h.top_graph.hyperarcs["tighten"].actions == ("tighten(human, screw)",)
    assert scenario.is_scenario_file(scenario_file)


def test_graph_of_a_graph_file_is_load(tmp_path):
    path = ROOT / "examples" / "graphs" / "ball_in_box.yaml"
    assert not scenario.is_scenario_file(path)
    assert scenario.graph_of(path).stats() == load(path).stats()


def test_graph_of_a_scenario_with_a_graph_file_and_hyperarc_actions():
    # ball_in_box: the authors' ANDOR text graph, actions attached by hyperarc_actions
    path = scenario.shipped_path("ball_in_box")
    h = scenario.graph_of(path)
    assert h.stats() == scenario.load(path).graph.stats()
    assert all(a.actions for a in h.top_graph.hyperarcs.values())


def test_graph_of_a_scenario_whose_inline_graph_includes_files():
    # an inline graphs: block with file: references (they were read with a wrong argument)
    path = ROOT / "src/flexhrc/scenario/builtin/data/kitchen_drawer/kitchen_drawer.graph.yaml"
    assert scenario.graph_of(path).stats()["graphs"] == 4


def test_validate(capsys, scenario_file):
    code, rep = run_json(capsys, "graph", "validate", str(scenario_file))
    assert code == 0
    assert rep["valid"] and rep["solvable"] and rep["nodes"] == 4 and rep["hyperarcs"] == 3


def test_stats(capsys, scenario_file):
    code, st = run_json(capsys, "graph", "stats", str(scenario_file))
    assert code == 0 and st["graphs"] == 1 and st["instantiated_hyperarcs"] == 3
    assert st["optimal_cost"] == 3


def test_suggest(capsys, scenario_file):
    code, rows = run_json(capsys, "graph", "suggest", str(scenario_file), "--met", "parts_ready")
    assert code == 0
    assert [(r["element"], r["kind"]) for r in rows] == [("place_bracket", "hyperarc")]


def test_play(capsys, scenario_file, tmp_path):
    events = tmp_path / "events.jsonl"
    code, rep = run_json(
        capsys, "graph", "play", str(scenario_file), "--steps", "--events", str(events)
    )
    assert code == 0 and rep["outcome"] == "solved"
    assert [s["element"] for s in rep["steps"]][:2] == ["parts_ready", "place_bracket"]
    assert events.read_text().count("\n") == len(rep["steps"])


def test_render(capsys, scenario_file, tmp_path):
    out = tmp_path / "g.dot"
    code, rep = run_json(
        capsys, "graph", "render", str(scenario_file), "-o", str(out), "--met", "parts_ready"
    )
    assert code == 0 and rep["nodes"] == 4 and rep["statuses"]
    text = out.read_text()
    assert text.startswith("digraph") and "place_bracket" in text and "tighten" in text


def test_render_refuses_to_overwrite_the_scenario(capsys, scenario_file):
    before = scenario_file.read_text()
    assert main(["graph", "render", str(scenario_file), "-o", str(scenario_file)]) == 2
    assert scenario_file.read_text() == before
    capsys.readouterr()


def test_to_task(capsys, scenario_file):
    code, rep = run_json(capsys, "graph", "to-task", str(scenario_file))
    assert code == 0 and rep["task"] == "(THEN place_bracket place_screw tighten)"


def test_only_the_graph_is_read(capsys, scenario_file):
    # the graph commands need the graph; the rest is `flexhrc scenario validate`'s business
    scenario_file.write_text(STARTER.replace("kind: robot", "kind: robt"), encoding="utf-8")
    assert main(["graph", "validate", str(scenario_file)]) == 0
    assert main(["scenario", "validate", str(scenario_file)]) == 2
    capsys.readouterr()


COMMANDS = [
    ["validate"],
    ["stats"],
    ["suggest"],
    ["play"],
    ["render", "-o", "OUT"],
    ["to-task"],
]


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
def test_a_scenario_whose_graph_has_an_error_is_one_line_exit_2(
    capsys, scenario_file, tmp_path, command
):
    scenario_file.write_text(
        STARTER.replace("children: [screw_placed]", "children: [screw_plaed]"), encoding="utf-8"
    )
    argv = [str(tmp_path / "g.dot") if a == "OUT" else a for a in command]
    assert main(["graph", argv[0], str(scenario_file), *argv[1:]]) == 2
    out = capsys.readouterr()
    line = line_of(scenario_file, "- name: tighten")
    assert out.out == ""
    assert out.err.splitlines() == [
        f"error: {scenario_file}:{line}: hyper-arc 'tighten': unknown child node 'screw_plaed'"
    ]
    assert not (tmp_path / "g.dot").exists()


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: c[0])
def test_a_scenario_with_a_syntax_error_is_one_line_exit_2(capsys, tmp_path, command):
    path = tmp_path / "broken.yaml"
    path.write_text("flexhrc: 1\nname: broken\ngraphs: [\n", encoding="utf-8")
    argv = [str(tmp_path / "g.dot") if a == "OUT" else a for a in command]
    assert main(["graph", argv[0], str(path), *argv[1:]]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {path}:4: YAML syntax error")


def test_a_scenario_whose_graph_file_is_missing(capsys, tmp_path):
    path = tmp_path / "task.yaml"
    path.write_text("flexhrc: 1\nname: t\ngraph: nowhere.yaml\n", encoding="utf-8")
    assert main(["graph", "validate", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"error: {path}:3: graph file 'nowhere.yaml' not found (looked for {tmp_path}/nowhere.yaml)"
    ]
    with pytest.raises(FormatError):
        scenario.graph_of(path)
