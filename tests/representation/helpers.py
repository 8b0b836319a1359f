"""Builders shared by the representation tests."""

from __future__ import annotations

from flexhrc.representation import AndOrGraph, HierarchicalGraph


def diamond() -> AndOrGraph:
    """root <- h1(a, b) | h2(b, c) ; a, b, c leaves. h1 and h2 share b."""
    g = AndOrGraph("diamond", root="root")
    for n, w in (("a", 1), ("b", 0), ("c", 2), ("root", 1)):
        g.add_node(n, w)
    g.add_hyperarc("h1", ["a", "b"], "root", 3)
    g.add_hyperarc("h2", ["b", "c"], "root", 1)
    return g


def two_layer() -> HierarchicalGraph:
    """top: t0 <- H(x, y) with a lower graph; lower: r <- l1(p) ; r <- l2(q)."""
    top = AndOrGraph("top", root="t0")
    for n in ("x", "y", "t0"):
        top.add_node(n)
    top.add_hyperarc("H", ["x", "y"], "t0", 100, lower="low")
    low = AndOrGraph("low", root="r")
    for n, w in (("p", 0), ("q", 0), ("r", 0)):
        low.add_node(n, w)
    low.add_hyperarc("l1", ["p", "q"], "r", 2)
    low.add_hyperarc("l2", ["q"], "r", 5)
    return HierarchicalGraph({"top": top, "low": low}, "top")
