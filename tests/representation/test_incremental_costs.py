"""The online phase's incremental costs against a recomputation from scratch (hypothesis), and
the work a query costs on a deep chain (probe case R12).

After every query, the cost of every feasible element and the optimal cost must be exactly the
values a full pass over the current statuses gives — the same floats, also with fractional
weights: the engine updates only what a query changed and leaves inside costs nothing reads
out of date until they are asked for, so the recomputation here is written out in full.
"""

from __future__ import annotations

from unittest.mock import patch

from hypothesis import given, note
from hypothesis import strategies as st

from flexhrc.representation import AndOrGraph, HierarchicalGraph, OnlineGraph

from .test_properties import SETTINGS, hierarchical_graph, tree_graph

INF = float("inf")
FRACTIONAL = (0.0, 0.1, 0.25, 0.3, 1.0, 2.5, 1e-3)


def recompute(online: OnlineGraph) -> tuple[dict[int, float], float, list[float]]:
    """Every cost from the statuses alone: (feasible element id -> cost, the optimal cost,
    every element's inside cost), summed in the engine's order (eqs. 9-11, 19)."""
    n = len(online._kind)
    done, blocked, lower, w = online._done, online._blocked, online._lower, online._w
    spans, tmpls, roots, upper = online._i_span, online._i_tmpl, online._i_root, online._i_upper
    n_inst = len(spans)
    children: list[list[int]] = [[] for _ in range(n)]
    incoming: list[list[int]] = [[] for _ in range(n)]
    outgoing: list[list[int]] = [[] for _ in range(n)]
    parent = [-1] * n
    order: list[list[int]] = []  # per instance, children before parents
    for k in range(n_inst):
        lo, _ = spans[k]
        t = tmpls[k]
        t.complete()
        for x in range(t.size):
            children[lo + x] = [lo + c for c in t.children[x]]
            incoming[lo + x] = [lo + h for h in t.incoming[x]]
            outgoing[lo + x] = [lo + h for h in t.outgoing[x]]
            parent[lo + x] = lo + t.parent[x] if t.kinds[x] else -1
        order.append([lo + x for x in t.topo])
    ins = [0.0] * n
    for k in range(n_inst - 1, -1, -1):  # an instance after every instance below it
        for e in order[k]:
            if blocked[e]:
                ins[e] = INF
            elif children[e]:
                v = 0.0 if done[e] else ins[roots[lower[e]]] if lower[e] >= 0 else w[e]
                for c in children[e]:
                    v += ins[c]
                ins[e] = v
            else:
                v = 0.0 if done[e] else w[e]
                if incoming[e]:
                    v += min(ins[h] for h in incoming[e])
                ins[e] = v
    out = [0.0] * n  # relative to the instance root
    off = [0.0] * n_inst  # the instance root's outside cost in the whole hierarchy
    for k in range(n_inst):  # an instance after the one above it
        u = upper[k]
        if u >= 0:
            if blocked[u]:
                off[k] = INF
            else:
                v = out[u] + off[online._inst[u]]
                for c in children[u]:
                    v += ins[c]
                off[k] = v
        for e in reversed(order[k]):
            if e == roots[k]:
                out[e] = 0.0
            elif children[e]:
                p = parent[e]
                out[e] = INF if blocked[p] else (0.0 if done[p] else w[p]) + out[p]
            else:
                best = INF
                for h in outgoing[e]:
                    if blocked[h]:
                        continue
                    own = 0.0 if done[h] else ins[roots[lower[h]]] if lower[h] >= 0 else w[h]
                    for c in children[h]:
                        if c != e:
                            own += ins[c]
                    own += out[h]
                    best = min(best, own)
                out[e] = best
    costs: dict[int, float] = {}
    if done[roots[0]]:  # solved: nothing is suggested any more
        return costs, ins[roots[0]], ins
    for e in online._feasible:
        c = ins[e] + out[e] + off[online._inst[e]]
        if c < INF:
            costs[e] = c
    return costs, ins[roots[0]], ins


@st.composite
def deep_graph(draw: st.DrawFn) -> AndOrGraph:
    """A spine of 2-30 steps, each a hyper-arc from the step below (sometimes with a leaf
    beside it), sometimes an alternative (a leaf, or the step below again): long stretches of
    one child and one way, where an inside cost is read by nothing but the step above."""
    g = AndOrGraph("deep")
    weight = st.sampled_from(FRACTIONAL)
    g.add_node("s0", draw(weight))
    steps = draw(st.integers(2, 30))
    for i in range(1, steps + 1):
        g.add_node(f"s{i}", draw(weight))
        kids = [f"s{i - 1}"]
        if draw(st.integers(0, 4)) == 0:
            g.add_node(f"x{i}", draw(weight))
            kids.append(f"x{i}")
        g.add_hyperarc(f"h{i}", kids, f"s{i}", draw(weight))
        alt = draw(st.integers(0, 5))
        if alt == 0:
            g.add_node(f"y{i}", draw(weight))
            g.add_hyperarc(f"a{i}", [f"y{i}"], f"s{i}", draw(weight))
        elif alt == 1:
            g.add_hyperarc(f"a{i}", [f"s{i - 1}"], f"s{i}", draw(weight))
    g.root = f"s{steps}"
    return g


