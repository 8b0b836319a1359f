"""The paper's reaction to an unsuggested human action (000, V-B) where it matters (issue 21,
item 3): on the shipped ``table_two_arms`` both arms work at once, so ``--reaction paper``
(every robot action stops, every arm rests) and ``conflicts`` (only the conflicting one stops)
give different runs — on the table assembly only one robot action ever runs at a time."""

from __future__ import annotations

import json
from typing import Any

import pytest

from flexhrc import scenario
from flexhrc.cell.local import RunResult
from flexhrc.cli import main

NAME = "table_two_arms"


def _run(reaction: str, takes: list[int] | None) -> RunResult:
    return scenario.run(scenario.load_scenario(NAME), reaction=reaction, human_takes=takes)


def _cooperation(result: RunResult) -> list[dict[str, Any]]:
    """The log without its closing summary (wall-clock compute differs from run to run)."""
    return [ev for ev in result.events if ev["type"] != "summary"]


def _running_at(result: RunResult, t: float) -> set[str]:
    """The robot agents with a command running at time ``t`` (started before, ended after)."""
    agents = scenario.load_scenario(NAME).domain.agents.values()
    robots = {a.name for a in agents if not a.is_human}
    return {
        agent
        for ev in result.events
        if ev["type"] == "action_end" and ev["start"] < t < ev["t"]
        for agent in ev["agents"]
        if agent in robots
    }


def _stops(result: RunResult) -> dict[str, str]:
    return {ev["agent"]: ev["reason"] for ev in result.events if ev["type"] == "stop"}


def _deciding(result: RunResult, element: str) -> list[dict[str, Any]]:
    return [ev for ev in result.events if ev["type"] == "decision" and ev["element"] == element]


def test_it_is_listed_with_the_shipped_scenarios(capsys):
    assert NAME in scenario.SHIPPED
    assert main(["scenario", "list", "--json"]) == 0
    assert NAME in [s["name"] for s in json.loads(capsys.readouterr().out)]


def test_both_arms_work_at_once_and_without_a_deviation_the_reactions_agree():
    conflicts, paper = _run("conflicts", None), _run("paper", None)
    assert conflicts.outcome == paper.outcome == "solved"
    assert _cooperation(conflicts) == _cooperation(paper)  # nothing unsuggested: no reaction
    first = next(ev for ev in conflicts.events if ev["type"] == "action_end")
    assert _running_at(conflicts, first["t"] - 1e-6) == {"left", "right"}
    assert {a for s in conflicts.summary["solved_hyperarcs"] for a in s["agent"].split("+")} == {
        "left",
        "right",
    }


@pytest.fixture(scope="module")
def deviated() -> dict[str, RunResult]:
    """The operator takes the first step it could do (bolt 1, the left arm's) with the spare leg
    while both arms are on their way: once under each reaction."""
    return {reaction: _run(reaction, [1]) for reaction in ("conflicts", "paper")}


def test_when_the_person_deviates_two_robot_actions_are_running(deviated):
    for result in deviated.values():
        recognised = next(ev for ev in result.events if ev["type"] == "recognised")
        assert recognised["element"] == "human_1"
        assert _running_at(result, recognised["t"] - 1e-6) == {"left", "right"}
    assert _cooperation(deviated["conflicts"]) != _cooperation(deviated["paper"])


def test_conflicts_stops_only_the_arm_whose_work_the_person_took(deviated):
    result = deviated["conflicts"]
    assert _stops(result) == {"left": "human does human_1"}
    assert len(_deciding(result, "robot_2")) == 1  # the right arm goes on with its leg
    solved = {s["hyperarc"]: s["agent"] for s in result.summary["solved_hyperarcs"]}
    assert solved == {"human_1": "human", "robot_2": "right"}
    assert result.outcome == "solved"


def test_paper_stops_every_arm_sends_it_to_rest_and_decides_again(deviated):
    result = deviated["paper"]
    stops = _stops(result)
    assert set(stops) == {"left", "right"}
    assert stops["right"] == "human did pick_up(human, leg3) (not suggested)"
    aborted = [ev["element"] for ev in result.events if ev["type"] == "abort"]
    assert aborted == ["robot_1", "robot_2"]
    t = next(ev["t"] for ev in result.events if ev["type"] == "recognised")
    rests = {
        ev["agents"][0]
        for ev in result.events
        if ev["type"] == "command" and ev["action"].startswith("rest(") and ev["t"] == t
    }
    assert rests == {"left", "right"}  # every arm to its resting configuration
    assert len(_deciding(result, "robot_2")) == 2  # robot_2 is decided again after the rest
    assert result.outcome == "solved"
    # the cost of stopping work that did not conflict: a longer makespan than under conflicts
    conflicts = deviated["conflicts"].summary["timing"]["total_s"]
    assert result.summary["timing"]["total_s"] > conflicts
