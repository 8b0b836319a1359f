"""`scenario validate`: a hyper-arc whose actions never make its parent's formula true."""

from __future__ import annotations

from pathlib import Path

import pytest

from flexhrc import scenario
from flexhrc.cli import main
from flexhrc.scenario.starter import STARTER

from .helpers import line_of

ROOT = Path(__file__).resolve().parents[2]

#: the issue's case: the cover is put on the housing, nothing closes it
COVER = """\
flexhrc: 1
name: cover_task
graphs:
  cover_task:
    root: cover_on
    nodes:
      - {name: ready, state: "on_table(cover)"}
      - {name: cover_on, state: "on(cover, housing) & closed(housing)"}
    hyperarcs:
      - name: put_cover
        children: [ready]
        parent: cover_on
        weight: 1
        actions: ["pick(?who, cover)", "put(?who, cover, housing)"]
domain:
  agents:
    human: {kind: human, types: [human], hand: [1.0, 0.0, 0.1]}
    arm: {kind: robot, types: [robot], base: [0.0, 0.0, 0.4], rest: [0.3, 0.0, 0.5], reach: 0.9}
  actions:
    pick:
      parameters: {"?who": agent, "?p": part}
      agents: {choice: "?who"}
      pre: ["on_table(?p)", "free(?who)"]
      add: ["holding(?who, ?p)"]
      delete: ["on_table(?p)", "free(?who)"]
      duration: 1.0
    put:
      parameters: {"?who": agent, "?p": part, "?on": part}
      agents: {choice: "?who"}
      pre: ["holding(?who, ?p)"]
      add: ["on(?p, ?on)", "free(?who)"]
      delete: ["holding(?who, ?p)"]
      duration: 1.0
    close:
      parameters: {"?who": agent, "?x": part}
      agents: {choice: "?who"}
      add: ["closed(?x)"]
      duration: 1.0
world:
  objects:
    cover: {type: part, position: [0.4, 0.2, 0.0]}
    housing: {type: part, position: [0.5, 0.0, 0.0]}
  places:
    bench: [0.6, 0.0, 0.0]
  facts: ["on_table(cover)", "free(arm)", "free(human)"]
humans:
  - {name: human, profile: passive, speed: 1.0}
"""
PUT = '"put(?who, cover, housing)"]'


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "cover.yaml"
    path.write_text(text, encoding="utf-8")
    return path


def _validate(capsys: pytest.CaptureFixture[str], path: Path) -> tuple[int, list[str]]:
    code = main(["scenario", "validate", str(path)])
    return code, capsys.readouterr().err.strip().splitlines()


def test_the_issue_case_is_one_error_on_the_hyper_arcs_line(tmp_path, capsys):
    path = _write(tmp_path, COVER)
    code, err = _validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '- name: put_cover')}: hyper-arc put_cover: its actions never "
        "make 'closed(housing)' true (node cover_on)"
    ]
    faults = [f for f in scenario.validate(path) if f.severity == "error"]
    assert [(f.line, f.message) for f in faults] == [
        (
            line_of(path, "- name: put_cover"),
            "hyper-arc put_cover: its actions never make 'closed(housing)' true (node cover_on)",
        )
    ]


def test_an_action_that_adds_it_through_a_variable_binding_validates_clean(tmp_path, capsys):
    path = _write(tmp_path, COVER.replace(PUT, PUT[:-1] + ', "close(?who, ?lid)"]'))
    code, err = _validate(capsys, path)
    assert (code, err) == (0, [])


def test_a_binding_of_the_wrong_type_never_makes_it_true(tmp_path, capsys):
    # ?lid is typed place by close's parameter: housing (a part) can never be bound to it
    text = COVER.replace(PUT, PUT[:-1] + ', "close(?who, ?lid)"]')
    text = text.replace('{"?who": agent, "?x": part}', '{"?who": agent, "?x": place}')
    path = _write(tmp_path, text)
    code, err = _validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '- name: put_cover')}: hyper-arc put_cover: its actions never "
        "make 'closed(housing)' true (node cover_on)"
    ]


def test_a_fact_true_from_the_start_needs_no_action(tmp_path, capsys):
    text = COVER.replace('"free(human)"]', '"free(human)", "closed(housing)"]')
    code, err = _validate(capsys, _write(tmp_path, text))
    assert (code, err) == (0, [])


def test_an_alternative_into_the_same_node_may_make_it_true(tmp_path, capsys):
    # another hyper-arc into cover_on closes the housing: the node can be met (not "never")
    text = COVER.replace(
        "domain:\n",
        "      - name: close_it\n"
        "        children: [ready]\n"
        "        parent: cover_on\n"
        "        weight: 2\n"
        '        actions: ["close(?who, housing)"]\n'
        "domain:\n",
    )
    code, err = _validate(capsys, _write(tmp_path, text))
    assert (code, err) == (0, [])


def test_a_later_hyper_arc_does_not_count(tmp_path, capsys):
    # a hyper-arc that needs cover_on met first cannot help to meet it
    text = COVER.replace("root: cover_on", "root: sealed").replace(
        '      - {name: cover_on, state: "on(cover, housing) & closed(housing)"}\n',
        '      - {name: cover_on, state: "on(cover, housing) & closed(housing)"}\n'
        '      - {name: sealed, state: "closed(housing)"}\n',
    )
    text = text.replace(
        "domain:\n",
        "      - name: seal\n"
        "        children: [cover_on]\n"
        "        parent: sealed\n"
        "        weight: 1\n"
        '        actions: ["close(?who, housing)"]\n'
        "domain:\n",
    )
    path = _write(tmp_path, text)
    code, err = _validate(capsys, path)
    assert code == 2
    assert err == [
        f"{path}:{line_of(path, '- name: put_cover')}: hyper-arc put_cover: its actions never "
        "make 'closed(housing)' true (node cover_on)"
    ]


SHIPPED = [*(scenario.shipped_path(n) for n in scenario.SHIPPED)]
EXAMPLES = sorted((ROOT / "examples" / "scenarios").glob("*.yaml")) + sorted(
    (ROOT / "examples" / "compiled_task").glob("*.scenario.yaml")
)


@pytest.mark.parametrize("path", [*SHIPPED, *EXAMPLES], ids=lambda p: p.name)
def test_shipped_and_example_scenarios_validate_clean(path):
    assert [str(f) for f in scenario.validate(path) if f.severity == "error"] == []


def test_the_starter_validates_clean(tmp_path):
    path = tmp_path / "scenario.yaml"
    path.write_text(STARTER, encoding="utf-8")
    assert [str(f) for f in scenario.validate(path) if f.severity == "error"] == []


def test_the_error_names_the_graph_file_and_its_line(tmp_path, capsys):
    # the graph in a file of its own: FILE:LINE is that file's
    head, rest = COVER.split("graphs:\n", 1)
    graph_text, domain = rest.split("domain:\n", 1)
    graph = tmp_path / "cover.graph.yaml"
    graph.write_text("flexhrc: 1\ngraphs:\n" + graph_text, encoding="utf-8")
    path = _write(tmp_path, head + "graph: cover.graph.yaml\ndomain:\n" + domain)
    code, err = _validate(capsys, path)
    assert code == 2
    assert err == [
        f"{graph}:{line_of(graph, '- name: put_cover')}: hyper-arc put_cover: its actions never "
        "make 'closed(housing)' true (node cover_on)"
    ]