def walk_and_recompute(data: st.DataObject, online: OnlineGraph) -> None:
    """A random traversal (reports, sometimes 'infeasible', sometimes the optimal cost asked
    for, which brings stale inside costs up to date); after every answer, its costs are the
    recomputed ones."""
    answer = online.query()
    for _ in range(300):
        costs, optimal, _ = recompute(online)
        assert answer.element_ids == costs
        if data.draw(st.integers(0, 3)) == 0:
            assert online.optimal_cost() == optimal
        if answer.outcome != "running":
            break
        e = data.draw(st.sampled_from(sorted(answer.element_ids)))
        name = online.element_name(e)
        action = data.draw(st.integers(0, 11))
        note(f"{'infeasible' if action == 0 else 'report'} {name}")
        if action == 0:
            answer = online.mark_infeasible(name)
        elif online.kind(name) == "node":
            answer = online.update(met_nodes=[name])
        else:
            answer = online.update(solved_hyperarcs=[name])
    _, optimal, ins = recompute(online)
    assert online.optimal_cost() == optimal
    assert [online._pull(e) for e in range(len(ins))] == ins


def lazy(graph: AndOrGraph | HierarchicalGraph) -> OnlineGraph:
    """The online phase of ``graph`` leaving out of date every inside cost it may, however few
    (by default only a long stretch of them is: a small graph would not exercise it)."""
    with patch.object(OnlineGraph, "_LAZY_MIN", 0):
        return OnlineGraph(graph)


@SETTINGS
@given(graph=tree_graph(weights=st.sampled_from(FRACTIONAL)), data=st.data())
def test_incremental_costs_equal_a_recomputation(graph, data):
    walk_and_recompute(data, lazy(graph))


@SETTINGS
@given(graph=deep_graph(), data=st.data())
def test_incremental_costs_equal_a_recomputation_deep(graph, data):
    walk_and_recompute(data, lazy(graph))


@SETTINGS
@given(graph=hierarchical_graph(), data=st.data())
def test_incremental_costs_equal_a_recomputation_hierarchical(graph, data):
    walk_and_recompute(data, lazy(graph))


class Counting(list):  # type: ignore[type-arg]
    """A list that counts the reads and writes of its items: the test's measure of the work
    of the cost passes (no clock)."""

    n = 0

    def __getitem__(self, i):  # type: ignore[no-untyped-def]
        Counting.n += 1
        return super().__getitem__(i)

    def __setitem__(self, i, v):  # type: ignore[no-untyped-def]
        Counting.n += 1
        super().__setitem__(i, v)


def test_r12_a_deep_chain_costs_each_query_a_few_elements():
    # the probe's chain: n0 <- h0 <- n1 <- ... <- n2999, nodes weigh 0, hyper-arcs 1. Each
    # solved hyper-arc lowers the inside cost of everything above it; recomputing them all
    # made a play quadratic (10 000 nodes: 203 s; here 27 million reads and writes of costs
    # and 18 000 per query before, 90 000 and at most 16 after). Work is counted, not timed.
    n = 3000
    g = AndOrGraph("chain", root=f"n{n - 1}")
    for i in range(n):
        g.add_node(f"n{i}", 0)
    for i in range(n - 1):
        g.add_hyperarc(f"h{i}", [f"n{i}"], f"n{i + 1}", 1)
    online = OnlineGraph(g)
    # every inside and outside cost, and the out-of-date marks, read and written through these
    for costs in ("_inside", "_out_val", "_stale"):
        setattr(online, costs, Counting(getattr(online, costs)))
    answer = online.query()
    per_query = []
    solved = 0
    while answer.outcome == "running":
        ((e, cost),) = answer.element_ids.items()  # one feasible element at a time
        name = online.element_name(e)
        assert cost == n - 1 - solved  # the hyper-arcs left
        before = Counting.n
        if online.kind(name) == "node":
            answer = online.update(met_nodes=[name])
        else:
            answer = online.update(solved_hyperarcs=[name])
            solved += 1
        per_query.append(Counting.n - before)
    elements = 2 * n - 1
    assert answer.solved and len(per_query) == elements
    # the first solved hyper-arc marks everything above it out of date, once; then every
    # query reads and writes a few costs, however deep the chain still is above them
    assert sum(per_query) <= 30 * elements
    assert max(per_query[2:]) <= 50
    assert online.optimal_cost() == 0
