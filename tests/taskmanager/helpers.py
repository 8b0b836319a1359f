"""Shared helpers: a fixed layout, a runner, and invariant checks on event logs."""

from __future__ import annotations

import itertools
import re
from collections import defaultdict
from typing import Any

from flexhrc.cell.local import LocalCell, RunResult
from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.taskmanager import AnalyticSimulator

# legs on both sides of the tabletop, two per side
LAYOUT = [(0.35, 0.30, 0.0), (0.50, 0.32, 0.0), (0.35, -0.30, 0.0), (0.50, -0.32, 0.0)]


def run_table(
    profile: str = "passive", *, seed: int = 0, layout=LAYOUT, run_kw=None, **scenario_kw
):
    sc = table_assembly(segments="legs", seed=seed, leg_positions=layout, **scenario_kw)
    kw = {"simulator": AnalyticSimulator(), **(run_kw or {})}  # fast; the kinematic one is tested
    run = LocalCell(sc, profile=profile, seed=seed, **kw)
    return run.run(), run


def solved(result: RunResult) -> list[tuple[str, tuple[str, ...]]]:
    """(hyper-arc, agents that carried it out), in the order they were solved."""
    return [(e["element"], tuple(e["agents"])) for e in result.events if e["type"] == "solved"]


ARGS = re.compile(r"^(\w+)\((.*)\)$")


def parse(action: str) -> tuple[str, list[str]]:
    m = ARGS.match(action)
    assert m, action
    return m.group(1), [a.strip() for a in m.group(2).split(",")]


def holdings(result: RunResult) -> dict[str, list[tuple[float, float, str]]]:
    """Who holds which leg when: from grasp/pick_up to ungrasp/screw/put_down or a stop."""
    open_: dict[str, tuple[str, float]] = {}  # agent -> (leg, since)
    out: dict[str, list[tuple[float, float, str]]] = defaultdict(list)
    end_t = 0.0
    for ev in result.events:
        if ev["type"] != "action_end":
            continue
        t = float(ev["t"])
        end_t = max(end_t, t)
        name, args = parse(ev["action"])
        for agent in ev["agents"]:
            held = open_.get(agent)
            if ev["status"] == "done" and name in ("grasp", "pick_up"):
                open_[agent] = (args[1], t)
            elif held and (
                ev["status"] != "done"
                or name in ("ungrasp", "put_down")
                or (name == "screw" and agent == "human")
            ):
                out[held[0]].append((held[1], t, agent))
                del open_[agent]
    for agent, (leg, since) in open_.items():
        out[leg].append((since, end_t, agent))
    return out


def check_invariants(result: RunResult, legs: int) -> None:
    """No arm or leg double-booked, every bolt filled exactly once (from the event log)."""
    per_agent: dict[str, list[tuple[float, float]]] = defaultdict(list)
    screws: dict[str, int] = defaultdict(int)
    connected_legs: dict[str, int] = defaultdict(int)
    for ev in result.events:
        if ev["type"] != "action_end":
            continue
        name, args = parse(ev["action"])
        for agent in ev["agents"]:
            per_agent[agent].append((float(ev["start"]), float(ev["t"])))
        if name == "screw" and ev["status"] == "done":
            screws[args[2]] += 1
            connected_legs[args[1]] += 1
    for agent, spans in per_agent.items():
        spans.sort()
        for (_, e0), (s1, _) in itertools.pairwise(spans):
            assert s1 >= e0 - 1e-9, f"{agent} runs two actions at once at t={s1}"
    for leg, spans in holdings(result).items():
        spans.sort()
        for (_, e0, a0), (s1, _, a1) in itertools.pairwise(spans):
            assert s1 >= e0 - 1e-9, f"{leg} held by {a0} and {a1} at once (t={s1})"
    assert dict(screws) == {f"bolt_{k}": 1 for k in range(1, legs + 1)}, dict(screws)
    assert all(n == 1 for n in connected_legs.values()), dict(connected_legs)
    assert len(connected_legs) == legs  # no leg left unconnected


def first(events: list[dict[str, Any]], kind: str) -> dict[str, Any]:
    return next(e for e in events if e["type"] == kind)
