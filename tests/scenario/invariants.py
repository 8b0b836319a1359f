"""Invariants of a cooperation, checked from its event log alone (plus the scenario's domain and
graph to read the log with) — nothing here looks inside the run.

* no agent runs two actions at once;
* no object is held by two agents at once (``holding(agent, obj)``, the domain's
  ``on_stop.holding``, replayed from the effects of the actions the log says were done) —
  unless they took it together, in one joint action (both arms on the tabletop, Fig. 8);
* every solved hyper-arc's actions ran in order, by the agents it names, before it was solved;
* the solved hyper-arcs form one cooperation path: replaying the log's graph reports into a
  fresh online graph solves it, each solved hyper-arc was feasible when solved, and no two of
  them in one graph instance share a child node (no OR alternative taken twice).
"""

from __future__ import annotations

import itertools
import re
from collections import defaultdict
from typing import Any

from flexhrc.logic import apply_substitution
from flexhrc.representation import OnlineGraph
from flexhrc.scenario import Scenario

CALL = re.compile(r"^(\w+)\((.*)\)$")


def parse_call(text: str) -> tuple[str, tuple[str, ...]]:
    m = CALL.match(text)
    assert m, text
    args = tuple(a.strip() for a in m.group(2).split(",")) if m.group(2).strip() else ()
    return m.group(1), args


def check_invariants(scenario: Scenario, events: list[dict[str, Any]]) -> None:
    ends = [e for e in events if e["type"] == "action_end"]
    _no_agent_twice(ends)
    _no_object_held_twice(scenario, events)
    _actions_in_order(scenario, events)
    _one_cooperation_path(scenario, events)


def _no_agent_twice(ends: list[dict[str, Any]]) -> None:
    spans: dict[str, list[tuple[float, float, str]]] = defaultdict(list)
    for ev in ends:
        for agent in ev["agents"]:
            spans[agent].append((float(ev["start"]), float(ev["t"]), ev["action"]))
    for agent, items in spans.items():
        items.sort()
        for (_, e0, a0), (s1, _, a1) in itertools.pairwise(items):
            assert s1 >= e0 - 1e-9, f"{agent} runs {a0} and {a1} at once (t={s1})"


def _no_object_held_twice(scenario: Scenario, events: list[dict[str, Any]]) -> None:
    domain = scenario.domain
    rule = domain.on_stop
    holder: dict[str, dict[str, tuple[Any, ...]]] = defaultdict(dict)  # obj -> agent -> taken by
    schemas = {**domain.actions, **domain.processes}
    for ev in events:
        if ev["type"] in ("stop", "abort"):
            agents = [ev["agent"]] if ev["type"] == "stop" else ev.get("agents", [])
            for a in agents:
                if domain.agent(a).is_human:
                    continue
                for held_by in holder.values():
                    held_by.pop(a, None)  # a stopped arm lets go where it is
            continue
        if ev["type"] != "action_end" or ev["status"] != "done":
            continue
        name, args = parse_call(ev["action"])
        schema = schemas[name]
        binding = dict(zip(schema.variables, args, strict=True))
        for lit in schema.delete:
            g = apply_substitution(lit, binding)
            held = g.predicate == rule.holding.predicate and len(g.args) == 2
            if held:
                holder[g.args[1]].pop(g.args[0], None)
        for lit in schema.add:
            g = apply_substitution(lit, binding)
            if g.predicate == rule.holding.predicate and len(g.args) == 2:
                agent, obj = g.args
                taken = (ev["start"], ev["action"])  # the arms of one joint action share it
                others = sorted(a for a, by in holder[obj].items() if a != agent and by != taken)
                assert not others, (
                    f"{obj} held by {', '.join(others)} and {agent} at once "
                    f"(t={ev['t']}, {ev['action']})"
                )
                holder[obj][agent] = taken


def _actions_in_order(scenario: Scenario, events: list[dict[str, Any]]) -> None:
    graph = OnlineGraph(scenario.graph)
    done = [e for e in events if e["type"] == "action_end" and e["status"] == "done"]
    for ev in events:
        if ev["type"] != "solved":
            continue
        definition = graph.definition_of(ev["element"])
        h = definition.hyperarcs[graph.local_name(ev["element"])]
        grounding = ev["grounding"]
        expected = []
        for text in h.actions:
            name, terms = parse_call(text)
            expected.append(f"{name}({', '.join(grounding.get(t, t) for t in terms)})")
        bound = float(ev["t"])
        agents = set(ev["agents"])
        for want in reversed(expected):
            match = [
                d
                for d in done
                if d["action"] == want
                and float(d["t"]) <= bound + 1e-9
                and set(d["agents"]) <= agents
            ]
            assert match, f"{ev['element']}: {want} not done by {agents} before t={bound}"
            last = max(match, key=lambda d: float(d["t"]))
            bound = float(last["start"])


def _one_cooperation_path(scenario: Scenario, events: list[dict[str, Any]]) -> None:
    graph = OnlineGraph(scenario.graph)
    solved: list[str] = []
    for ev in events:
        if ev["type"] != "query":
            continue
        report = ev.get("report", {})
        if report.get("met_nodes"):
            graph.update(met_nodes=report["met_nodes"])
        for h in report.get("solved_hyperarcs", []):  # one at a time: each must be feasible
            assert graph.is_feasible(h), f"{h} solved while not feasible"
            solved.append(h)
            graph.update(solved_hyperarcs=[h])
        if report.get("infeasible"):
            graph.update(infeasible=report["infeasible"])
    assert graph.solved, "replaying the log's reports does not solve the graph"
    by_instance: dict[str, list[str]] = defaultdict(list)
    for h in solved:
        by_instance[graph.graph_of(h)].append(h)
    for inst, arcs in by_instance.items():
        for a, b in itertools.combinations(arcs, 2):
            ca = set(_children(graph, a))
            cb = set(_children(graph, b))
            assert not ca & cb, f"{a} and {b} (graph {inst!r}) share children {ca & cb}"


def _children(graph: OnlineGraph, h: str) -> tuple[str, ...]:
    return graph.definition_of(h).hyperarcs[graph.local_name(h)].children
