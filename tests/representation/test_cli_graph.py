"""The `flexhrc graph` commands and their JSON contract."""

from __future__ import annotations

import json
import shutil

import pytest

from flexhrc.cli import main

TWO_LEGS = """\
TableAssembly 5 Table_FinalPose
Plate_initPose 0
Plate_assemblyPose 0
Leg1_T 0
Leg1_Plate_connected 0
Table_FinalPose 0
h0 1 Plate_assemblyPose 1 -
Plate_initPose
h1 2 Leg1_Plate_connected 1 basic_connection
Leg1_T
Plate_assemblyPose
h21 1 Table_FinalPose 1 -
Leg1_Plate_connected
"""

BASIC = """\
ConnectLegPlate 4 Leg_Plate_Connected
Leg_Plate_Connected 0
Leg_T 0
Leg_middlePose 0
Plate 0
h1 2 Leg_middlePose 2 -
Leg_T
Plate
h2 2 Leg_Plate_Connected 1 -
Leg_T
Plate
h3 1 Leg_Plate_Connected 1 -
Leg_middlePose
"""


@pytest.fixture
def graph_file(tmp_path):
    (tmp_path / "basic_connection.txt").write_text(BASIC)
    top = tmp_path / "table.txt"
    top.write_text(TWO_LEGS)
    return top


def run_json(capsys, *argv):
    code = main([*argv, "--json"])
    out = capsys.readouterr().out
    return code, json.loads(out)


def test_stats_json_keys(capsys, graph_file):
    code, st = run_json(capsys, "graph", "stats", str(graph_file))
    assert code == 0
    for key in (
        "graphs",
        "nodes",
        "hyperarcs",
        "layers",
        "instantiated_nodes",
        "instantiated_hyperarcs",
    ):
        assert key in st
    assert (st["graphs"], st["layers"], st["nodes"], st["hyperarcs"]) == (2, 2, 9, 6)
    assert (st["instantiated_nodes"], st["instantiated_hyperarcs"]) == (9, 6)


# the top graph up to the lower-graph instance of h1
TOP_DONE = ["--met", "Plate_initPose", "--met", "Leg1_T", "--solved", "h0",
            "--met", "Plate_assemblyPose"]  # fmt: skip
LOWER_LEAVES = ["--met", "h1/Leg_T", "--met", "h1/Plate"]


def test_suggest_json_contract_and_qualified_names(capsys, graph_file):
    code, rows = run_json(capsys, "graph", "suggest", str(graph_file), *TOP_DONE)
    assert code == 0
    assert all(set(r) == {"element", "kind", "cost", "graph"} for r in rows)
    assert {r["element"] for r in rows} == {"h1/Leg_T", "h1/Plate"}
    assert {r["graph"] for r in rows} == {"h1"}
    # cheapest lower path: h2 (1); upper: + h21 1 -> 2
    assert rows[0]["cost"] == 2 and rows[0]["kind"] == "node"
    code, rows = run_json(capsys, "graph", "suggest", str(graph_file), *TOP_DONE, *LOWER_LEAVES)
    assert rows[0] == {"element": "h1/h2", "kind": "hyperarc", "cost": 2, "graph": "h1"}
    code, exact = run_json(
        capsys, "graph", "suggest", str(graph_file), "--exact", *TOP_DONE, *LOWER_LEAVES
    )
    assert exact == rows


def test_suggest_unknown_name_exit_2(capsys, graph_file):
    assert main(["graph", "suggest", str(graph_file), "--met", "h1/Nope"]) == 2
    assert "unknown element 'h1/Nope'" in capsys.readouterr().err


@pytest.mark.parametrize("policy", ["cheapest", "random"])
def test_play_json_contract(capsys, graph_file, policy):
    code, rep = run_json(
        capsys, "graph", "play", str(graph_file), "--policy", policy, "--seed", "4"
    )
    assert code == 0
    for key in (
        "outcome",
        "queries",
        "offline_s",
        "online_s_total",
        "online_s_per_query_median",
        "cost",
    ):
        assert key in rep
    assert rep["outcome"] == "solved" and rep["queries"] > 5


def test_play_events_replay(tmp_path, capsys, graph_file):
    from flexhrc.representation import OnlineGraph, load

    events = tmp_path / "ev.jsonl"
    assert (
        main(["graph", "play", str(graph_file), "--policy", "random", "--events", str(events)]) == 0
    )
    capsys.readouterr()
    replayed = OnlineGraph.replay(load(graph_file), OnlineGraph.load_events(events))
    assert replayed.solved


def test_render_dot_and_svg(tmp_path, capsys, graph_file):
    out = tmp_path / "g.dot"
    assert main(["graph", "render", str(graph_file), "-o", str(out), "--met", "Leg1_T"]) == 0
    text = out.read_text()
    assert text.startswith("digraph") and "cluster_1" in text and "palegreen" in text
    if shutil.which("dot"):
        svg = tmp_path / "g.svg"
        assert main(["graph", "render", str(graph_file), "-o", str(svg)]) == 0
        assert "<svg" in svg.read_text()
    assert main(["graph", "render", str(graph_file), "-o", str(tmp_path / "g.bmp")]) == 2
    assert "unsupported output format" in capsys.readouterr().err


def test_validate_yaml_with_formulas(tmp_path, capsys):
    f = tmp_path / "g.yaml"
    f.write_text(
        """\
flexhrc: 1
graphs:
  table:
    root: done
    nodes:
      - name: leg_free
        state: leg(?l) & not connected(?l)
      - plate
      - name: done
        processes: ["hold(?plate)"]
    hyperarcs:
      - name: attach
        children: [leg_free, plate]
        parent: done
        weight: 2
        actions:
          - pick(?arm, ?l)
          - screw(?arm, ?l, ?p)
"""
    )
    code, rep = run_json(capsys, "graph", "validate", str(f))
    assert code == 0 and rep["valid"] and rep["nodes"] == 3
    from flexhrc.representation import load

    g = load(f).top_graph
    assert str(g.node("leg_free").formula[1]) == "not connected(?l)"
    assert g.hyperarc("attach").actions == ("pick(?arm, ?l)", "screw(?arm, ?l, ?p)")
