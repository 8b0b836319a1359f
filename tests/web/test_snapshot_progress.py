"""The progress the operator's view shows (issue 24, item 1): steps done, and the steps of the
cheapest way from the current state to the goal (eq. 10's solution graph, read off the
snapshot)."""

from __future__ import annotations

from typing import Any

from flexhrc.web.snapshot import progress


def _inst(
    nodes: dict[str, str], arcs: list[tuple[str, list[str], str, float, str]], **kw: Any
) -> dict[str, Any]:
    return {
        "path": kw.get("path", ""),
        "upper": kw.get("upper"),
        "nodes": [
            {"id": n, "status": st, "root": n == kw.get("root", "goal")} for n, st in nodes.items()
        ],
        "hyperarcs": [
            {"id": h, "children": ch, "parent": p, "weight": w, "status": st}
            for h, ch, p, w, st in arcs
        ],
    }


def test_the_cheapest_way_is_counted_not_every_alternative() -> None:
    # start -> a -> goal (1 + 1) or start -> goal directly (5): two steps to do, none done
    g = _inst(
        {"start": "met", "a": "pending", "goal": "pending"},
        [
            ("s_a", ["start"], "a", 1, "feasible"),
            ("a_goal", ["a"], "goal", 1, "pending"),
            ("direct", ["start"], "goal", 5, "feasible"),
        ],
    )
    assert progress([g]) == {"done": 0, "todo": 2}


def test_solved_steps_are_done_and_an_and_arc_counts_both_branches() -> None:
    g = _inst(
        {"start": "met", "x": "met", "y": "pending", "goal": "pending"},
        [
            ("sx", ["start"], "x", 1, "solved"),
            ("sy", ["start"], "y", 1, "feasible"),
            ("join", ["x", "y"], "goal", 1, "pending"),
        ],
    )
    assert progress([g]) == {"done": 1, "todo": 2}


def test_a_step_with_a_lower_graph_counts_its_steps() -> None:
    top = _inst(
        {"start": "met", "goal": "pending"},
        [("build", ["start"], "goal", 1, "feasible")],
    )
    low = _inst(
        {"l0": "met", "l1": "pending", "l2": "pending"},
        [("b1", ["l0"], "l1", 1, "feasible"), ("b2", ["l1"], "l2", 1, "pending")],
        path="build",
        upper="build",
        root="l2",
    )
    assert progress([top, low]) == {"done": 0, "todo": 2}


def test_the_end_has_nothing_to_do() -> None:
    g = _inst({"start": "met", "goal": "met"}, [("sg", ["start"], "goal", 1, "solved")])
    assert progress([g]) == {"done": 1, "todo": 0}
