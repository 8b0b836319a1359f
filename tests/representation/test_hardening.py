"""Regression tests for the graph-side cases of the bad-input review (issue 9).

Case ids (A9, B4, C25, ...) are those of ``../shared/reviews/bad-input-probe-2026-12-01.md``.
CLI cases go through ``flexhrc.cli.main``: one ``error:`` line, exit 2, no traceback.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys

import pytest

from flexhrc.cli import main
from flexhrc.errors import FlexhrcError, FormatError, UnknownNameError
from flexhrc.representation import (
    AndOrGraph,
    GraphArgumentError,
    HierarchicalGraph,
    InfeasibleUpdateError,
    OnlineGraph,
    load,
)
from flexhrc.representation.synthetic import chain, random_tree

from ..conftest import subprocess_env
from .test_cli_graph import BASIC, TWO_LEGS


@pytest.fixture
def graph_file(tmp_path):
    (tmp_path / "basic_connection.txt").write_text(BASIC)
    top = tmp_path / "table.txt"
    top.write_text(TWO_LEGS)
    return top


def one_error(capsys, argv: list[str], *words: str) -> str:
    """Run the CLI, expect exit 2 with exactly one ``error:`` line containing ``words``."""
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in err, err
    return err


def write_andor(g: AndOrGraph, path) -> None:
    from flexhrc.representation.formats.andor_text import dump_andor_text

    dump_andor_text(HierarchicalGraph({path.stem: g}, path.stem), path.parent)


# -- A: scale, recursion, data loss ----------------------------------------------------------


def test_a2_five_hundred_legs_table_graph_has_no_recursion_error():
    from flexhrc.scenario.builtin.table import build_graph

    online = OnlineGraph(build_graph(500))
    answer = online.update()
    assert answer.outcome == "running" and answer.feasible


@pytest.mark.slow
def test_a13_ten_thousand_node_chain(tmp_path, capsys):
    g = chain(10_000)
    online = OnlineGraph(g)  # deep: every walk is iterative
    answer = online.query()
    assert answer.feasible == {"n0": 10_000 + 9_999}
    answer = online.update(met_nodes=["n0"])
    assert answer.feasible == {"h1": 9_999 + 9_999}
    from flexhrc.representation.paths import exact_costs

    assert exact_costs(online) == {"h1": 19_998}
    f = tmp_path / "chain.txt"
    write_andor(g, f)
    assert main(["graph", "validate", str(f), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["valid"]


def test_a12_large_random_tree_played_to_the_end():
    # the 10 000-node play and its per-query median are in benchmarks/andor_scale.py; here a
    # smaller tree, in the same shape, played to the end (the test client sorts ~F ids per
    # query, which dominates the wall time of a 10 000-node play)
    from flexhrc.representation.play import play

    g = random_tree(2_000, seed=1)
    report = play(HierarchicalGraph.single(g), "random", seed=3)
    assert report.outcome == "solved"
    assert report.queries > 500


def test_a9_events_never_overwrite_the_input(tmp_path, capsys, graph_file):
    before = graph_file.read_bytes()
    one_error(
        capsys,
        ["graph", "play", str(graph_file), "--events", str(graph_file)],
        "--events",
        "input",
    )
    assert graph_file.read_bytes() == before
    lower = graph_file.parent / "basic_connection.txt"
    lower_before = lower.read_bytes()
    one_error(capsys, ["graph", "play", str(graph_file), "--events", str(lower)], "input")
    assert lower.read_bytes() == lower_before


def test_a10_truncated_file_is_warned_about(tmp_path, capsys):
    lines = TWO_LEGS.splitlines()
    (tmp_path / "basic_connection.txt").write_text(BASIC)
    f = tmp_path / "t.txt"
    f.write_text("\n".join(lines[:8]) + "\n")  # cut after h0's child: root now a leaf
    assert main(["graph", "validate", str(f), "--json"]) == 0
    captured = capsys.readouterr()
    rep = json.loads(captured.out)
    text = " ".join(rep["warnings"])
    assert "root 'Table_FinalPose' is a leaf" in text
    for idle in ("Leg1_T", "Leg1_Plate_connected"):
        assert f"node {idle!r} is on no hyper-arc" in text
    assert captured.err.count("warning:") == len(rep["warnings"])


# -- B: tracebacks ---------------------------------------------------------------------------


def _unprivileged() -> list[str]:
    """A command prefix that runs without the capabilities that let root read anything."""
    import shutil

    if os.geteuid() != 0:
        return []
    if shutil.which("setpriv") is None:
        pytest.skip("running as root without setpriv: chmod 000 does not stop root")
    caps = "-dac_override,-dac_read_search"
    return ["setpriv", f"--inh-caps={caps}", f"--bounding-set={caps}"]


@pytest.mark.parametrize("which", ["top", "lower"])
def test_b1_unreadable_graph_or_lower_graph(tmp_path, graph_file, which):
    target = graph_file if which == "top" else graph_file.parent / "basic_connection.txt"
    prefix = _unprivileged()
    target.chmod(0)
    try:
        proc = subprocess.run(
            [*prefix, sys.executable, "-m", "flexhrc", "graph", "validate", str(graph_file)],
            capture_output=True,
            text=True,
            env=subprocess_env(),
            timeout=120,
        )
    finally:
        target.chmod(0o644)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {target}: cannot read"), proc.stderr


def test_b1_unreadable_is_reported_without_permissions(tmp_path, capsys, monkeypatch):
    # root can read chmod-000 files: simulate the permission error where the file is opened.
    # The compiled reader opens files in C, out of the simulation's reach: it is off here (it
    # declines a file it cannot read, and the Python reader reports it: the setpriv test above
    # shows that with real permissions)
    monkeypatch.setattr("flexhrc.representation.formats.andor_text._parse_compiled", None)
    f = tmp_path / "g.txt"
    f.write_text(TWO_LEGS)
    real_open = open

    def deny(path, *a, **kw):
        if str(path) == str(f):
            raise PermissionError(13, "Permission denied", str(path))
        return real_open(path, *a, **kw)

    real_os_open = os.open

    def deny_fd(path, *a, **kw):  # the ANDOR text reader reads with os.open
        if str(path) == str(f):
            raise PermissionError(13, "Permission denied", str(path))
        return real_os_open(path, *a, **kw)

    monkeypatch.setattr("builtins.open", deny)
    monkeypatch.setattr("os.open", deny_fd)
    monkeypatch.setattr(
        "pathlib.Path.read_bytes",
        lambda self: (_ for _ in ()).throw(PermissionError(13, "Permission denied")),
    )
    one_error(capsys, ["graph", "validate", str(f)], str(f), "permission denied")


@pytest.mark.parametrize("suffix", [".yaml", ".txt"])
@pytest.mark.parametrize(
    "data,words",
    [
        (bytes(random.Random(0).randrange(256) for _ in range(2000)), "not"),
        (b"G 1 r\nr \xca\xfe 0\n", "not UTF-8"),
    ],
    ids=["random bytes", "latin-1"],
)
def test_b3_binary_or_non_utf8(tmp_path, capsys, suffix, data, words):
    f = tmp_path / f"b{suffix}"
    f.write_bytes(data)
    err = one_error(capsys, ["graph", "validate", str(f)], str(f), words)
    assert "\\x" not in err and "\ufffd" not in err  # the bytes are not echoed


def test_b4_yaml_including_itself(tmp_path, capsys):
    f = tmp_path / "file_self.yaml"
    f.write_text("flexhrc: 1\ntop: t\ngraphs:\n  t: {file: file_self.yaml}\n")
    one_error(capsys, ["graph", "validate", str(f)], "includes itself")
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text("flexhrc: 1\ntop: t\ngraphs:\n  t: {file: b.yaml}\n")
    b.write_text("flexhrc: 1\ntop: t\ngraphs:\n  t: {file: a.yaml}\n")
    one_error(capsys, ["graph", "validate", str(a)], "includes itself", "a.yaml -> b.yaml")


def test_b5_deeply_nested_yaml(tmp_path, capsys):
    f = tmp_path / "deep.yaml"
    f.write_text("[" * 100_000 + "]" * 100_000 + "\n")
    one_error(capsys, ["graph", "validate", str(f)], str(f), "nested too deeply")


@pytest.mark.parametrize(
    "argv,option",
    [
        (["graph", "play", "{g}", "--events", "{tmp}/nonexistent/ev.jsonl"], "--events"),
        (["graph", "play", "{g}", "--events", "{tmp}"], "--events"),
        (["graph", "play", "{g}", "--events", "/dev/full"], "--events"),
        (["graph", "render", "{g}", "-o", "{tmp}/nonexistent/x.dot"], "-o"),
        (["graph", "render", "{g}", "-o", "{tmp}/g.txt"], "-o"),
        (["graph", "play", "{g}", "--events", ""], "--events"),
        (["graph", "play", "{g}", "--events", "/proc/version"], "--events"),
    ],
)
def test_b8_output_paths_checked_before_the_work(tmp_path, capsys, graph_file, argv, option):
    argv = [a.format(g=graph_file, tmp=tmp_path) for a in argv]
    one_error(capsys, argv, option)
    assert not (tmp_path / "nonexistent").exists()  # no folder created


def test_b8_events_are_streamed_event_by_event(tmp_path, capsys, graph_file, monkeypatch):
    from flexhrc.files import EventLogWriter

    events = tmp_path / "ev.jsonl"
    sizes: list[int] = []
    write = EventLogWriter.write

    def spy(self, event):
        write(self, event)
        sizes.append(events.stat().st_size)  # on disk already, not at the end

    monkeypatch.setattr(EventLogWriter, "write", spy)
    assert main(["graph", "play", str(graph_file), "--events", str(events)]) == 0
    lines = events.read_text().splitlines()
    assert len(sizes) == len(lines) > 3 and sizes == sorted(sizes) and sizes[0] > 0
    assert OnlineGraph.replay(load(graph_file), [json.loads(x) for x in lines]).solved


def test_b8_render_is_atomic(tmp_path, capsys, graph_file, monkeypatch):
    out = tmp_path / "g.dot"
    out.write_text("old")
    import flexhrc.representation.formats.dot as dot

    def boom(*a, **kw):
        raise FlexhrcError("interrupted")

    monkeypatch.setattr(dot, "_legend", boom)
    one_error(capsys, ["graph", "render", str(graph_file), "-o", str(out)], "interrupted")
    assert out.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".g.dot")] == []


@pytest.mark.parametrize(
    "call",
    [
        lambda o: o.update(met_nodes=None),
        lambda o: o.update(met_nodes=[5]),
        lambda o: o.update(met_nodes=[["x"]]),
        lambda o: o.update(met_nodes="Leg1_T"),
        lambda o: o.update(solved_hyperarcs=3),
        lambda o: o.update(infeasible=[None]),
        lambda o: o.is_met(7),
        lambda o: o.element_name("x"),
        lambda o: OnlineGraph(None),
        lambda o: OnlineGraph("file.txt"),
        lambda o: load(5),
        lambda o: OnlineGraph.replay(o.hierarchy, [{"query": 1, "type": "met"}]),
        lambda o: OnlineGraph.replay(o.hierarchy, [{"query": "x", "type": "met", "element": "a"}]),
        lambda o: OnlineGraph.replay(o.hierarchy, [5]),
        lambda o: OnlineGraph.replay(o.hierarchy, None),
    ],
)
def test_b18_wrong_argument_types_are_flexhrc_errors(graph_file, call):
    online = OnlineGraph(load(graph_file))
    before = online.state()
    with pytest.raises(FlexhrcError) as info:
        call(online)
    assert isinstance(info.value, TypeError | ValueError | KeyError)
    assert online.state() == before
    assert online.update(met_nodes=["Leg1_T"]).outcome == "running"  # still usable


def test_b18_type_errors_are_type_errors(graph_file):
    online = OnlineGraph(load(graph_file))
    with pytest.raises(TypeError, match="met_nodes must be a list"):
        online.update(met_nodes=None)
    with pytest.raises(GraphArgumentError, match="wrap it in a list"):
        online.update(met_nodes="Leg1_T")
    with pytest.raises(TypeError, match="load the file first"):
        OnlineGraph("file.txt")


# -- C: garbage accepted -----------------------------------------------------------------------


def test_c23_unbalanced_action_formula(tmp_path, capsys):
    f = tmp_path / "badaction.yaml"
    f.write_text(
        "flexhrc: 1\ngraphs:\n  g:\n    root: r\n    nodes: [a, r]\n    hyperarcs:\n"
        "      - name: h\n        children: [a]\n        parent: r\n"
        '        actions: ["release(?agent, ?b, ?x"]\n'
    )
    one_error(capsys, ["graph", "validate", str(f)], f"{f}:10:", "malformed literal")


def test_c24_path_limit_needs_exact_and_a_positive_value(capsys, graph_file):
    one_error(capsys, ["graph", "suggest", str(graph_file), "--path-limit", "5"], "--exact")
    for bad in ("-1", "0", "nan", "inf", "1e99", "10000000000"):
        one_error(
            capsys,
            ["graph", "suggest", str(graph_file), "--exact", "--path-limit", bad],
            "--path-limit",
        )
    assert main(["graph", "suggest", str(graph_file), "--exact", "--path-limit", "5"]) == 0


@pytest.mark.parametrize("bad", ["-5", "nan", "1.5", "99999999999999999999999"])
def test_numeric_seed_validated(capsys, graph_file, bad):
    one_error(
        capsys, ["graph", "play", str(graph_file), "--policy", "random", "--seed", bad], "--seed"
    )


def test_c25_is_met_and_is_solved_refuse_the_other_kind(graph_file):
    online = OnlineGraph(load(graph_file))
    with pytest.raises(UnknownNameError, match="hyper-arc, not a node"):
        online.is_met("h0")
    with pytest.raises(UnknownNameError, match="node, not a hyper-arc"):
        online.is_solved("Plate_initPose")
    assert online.is_met("Plate_initPose") is False and online.is_solved("h0") is False


def test_c26_replay_refuses_unknown_event_types(graph_file):
    g = load(graph_file)
    with pytest.raises(GraphArgumentError, match="unknown event type 'eaten'"):
        OnlineGraph.replay(g, [{"query": 1, "type": "eaten", "element": "Plate_initPose"}])


def test_c27_rejected_update_does_not_count_a_query(graph_file):
    online = OnlineGraph(load(graph_file))
    online.query()
    online.update(met_nodes=["Plate_initPose"])
    n, events, state = online.queries, list(online.events), online.state()
    with pytest.raises(InfeasibleUpdateError):
        online.update(met_nodes=["Table_FinalPose"])
    with pytest.raises(UnknownNameError):
        online.update(met_nodes=["nope"])
    assert online.queries == n and online.events == events and online.state() == state
    assert online.update(solved_hyperarcs=["h0"]).query == n + 1


def test_c28_steps_and_events_agree_on_query_numbers(tmp_path, capsys, graph_file):
    events = tmp_path / "ev.jsonl"
    code = main(["graph", "play", str(graph_file), "--steps", "--events", str(events), "--json"])
    assert code == 0
    steps = json.loads(capsys.readouterr().out)["steps"]
    logged = [json.loads(x) for x in events.read_text().splitlines()]
    # each step reports one element; the events of its query start with that element
    first_of_query = {}
    for ev in logged:
        first_of_query.setdefault(ev["query"], ev["element"])
    assert {s["query"]: s["element"] for s in steps} == first_of_query


# -- D: misleading messages --------------------------------------------------------------------


def test_d_lower_graph_outside_the_folder_is_refused_without_quoting_it(tmp_path, capsys):
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:root:/root:/bin/bash\n")
    sub = tmp_path / "g"
    sub.mkdir()
    f = sub / "lower_passwd.txt"
    f.write_text(TWO_LEGS.replace("basic_connection", "../secret"))
    err = one_error(capsys, ["graph", "validate", str(f)], f"{f}:", "outside the top graph")
    assert "root:x" not in err
    y = sub / "y.yaml"
    y.write_text("flexhrc: 1\ntop: t\ngraphs:\n  t: {file: ../secret.txt}\n")
    err = one_error(capsys, ["graph", "validate", str(y)], "outside the top graph")
    assert "root:x" not in err


def test_d_a_file_that_is_not_a_graph_is_not_quoted(tmp_path, capsys):
    f = tmp_path / "passwd.txt"
    f.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1::/:/bin/false\n")
    err = one_error(capsys, ["graph", "validate", str(f)], "not an ANDOR graph file")
    assert "root:x" not in err
    f.write_text("name count root\n")
    err = one_error(capsys, ["graph", "validate", str(f)], "not an ANDOR graph file")
    assert "count" not in err.split(":", 3)[-1].split("(")[0] or "number of nodes" in err


# -- item 3 and 7 of the issue: validate warnings, render legend, help --------------------------


def test_validate_warns_about_a_node_shared_by_the_children_of_one_hyperarc(tmp_path, capsys):
    y = tmp_path / "shared.yaml"
    y.write_text(
        "flexhrc: 1\ngraphs:\n  g:\n    root: r\n    nodes: [s, a, b, r]\n    hyperarcs:\n"
        "      - {name: ha, children: [s], parent: a}\n"
        "      - {name: hb, children: [s], parent: b}\n"
        "      - {name: top, children: [a, b], parent: r}\n"
    )
    assert main(["graph", "validate", str(y), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert any("node 's' is shared between its children" in w for w in rep["warnings"])
    assert rep["solvable"] is True


def test_validate_on_a_clean_graph_has_no_warnings(capsys, graph_file):
    assert main(["graph", "validate", str(graph_file), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["warnings"] == [] and rep["solvable"] is True


def test_validate_reports_a_graph_that_can_never_be_solved(capsys, graph_file, monkeypatch):
    # structurally every valid graph starts solvable; a fault injected into the check's
    # answer must reach the user as a warning and in the JSON
    real_query = OnlineGraph.query

    def failed(self):
        self.update(infeasible=[self.hierarchy.top_graph.root])
        return real_query(self)

    monkeypatch.setattr(OnlineGraph, "query", failed)
    assert main(["graph", "validate", str(graph_file), "--json"]) == 0
    captured = capsys.readouterr()
    rep = json.loads(captured.out)
    assert rep["solvable"] is False and "can never be solved" in captured.err


def test_render_has_a_legend_and_json(tmp_path, capsys, graph_file):
    out = tmp_path / "g.dot"
    code = main(["graph", "render", str(graph_file), "-o", str(out), "--met", "Leg1_T", "--json"])
    assert code == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["output"] == str(out) and rep["format"] == "dot" and rep["legend"]
    text = out.read_text()
    assert "cluster_legend" in text and "met / solved" in text and "feasible (cost)" in text
    assert main(["graph", "render", str(graph_file), "-o", str(out), "--no-legend"]) == 0
    assert "cluster_legend" not in out.read_text()


def test_every_graph_argument_has_help():
    import argparse

    from flexhrc.cli import build_parser

    parser = build_parser()
    graph = next(
        a for a in parser._subparsers._group_actions[0].choices.items() if a[0] == "graph"
    )[1]
    sub = next(a for a in graph._actions if isinstance(a, argparse._SubParsersAction))
    for name, p in sub.choices.items():
        for action in p._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            assert action.help, f"graph {name}: {action.dest} has no help"


def test_no_traceback_in_a_real_process(tmp_path):
    f = tmp_path / "deep.yaml"
    f.write_text("[" * 100_000 + "]" * 100_000 + "\n")
    proc = subprocess.run(
        [sys.executable, "-m", "flexhrc", "graph", "validate", str(f)],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=120,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr and proc.stderr.startswith("error: ")


def test_load_errors_are_format_errors(tmp_path):
    with pytest.raises(FormatError, match="no such file"):
        load(tmp_path / "missing.txt")


def test_d_a_symbolic_link_out_of_the_folder_is_refused(tmp_path, capsys):
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (outside / "basic_connection.txt").write_text(BASIC)
    sub = tmp_path / "g"
    sub.mkdir()
    (sub / "basic_connection.txt").symlink_to(outside / "basic_connection.txt")
    f = sub / "table.txt"
    f.write_text(TWO_LEGS)
    one_error(capsys, ["graph", "validate", str(f)], "outside the top graph")
    (sub / "basic_connection.txt").unlink()
    (sub / "inner").mkdir()
    (sub / "inner" / "real.txt").write_text(BASIC)
    (sub / "basic_connection.txt").symlink_to(sub / "inner" / "real.txt")
    assert main(["graph", "validate", str(f)]) == 0  # a link that stays inside is fine


def test_an_instance_marked_infeasible_before_it_is_active_keeps_exact_costs():
    # two uses of one lower graph; the second instance is changed while still inactive, so it
    # must not start from the definition's shared initial costs
    from flexhrc.representation.paths import exact_costs

    top = AndOrGraph("top", root="t")
    for n in ("x", "y", "m", "t"):
        top.add_node(n)
    top.add_hyperarc("A", ["x"], "m", 1, lower="low")
    top.add_hyperarc("B", ["m", "y"], "t", 1, lower="low")
    low = AndOrGraph("low", root="r")
    for n, w in (("p", 1), ("q", 2), ("s", 0), ("r", 0)):
        low.add_node(n, w)
    low.add_hyperarc("l1", ["p", "q"], "s", 2)
    low.add_hyperarc("l2", ["q"], "r", 7)
    low.add_hyperarc("l3", ["s"], "r", 1)
    h = HierarchicalGraph({"top": top, "low": low}, "top")
    online = OnlineGraph(h)
    online.update(infeasible=["B/l3"])  # B's instance is inactive
    steps = [
        {"met_nodes": ["x"]},
        {"met_nodes": ["A/p", "A/q"]},
        {"solved_hyperarcs": ["A/l1"]},
        {"met_nodes": ["A/s"]},
        {"solved_hyperarcs": ["A/l3"]},
        {"met_nodes": ["A/r", "m", "y"]},
    ]
    for kw in steps:
        answer = online.update(**kw)
        assert answer.feasible == exact_costs(online), kw
    # with l3 gone, p is on no way to B's root: only q (through l2) is left to suggest
    assert answer.feasible == {"B/q": 2 + 7}  # w(q) + w(l2); the lower path replaces w(B)
    again = OnlineGraph(h)  # the same definition, pristine: shared initial costs
    again.update(met_nodes=["x"])
    assert again.query().feasible == exact_costs(again)
