"""An independent check of a plan's schedule against the scenario (not the planner's model).

It reads the AND/OR graph and the domain as the scenario file gives them and checks, from the
schedule alone: the hyper-arcs taken form one cooperation path to the goal (the root reached,
each reached node reached by exactly one hyper-arc taken, each hyper-arc taken has its children
reached and leads to a reached node), a hyper-arc's actions are its A(h) in order, one after the
other; it starts after every child it needs is met (a node with a process: after the process);
every agent does one action at a time; a joint action is on every agent it names; an agent does
only actions it is able to do (agents(a) of eq. 20); the makespan is the last end.

A hierarchy of graphs (paper 000, IV-B) is expanded here on its own terms: a hyper-arc with a
lower graph stands for an instance of it, named ``HYPERARC/ELEMENT`` under the path of the
hyper-arc that calls it; the instance's root is reached when that hyper-arc is taken, its leaves
are met no earlier than the hyper-arc's children (the instance is active, eq. 17) and the
hyper-arc is done when the instance's root is met (eq. 18).
"""

from __future__ import annotations

import re
from itertools import pairwise
from typing import Any

EPS = 1e-6


def _parse(text: str) -> tuple[str, list[str]]:
    m = re.fullmatch(r"\s*([A-Za-z_][\w]*)\((.*)\)\s*", text)
    assert m, f"not an action: {text!r}"
    args = [a.strip() for a in m.group(2).split(",") if a.strip()]
    return m.group(1), args


def validate(scenario: Any, data: dict[str, Any]) -> list[str]:
    """Every broken rule of the plan ``data`` (``Plan.to_json()``) as one line; [] if none."""
    problems: list[str] = []
    g = _flat(scenario.graph)
    domain = scenario.domain
    schedule = data["schedule"]
    by_arc: dict[str, list[dict[str, Any]]] = {}
    processes: dict[str, list[dict[str, Any]]] = {}
    for e in schedule:
        if e["hyperarc"] in g.hyperarcs:
            by_arc.setdefault(e["hyperarc"], []).append(e)
        elif e["hyperarc"] in g.nodes:
            processes.setdefault(e["hyperarc"], []).append(e)
        else:
            problems.append(f"{e['hyperarc']}: neither a hyper-arc nor a node")
        if e["end_s"] < e["start_s"] - EPS:
            problems.append(f"{e['action']}: ends before it starts")
    taken = set(by_arc) | {
        h for h, arc in g.hyperarcs.items() if not arc.actions and h not in g.lower
    }
    # a hyper-arc with a lower graph is taken when actions of its instance are scheduled
    taken |= {h for h in g.lower if any(a.startswith(h + "/") for a in by_arc)}
    # zero-action hyper-arcs carry no entry: take those whose parent is needed (below)
    # -- one cooperation path ------------------------------------------------------------
    incoming: dict[str, list[str]] = {n: [] for n in g.nodes}
    for h, arc in g.hyperarcs.items():
        incoming[arc.parent].append(h)
    reached = {g.root}
    todo = [g.root]
    path: set[str] = set()
    while todo:
        n = todo.pop()
        into = [h for h in incoming[n] if h in taken]
        if incoming[n] and len(into) != 1:
            problems.append(f"node {n}: reached by {len(into)} hyper-arcs taken ({into})")
        for h in into:
            path.add(h)
            below = [g.lower[h]] if h in g.lower else []
            for c in [*g.hyperarcs[h].children, *below]:
                if c not in reached:
                    reached.add(c)
                    todo.append(c)
    extra = {h for h in by_arc if h not in path}
    if extra:
        problems.append(f"hyper-arcs off the cooperation path: {sorted(extra)}")
    # -- each hyper-arc: its actions in order, after its children ----------------------------
    end_of: dict[str, float] = {}
    for h in path:
        if h in g.lower:
            if h in by_arc:
                problems.append(f"{h}: actions of its own, but its lower graph carries it out")
            continue
        arc = g.hyperarcs[h]
        entries = sorted(by_arc.get(h, []), key=lambda e: e["start_s"])
        names = [_parse(e["action"])[0] for e in entries]
        want = [_parse(a)[0] for a in arc.actions]
        if names != want:
            problems.append(f"{h}: actions {names}, A(h) is {want}")
        for a, b in pairwise(entries):
            if b["start_s"] < a["end_s"] - EPS:
                problems.append(f"{h}: {b['action']} starts before {a['action']} ends")
        if entries:
            end_of[h] = max(e["end_s"] for e in entries)
    met_at: dict[str, float] = {}

    def met(n: str) -> float:
        if n not in met_at:
            into = [h for h in incoming[n] if h in path]
            t = 0.0
            up = g.activated_by.get(n)
            if up is not None:  # a lower instance's leaf: met once the instance is active
                t = max([0.0, *(met(c) for c in g.hyperarcs[up].children)])
            if into and into[0] in g.lower:  # done by its lower instance
                h = into[0]
                t = met(g.lower[h])
                end_of[h] = t
            elif into:
                h = into[0]
                first = min((e["start_s"] for e in by_arc.get(h, [])), default=None)
                start = (
                    first
                    if first is not None
                    else max([0.0, *(met(c) for c in g.hyperarcs[h].children)])
                )
                t = max(t, end_of.get(h, start))
            for p in processes.get(n, []):
                if p["start_s"] < t - EPS:
                    problems.append(f"process of {n} starts before {n} is reached")
                t = max(t, p["end_s"])
            met_at[n] = t
        return met_at[n]

    for h in path:
        if h in g.lower:
            continue
        entries = by_arc.get(h, [])
        if not entries:
            continue
        start = min(e["start_s"] for e in entries)
        for c in g.hyperarcs[h].children:
            if start < met(c) - EPS:
                problems.append(f"{h} starts at {start:g} before its child {c} is met ({met(c):g})")
    # -- agents: able, joint actions on all, one action at a time ------------------------------
    lanes: dict[str, list[tuple[float, float, str]]] = {}
    for e in schedule:
        name, args = _parse(e["action"])
        is_process = e["hyperarc"] in g.nodes
        schema = (domain.processes if is_process else domain.actions).get(name)
        if schema is None:
            problems.append(f"{e['action']}: no such action in the domain")
            continue
        spec = schema.agents
        if spec.mode in ("single", "joint"):
            want_agents = set(spec.names)
        else:
            i = [v for v, _ in schema.parameters].index(str(spec.variable))
            want_agents = {args[i]}
        if set(e["agents"]) != want_agents:
            problems.append(f"{e['action']}: agents {e['agents']}, the action names {want_agents}")
        able = {a.name for a in domain.capable(schema)}
        for a in e["agents"]:
            if a not in able:
                problems.append(f"{e['action']}: {a} is not able to do it")
            lanes.setdefault(a, []).append((e["start_s"], e["end_s"], e["action"]))
    for a, items in lanes.items():
        items.sort()
        for (s0, e0, t0), (s1, e1, t1) in pairwise(items):
            if s1 < e0 - EPS and e1 - s1 > EPS and e0 - s0 > EPS:
                problems.append(f"{a}: {t1} at {s1:g} overlaps {t0} (until {e0:g})")
    last = max((e["end_s"] for e in schedule), default=0.0)
    if data["makespan_s"] is not None and abs(data["makespan_s"] - last) > 1e-3:
        problems.append(f"makespan {data['makespan_s']} is not the last end {last}")
    # by_agent: the hyper-arcs each agent takes part in
    count: dict[str, int] = dict.fromkeys(domain.agents, 0)
    for h in path:
        for a in {a for e in by_arc.get(h, []) for a in e["agents"]}:
            count[a] += 1
    if data["by_agent"] != count:
        problems.append(f"by_agent {data['by_agent']} is not {count}")
    return problems


