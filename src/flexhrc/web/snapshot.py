"""The JSON state the panel shows, built from a Task Manager (no I/O, no web dependency).

:func:`graph_snapshot` describes every graph instance of a hierarchical AND/OR graph with the
statuses of paper 000 (section IV, eqs. 6-7): a node is ``met``, ``feasible``, ``infeasible``
(can no longer be reached) or ``pending``; a hyper-arc ``solved``, ``feasible``, ``infeasible``
or ``pending``. Lower-graph instances (eqs. 12-19) are listed after the instance that uses them,
with the qualified name of their upper hyper-arc, so the page can fold them.

:func:`suggestions` lists the feasible elements, cheapest first, with the cost of eq. (10), the
graph instance, and to whom the Task Manager gave them (an arm, the operator, or nobody yet).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from flexhrc.representation import OnlineGraph
from flexhrc.representation.hierarchy import qualify
from flexhrc.taskmanager.manager import TaskManager
from flexhrc.taskmanager.words import plain_words
from flexhrc.web.backend import json_safe

TIMELINE_LIMIT = 300  # entries of the timeline kept in a snapshot (the store keeps them all)


def feasible_costs(graph: OnlineGraph) -> dict[str, float]:
    """Suggestion costs of the feasible elements, read without querying the graph (a query
    counts in the graph's history; the panel only looks)."""
    return {s.element: s.cost for s in graph.suggestions()}


def _status(graph: OnlineGraph, name: str, done: str, is_done: Callable[[str], bool]) -> str:
    """A node's or hyper-arc's status as the panel colours it (``done``: met / solved)."""
    if is_done(name):
        return done
    if graph.is_feasible(name):
        return "feasible"
    return "infeasible" if graph.is_blocked(name) else "pending"


def graph_snapshot(
    graph: OnlineGraph,
    costs: Mapping[str, float],
    running: Mapping[str, str] | None = None,
) -> list[dict[str, Any]]:
    """Every graph instance with its nodes and hyper-arcs and their statuses.

    ``costs`` are the suggestion costs of the feasible elements; ``running`` maps an element
    being carried out to its owner (``"robot"`` or ``"human"``).
    """
    running = running or {}

    def element(path: str, local: str, done: str, is_done: Callable[[str], bool]) -> dict[str, Any]:
        name = qualify(path, local)
        status = _status(graph, name, done, is_done)
        return {"id": name, "name": local, "status": status, "cost": costs.get(name)}

    out: list[dict[str, Any]] = []
    for info in graph.hierarchy.instances():
        definition = graph.hierarchy.graphs[info.key]
        nodes = [
            {
                **element(info.path, local, "met", graph.is_met),
                "root": local == definition.root,
                "weight": node.weight,
            }
            for local, node in definition.nodes.items()
        ]
        arcs = [
            {
                **element(info.path, local, "solved", graph.is_solved),
                "weight": h.weight,
                "children": [qualify(info.path, c) for c in h.children],
                "parent": qualify(info.path, h.parent),
                "actions": list(h.actions),
                "lower": qualify(info.path, local) if h.lower is not None else None,
                "running": running.get(qualify(info.path, local)),
            }
            for local, h in definition.hyperarcs.items()
        ]
        out.append(
            {
                "path": info.path,
                "name": definition.name,
                "depth": info.depth,
                "upper": info.upper,
                "nodes": nodes,
                "hyperarcs": arcs,
            }
        )
    return json_safe(out)


def suggestions(tm: TaskManager) -> list[dict[str, Any]]:
    """Feasible elements, cheapest first: ``{element, kind, cost, graph, graph_name, to, owner,
    actions, next, next_text}``. ``to`` lists the agents the element was given to (empty:
    nobody yet); ``next`` is the ground action to do next when it was given to someone and
    ``next_text`` the same in plain words (:func:`~flexhrc.taskmanager.words.plain_words`)."""
    names = tuple(tm.domain.agents)
    out = []
    for s in tm.graph.suggestions():
        ex = tm.executions.get(s.element)
        item: dict[str, Any] = {**s.to_dict(), "to": [], "owner": None, "actions": [], "next": None}
        if ex is not None:
            item["to"] = list(ex.branch.agents)
            item["owner"] = ex.owner
            item["actions"] = [str(a) for a in ex.branch.steps]
            item["done"] = ex.next_index
            if ex.next_index < len(ex.branch.steps):
                item["next"] = str(ex.branch.steps[ex.next_index])
                item["next_text"] = plain_words(ex.branch.steps[ex.next_index], names)
        out.append(item)
    return json_safe(out)


def progress(instances: list[dict[str, Any]]) -> dict[str, int]:
    """Steps done and steps to do, for the person's progress bar: ``done`` counts the solved
    hyper-arcs; ``todo`` the unsolved hyper-arcs of the cheapest way from the current state to
    the goal (the AND/OR solution graph of least cost, eq. 10, read off the snapshot of
    :func:`graph_snapshot`; a hyper-arc that opens a lower graph counts that graph's steps)."""
    by_path = {inst["path"]: inst for inst in instances}
    lower_of = {inst["upper"]: inst["path"] for inst in instances if inst.get("upper")}
    done = sum(1 for inst in instances for h in inst["hyperarcs"] if h["status"] == "solved")

    def todo(inst: dict[str, Any]) -> int:
        met = {n["id"] for n in inst["nodes"] if n["status"] == "met"}
        ways: dict[str, list[dict[str, Any]]] = {}
        for h in inst["hyperarcs"]:
            if h["status"] != "infeasible":
                ways.setdefault(h["parent"], []).append(h)
        best: dict[str, tuple[float, dict[str, Any] | None]] = {}

        def cost(node: str, seen: frozenset[str]) -> float:
            if node in met:
                return 0.0
            if node in best:
                return best[node][0]
            if node in seen:  # a cycle is no way to the goal
                return float("inf")
            choice: tuple[float, dict[str, Any] | None] = (float("inf"), None)
            for h in ways.get(node, []):
                c = float(h["weight"]) + sum(cost(ch, seen | {node}) for ch in h["children"])
                if c < choice[0]:
                    choice = (c, h)
            best[node] = choice
            return choice[0]

        roots = [n["id"] for n in inst["nodes"] if n.get("root")]
        if not roots or cost(roots[0], frozenset()) == float("inf"):
            return 0
        count, stack, counted = 0, [roots[0]], set()
        while stack:
            node = stack.pop()
            h = best.get(node, (0.0, None))[1] if node not in met else None
            if h is None or h["id"] in counted:
                continue
            counted.add(h["id"])
            lower = lower_of.get(h["id"])
            count += todo(by_path[lower]) if lower is not None and lower in by_path else 1
            stack.extend(h["children"])
        return count

    top = by_path.get("")
    return {"done": done, "todo": todo(top) if top is not None else 0}


__all__ = ["TIMELINE_LIMIT", "feasible_costs", "graph_snapshot", "progress", "suggestions"]
