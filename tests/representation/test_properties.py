"""Property tests on random AND/OR graphs (hypothesis).

Random graphs are built without nodes shared between the AND branches of one hyper-arc (the
children's sub-graphs are disjoint), while OR alternatives may share children — as in the
table-assembly files. On those, the dynamic-programming costs must equal exhaustive path
enumeration at every step of any traversal.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from flexhrc.representation import AndOrGraph, HierarchicalGraph, OnlineGraph
from flexhrc.representation.paths import exact_costs


@st.composite
def tree_graph(
    draw: st.DrawFn,
    name: str = "g",
    max_depth: int = 3,
    weights: st.SearchStrategy[float] | None = None,
) -> AndOrGraph:
    """A random tree; ``weights``: of every node and hyper-arc (default integers 0-3 for
    nodes, 0-4 for hyper-arcs)."""
    g = AndOrGraph(name)
    counter = [0]

    def fresh(prefix: str) -> str:
        counter[0] += 1
        return f"{prefix}{counter[0]}"

    def build(depth: int) -> str:
        node = fresh("n")
        g.add_node(node, draw(st.integers(0, 3) if weights is None else weights))
        if depth == 0 or draw(st.integers(0, 3)) == 0:
            return node
        pool = [build(depth - 1) for _ in range(draw(st.integers(1, 3)))]
        n_arcs = draw(st.integers(1, 3))
        subsets: list[list[str]] = [[] for _ in range(n_arcs)]
        for i, child in enumerate(pool):  # every pool member is used by some alternative
            subsets[i % n_arcs].append(child)
        for sub in subsets:
            extra = draw(st.lists(st.sampled_from(pool), max_size=2))
            chosen = sorted(set(sub) | set(extra), key=pool.index)
            if chosen:
                g.add_hyperarc(
                    fresh("h"),
                    chosen,
                    node,
                    draw(st.integers(0, 4) if weights is None else weights),
                )
        return node

    g.root = build(max_depth)
    return g


@st.composite
def hierarchical_graph(draw: st.DrawFn) -> HierarchicalGraph:
    top = draw(tree_graph("top", 3))
    low = draw(tree_graph("low", 2))
    n_leaves = len(low.leaves())
    graphs = {"top": top, "low": low}
    for h in list(top.hyperarcs.values()):
        if len(h.children) <= n_leaves and draw(st.booleans()):
            top.hyperarcs[h.name] = type(h)(h.name, h.children, h.parent, h.weight, lower="low")
    return HierarchicalGraph(graphs, "top")


SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def walk(data: st.DataObject, online: OnlineGraph, check) -> None:
    """A random traversal with occasional 'infeasible' marks; ``check`` after every answer."""
    from flexhrc.representation.formats.yaml_format import dump_yaml

    note(dump_yaml(online.hierarchy))
    answer = online.query()
    check(online, answer)
    for _ in range(200):
        if answer.outcome != "running":
            break
        feasible = sorted(answer.element_ids)
        e = data.draw(st.sampled_from(feasible))
        name = online.element_name(e)
        action = data.draw(st.integers(0, 9))
        note(f"{'infeasible' if action == 0 else 'report'} {name}")
        if action == 0:
            answer = online.mark_infeasible(name)
        elif online.kind(name) == "node":
            answer = online.update(met_nodes=[name])
        else:
            answer = online.update(solved_hyperarcs=[name])
        check(online, answer)


def check_answer(online: OnlineGraph, answer) -> None:
    # every suggestion is feasible, with the cost of the cheapest path through it
    exact = exact_costs(online)
    if answer.outcome == "solved":
        assert answer.feasible == {}
    else:
        assert answer.feasible == exact
    for s in answer.suggestions:
        assert online.is_feasible(s.element)
    root = online.hierarchy.top_graph.root
    assert answer.solved == online.is_met(root)  # solved iff root met
    if answer.failed:
        assert not exact  # failed iff nothing feasible lies on a way to the root
    if answer.outcome == "running":
        assert answer.feasible


@SETTINGS
@given(graph=tree_graph(), data=st.data())
def test_dp_equals_enumeration_single_layer(graph, data):
    walk(data, OnlineGraph(graph), check_answer)


@SETTINGS
@given(graph=hierarchical_graph(), data=st.data())
def test_dp_equals_enumeration_hierarchical(graph, data):
    walk(data, OnlineGraph(graph), check_answer)


@SETTINGS
@given(graph=hierarchical_graph(), data=st.data())
def test_replaying_the_history_rebuilds_the_state(graph, data):
    online = OnlineGraph(graph)
    walk(data, online, lambda o, a: None)
    again = OnlineGraph.replay(graph, online.events)
    assert again.state() == online.state()


@SETTINGS
@given(graph=tree_graph())
def test_cheapest_traversal_pays_the_optimal_cost(graph):
    from flexhrc.representation.play import play

    online = OnlineGraph(graph)
    best = online.optimal_cost()
    report = play(HierarchicalGraph.single(graph), "cheapest")
    assert report.outcome == "solved" and report.cost == best


@SETTINGS
@given(graph=tree_graph(), data=st.data())
def test_failed_reported_when_every_way_is_blocked(graph, data):
    online = OnlineGraph(graph)
    answer = online.query()
    for _ in range(500):
        if answer.outcome != "running":
            break
        e = data.draw(st.sampled_from(sorted(answer.element_ids)))
        answer = online.mark_infeasible(online.element_name(e))
    assert answer.failed and answer.reason
    assert answer.feasible == {}