class _Arc:
    def __init__(self, children: list[str], parent: str, actions: tuple[str, ...]) -> None:
        self.children, self.parent, self.actions = children, parent, actions


class _Flat:
    """The hierarchy expanded: every node and hyper-arc of every instance, by qualified name."""

    def __init__(self) -> None:
        self.root = ""
        self.nodes: dict[str, None] = {}
        self.hyperarcs: dict[str, _Arc] = {}
        self.lower: dict[str, str] = {}  # hyper-arc -> its instance's root
        self.activated_by: dict[str, str] = {}  # instance leaf -> the hyper-arc calling it


def _flat(hierarchy: Any) -> _Flat:
    flat = _Flat()
    flat.root = hierarchy.top_graph.root
    todo: list[tuple[str, str, str | None]] = [("", hierarchy.top, None)]
    while todo:
        path, key, upper = todo.pop()
        graph = hierarchy.graphs[key]

        def q(name: str, path: str = path) -> str:
            return f"{path}/{name}" if path else name

        for n in graph.nodes:
            flat.nodes[q(n)] = None
        if upper is not None:
            flat.lower[upper] = q(graph.root)
            produced = {h.parent for h in graph.hyperarcs.values()}
            for n in graph.nodes:
                if n not in produced:
                    flat.activated_by[q(n)] = upper
        for h in graph.hyperarcs.values():
            flat.hyperarcs[q(h.name)] = _Arc(
                [q(c) for c in h.children], q(h.parent), tuple(h.actions)
            )
            if h.lower is not None:
                todo.append((q(h.name), h.lower, q(h.name)))
    return flat
