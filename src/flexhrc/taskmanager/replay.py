"""Summaries recomputed from a saved cooperation log (``flexhrc replay LOG``).

Counts and simulated times come from the logged actions and decisions themselves; the
wall-clock compute times (Task Manager, representation, simulator) cannot be recomputed and are
read from the log's closing ``summary`` event when there is one.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any


def summarise_log(events: Iterable[dict[str, Any]]) -> dict[str, Any]:
    events = list(events)
    robot_actions = human_actions = 0
    robot_s = human_s = 0.0
    legs: dict[str, int] = {}
    decisions = branches = 0
    outcome, reason = "running", None
    end = 0.0
    for ev in events:
        end = max(end, float(ev.get("t", 0.0)))
        kind = ev.get("type")
        if kind == "start":
            for agent in ev.get("agents", []):
                legs.setdefault(agent, 0)
        elif kind == "decision":
            decisions += 1
            branches += len(ev.get("branches", []))
        elif kind == "outcome":
            outcome, reason = ev["outcome"], ev.get("reason")
        elif kind == "action_end":
            dt = float(ev["t"]) - float(ev["start"])
            human = "human" in ev["agents"]
            if human:
                human_s += dt
            else:
                robot_s += dt
            if ev["status"] != "done":
                continue
            if human:
                human_actions += 1
            else:
                robot_actions += 1
            if ev["action"].startswith("screw("):
                for agent in ev["agents"]:
                    legs[agent] = legs.get(agent, 0) + 1
    closing: dict[str, Any] = next(
        (ev for ev in reversed(events) if ev.get("type") == "summary"), {}
    )
    compute = closing.get("timing", {})
    return {
        "outcome": outcome,
        "reason": reason,
        "robot_actions": robot_actions,
        "human_actions": human_actions,
        "decisions": decisions,
        "branches_simulated": branches,
        "timing": {
            "task_manager_s": compute.get("task_manager_s", 0.0),
            "task_representation_s": compute.get("task_representation_s", 0.0),
            "simulator_s": compute.get("simulator_s", 0.0),
            "robot_actions_s": round(robot_s, 6),
            "human_actions_s": round(human_s, 6),
            "total_s": round(end, 6),
        },
        "legs_by_agent": legs,
    }
