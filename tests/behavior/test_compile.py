"""One task, two executors: THEN/AND/OR tasks compiled into AND/OR graphs (and back).

Properties: every order produced by playing the compiled graph satisfies the task's constraints;
on small tasks the set of behaviour orders of all cooperation paths (by exhaustive search over
the online graph) is exactly the set of orders the task allows; the reverse conversion gives the
task back."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexhrc.behavior import allowed_next, build_task, parse_prefix
from flexhrc.behavior.compile import (
    NotSeriesParallelError,
    compile_task,
    normalise,
    task_from_graph,
)
from flexhrc.cli import main
from flexhrc.representation import OnlineGraph
from flexhrc.representation.graph import AndOrGraph
from flexhrc.representation.hierarchy import HierarchicalGraph, split_qualified
from flexhrc.representation.play import play

GOALS = ("THEN", "AND", "OR")


def behavior_order(hierarchy, steps):
    """The behaviours carried out by a played cooperation path (``graph play`` steps, in
    order): the actions of the solved hyper-arcs that have any."""
    actions = {h.name: h.actions for g in hierarchy.graphs.values() for h in g.hyperarcs.values()}
    order = []
    for step in steps:
        if step.get("kind") == "hyperarc":
            order.extend(actions.get(split_qualified(str(step["element"]))[1], ()))
    return order


def shapes(max_leaves):
    return st.recursive(
        st.just("leaf"),
        lambda children: st.tuples(
            st.sampled_from(GOALS), st.lists(children, min_size=1, max_size=4)
        ),
        max_leaves=max_leaves,
    )


def to_task(shape):
    counter = [0]

    def spec(s):
        if s == "leaf":
            counter[0] += 1
            return ("BEHAVIOR", f"b{counter[0]}", 1, None)
        kind, children = s
        return (kind, [spec(c) for c in children], 1, None)

    return build_task(spec(shape), "<hypothesis>")


def satisfies(task, order):
    done: list[str] = []
    for b in order:
        if b not in allowed_next(task, done):
            return False
        done.append(b)
    return not allowed_next(task, done)  # and the task is complete


def task_orders(task):
    out = set()

    def walk(done):
        nxt = allowed_next(task, done)
        if not nxt:
            out.add(tuple(done))
            return
        for b in sorted(nxt):
            walk([*done, b])

    walk([])
    return out


def graph_orders(hierarchy):
    """Behaviour orders of every cooperation path, by exhaustive search with memoised states."""
    actions = {h.name: h.actions for g in hierarchy.graphs.values() for h in g.hyperarcs.values()}
    online = OnlineGraph(hierarchy)
    memo: dict[tuple, frozenset] = {}

    def search():
        key = (tuple(online._done), tuple(online._blocked), tuple(online._active))
        if key in memo:
            return memo[key]
        if online.solved:
            return frozenset({()})
        result: set[tuple[str, ...]] = set()
        for name in sorted(online.query().feasible):
            snap = online._snapshot()
            if online.kind(name) == "hyperarc":
                online.update(solved_hyperarcs=(name,))
            else:
                online.update(met_nodes=(name,))
            act = actions.get(split_qualified(name)[1], ())
            result |= {act + rest for rest in search()}
            online._restore(snap)
        memo[key] = frozenset(result)
        return memo[key]

    return set(search())


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(shape=shapes(30), seeds=st.lists(st.integers(0, 10**6), min_size=8, max_size=8))
def test_every_played_order_of_the_compiled_graph_satisfies_the_task(shape, seeds):
    task = to_task(shape)
    hierarchy = compile_task(task)
    for seed in seeds:
        report = play(hierarchy, policy="random", seed=seed, record_steps=True)
        assert report.outcome == "solved", task.to_prefix()
        order = behavior_order(hierarchy, report.steps)
        assert satisfies(task, order), (task.to_prefix(), order)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(shape=shapes(5))
def test_cooperation_paths_are_exactly_the_orders_the_task_allows(shape):
    task = to_task(shape)
    assert graph_orders(compile_task(task)) == task_orders(task), task.to_prefix()


@settings(max_examples=60, deadline=None)
@given(shape=shapes(30))
def test_graph_to_task_gives_the_task_back_and_the_graph_is_linear(shape):
    task = to_task(shape)
    hierarchy = compile_task(task)
    assert normalise(task_from_graph(hierarchy)) == normalise(task)
    st_ = hierarchy.stats()
    assert st_["hyperarcs"] <= 3 * task.size and st_["nodes"] <= 4 * task.size + 2
    behaviours = [h for g in hierarchy.graphs.values() for h in g.hyperarcs.values() if h.actions]
    assert sorted(h.name for h in behaviours) == sorted(task.behaviors)
    assert all(h.actions == (h.name,) for h in behaviours)


def test_table_setting_compiles_and_plays_its_constraints():
    task = parse_prefix(
        "(THEN placemat (AND (THEN plate bowl) fork spoon knife (OR wineglass cup soda_can)))"
    )
    hierarchy = compile_task(task)
    orders = {
        tuple(behavior_order(hierarchy, play(hierarchy, "random", s, record_steps=True).steps))
        for s in range(30)
    }
    assert all(satisfies(task, o) for o in orders)
    assert len(orders) > 10  # the choices of the AND and the OR are all open
    assert {o[0] for o in orders} == {"placemat"}


def test_graphs_that_are_not_series_parallel_are_refused_with_the_reason():
    g = AndOrGraph("g", root="r")
    for n in ("l", "m1", "m2", "r"):
        g.add_node(n)
    g.add_hyperarc("a", ["l"], "m1", actions=("a",))
    g.add_hyperarc("x", ["m1"], "m2", actions=("x",))
    g.add_hyperarc("y", ["m1", "m2"], "r", actions=("y",))  # m1 needed twice on one path
    with pytest.raises(NotSeriesParallelError, match="not series-parallel"):
        task_from_graph(HierarchicalGraph.single(g), "g.yaml")
    empty = AndOrGraph("e", root="r")
    empty.add_node("l")
    empty.add_node("r")
    empty.add_hyperarc("h", ["l"], "r")
    with pytest.raises(NotSeriesParallelError, match="nothing to do"):
        task_from_graph(HierarchicalGraph.single(empty), "e.yaml")
    # an alternative that does nothing beside one that acts: one error, not a TypeError
    optional = AndOrGraph("o", root="r")
    optional.add_node("l")
    optional.add_node("r")
    optional.add_hyperarc("skip", ["l"], "r")
    optional.add_hyperarc("act", ["l"], "r", actions=("act",))
    with pytest.raises(NotSeriesParallelError, match="an OR with an empty alternative"):
        task_from_graph(HierarchicalGraph.single(optional), "o.yaml")


def test_cli_compile_play_and_to_task(tmp_path, capsys):
    out = tmp_path / "graph.yaml"
    assert main(["behave", "compile", "(THEN a (AND b (OR c d)))", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["graph", "play", str(out), "--policy", "random", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["outcome"] == "solved"
    assert main(["graph", "to-task", str(out), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["task"] == "(THEN a (AND b (OR c d)))"
    txt = tmp_path / "task.txt"
    assert main(["graph", "to-task", str(out), "-o", str(txt)]) == 0
    capsys.readouterr()
    assert main(["behave", str(txt), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["order"][0] == "a"
    # output checked before the work: suffix and folder
    assert main(["behave", "compile", "(THEN a b)", "-o", str(tmp_path / "g.txt")]) == 2
    assert "unsupported output format" in capsys.readouterr().err
    assert main(["behave", "compile", "(THEN a b)"]) == 2
    assert "needs -o OUT" in capsys.readouterr().err


def test_to_task_on_a_graph_without_a_task_form_names_the_file_and_node(capsys):
    from tests.conftest import REPO

    graph = REPO / "examples" / "graphs" / "table_2legs.txt"
    assert main(["graph", "to-task", str(graph)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {graph}: node 'Leg_connected'") and err.count("\n") == 1
    ball = REPO / "examples" / "graphs" / "ball_in_box.yaml"
    assert main(["graph", "to-task", str(ball), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["task"].startswith("(THEN (OR ")
