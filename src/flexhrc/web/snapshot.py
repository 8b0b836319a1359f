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
    actions, next}``. ``to`` lists the agents the element was given to (empty: nobody yet);
    ``next`` is the ground action to do next when it was given to someone."""
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
        out.append(item)
    return json_safe(out)


__all__ = ["TIMELINE_LIMIT", "feasible_costs", "graph_snapshot", "suggestions"]
