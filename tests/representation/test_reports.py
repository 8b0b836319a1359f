"""``flexhrc.representation.reports``: each report equals what ``flexhrc graph ... --json``
prints for the same arguments, so a library user gets what the command gives."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from flexhrc.cli import main
from flexhrc.representation import reports
from flexhrc.scenario import graph_of

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
GRAPH = EXAMPLES / "graphs" / "table_2legs.txt"
SCENARIO = EXAMPLES / "scenarios" / "gearbox.yaml"


def _json(capsys, *argv: str):
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("file", [GRAPH, SCENARIO], ids=["graph", "scenario"])
def test_validation_and_statistics_equal_the_commands(capsys, file):
    graph = graph_of(file)
    assert reports.validation(graph, str(file)) == _json(capsys, "graph", "validate", str(file))
    assert reports.statistics(graph) == _json(capsys, "graph", "stats", str(file))


def test_path_counts_equal_graph_stats_paths(capsys):
    file = EXAMPLES / "graphs" / "connect_leg.txt"
    report = reports.statistics(graph_of(file), paths=True)
    assert report == _json(capsys, "graph", "stats", str(file), "--paths")
    assert sum(report["paths"].values()) > 0


@pytest.mark.parametrize("exact", [False, True])
def test_suggestions_equal_graph_suggest(capsys, exact):
    result, rows = reports.suggestions(graph_of(GRAPH), met=["Plate_initialPose"], exact=exact)
    argv = ["graph", "suggest", str(GRAPH), "--met", "Plate_initialPose"]
    assert result.outcome == "running" and rows
    assert rows == _json(capsys, *argv, *(["--exact"] if exact else []))
    assert [r["cost"] for r in rows] == sorted(r["cost"] for r in rows)


def test_render_graph_writes_the_file_and_equals_graph_render(capsys, tmp_path):
    out = tmp_path / "lib.dot"
    report = reports.render_graph(graph_of(GRAPH), out, file=str(GRAPH), met=["Plate_initialPose"])
    assert out.read_text().startswith("digraph")
    cli = _json(capsys, "graph", "render", str(GRAPH), "-o", str(tmp_path / "cli.dot"),
                "--met", "Plate_initialPose")  # fmt: skip
    assert report | {"output": ""} == cli | {"output": ""}
    assert report["statuses"] is True and report["format"] == "dot"


def test_render_graph_refuses_an_output_it_cannot_write(tmp_path):
    from flexhrc.errors import FlexhrcError

    with pytest.raises(FlexhrcError, match=r"\.svg"):
        reports.render_graph(graph_of(GRAPH), tmp_path / "g.jpg", file=str(GRAPH))
    assert not (tmp_path / "g.jpg").exists()
