"""Operator answers beyond "done" (issue 22, item 1): ``decline``, ``cannot``, ``start``,
``give_back`` and a request left unanswered for ``answer_timeout`` seconds.

The scenario: two lids to put on a box; the person stands by them (faster than the arm, so the
manager asks the person first, eq. 21), the arm can do it too. The operator is simulated in this
process (:class:`~flexhrc.cell.HumanAgent` with ``replies``); its answers are stored inputs, so a
resumed cell decides the same.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell, EventStore, HumanAgent, RobotAgent
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model
from flexhrc.cell.local import InjectedFailure, LocalCell
from flexhrc.cell.replay import replay
from flexhrc.cell.store import read_store
from flexhrc.errors import FlexhrcError
from flexhrc.scenario import load_scenario
from flexhrc.transport import InProcessBus

from .helpers import pump_of

LIDS = """\
flexhrc: 1
name: lids
description: Two lids onto a box; the person stands by them, the arm can do it too.
graphs:
  lids:
    root: closed
    nodes:
      - {name: ready, state: "on_table(lid_a) & on_table(lid_b)"}
      - {name: a_on, state: "on_box(lid_a)"}
      - {name: closed, state: "on_box(lid_a) & on_box(lid_b)"}
    hyperarcs:
      - {name: place_a, children: [ready], parent: a_on, weight: 1,
         actions: ["carry(?who, lid_a, box)"]}
      - {name: place_b, children: [a_on], parent: closed, weight: 1,
         actions: ["carry(?who, lid_b, box)"]}
domain:
  agents:
    human: {kind: human, types: [human], hand: [1.0, 0.0, 0.1]}
    arm: {kind: robot, types: [robot], base: [0.0, 0.0, 0.4], rest: [0.2, 0.0, 0.5], reach: 2.0}
  actions:
    carry:
      parameters: {"?who": agent, "?l": lid, "?to": container}
      agents: {choice: "?who"}
      pre: ["on_table(?l)"]
      add: ["on_box(?l)"]
      delete: ["on_table(?l)"]
      moves_to: "?to"
      carries: "?l"
      duration: 2.0
world:
  objects:
    lid_a: {type: lid, position: [1.0, 0.1, 0.0], size: [0.30, 0.20, 0.01]}
    lid_b: {type: lid, position: [1.0, -0.1, 0.0], size: [0.30, 0.20, 0.01]}
    box: {type: container, position: [1.1, 0.0, 0.0], size: [0.30, 0.20, 0.15], fixed: true}
  facts: ["on_table(lid_a)", "on_table(lid_b)"]
simulator: analytic
"""


@pytest.fixture
def lids(tmp_path: Path) -> Any:
    path = tmp_path / "lids.yaml"
    path.write_text(LIDS)
    return load_scenario(str(path), seed=0)


def _on(element: str, answer: Any) -> Any:
    """An operator that answers ``answer`` to every request for ``element``, does the rest."""
    return lambda el, actions, step: answer if el == element else None


def _events(result: Any, kind: str) -> list[dict[str, Any]]:
    return [e for e in result.events if e["type"] == kind]


def _done_by(result: Any) -> dict[str, list[str]]:
    out: dict[str, list[str]] = {}
    for e in _events(result, "action_end"):
        if e["status"] == "done":
            out.setdefault(e["agents"][0], []).append(e["action"])
    return out


def test_the_person_is_asked_first_and_does_both_lids(lids: Any) -> None:
    result = LocalCell(lids).run()
    assert result.outcome == "solved"
    assert [s["element"] for s in _events(result, "suggestion")] == ["place_a", "place_b"]
    assert result.summary["by_agent"] == {"human": 2, "arm": 0}


def test_a_declined_step_is_done_by_the_arm(lids: Any) -> None:
    result = LocalCell(lids, replies=_on("place_a", "decline")).run()
    assert result.outcome == "solved", result.reason
    [said] = _events(result, "human_declined")
    assert said["element"] == "place_a" and said["reply"] == "decline" and said["t"] == 1.0
    assert "carry(arm, lid_a, box)" in _done_by(result)["arm"]
    [cmd] = [c for c in _events(result, "command") if c["element"] == "place_a"]
    assert cmd["t"] == 1.0  # at the "not now", not later


def test_a_cannot_branch_is_never_offered_again_to_that_person(tmp_path: Path) -> None:
    # a second arm far away; the first drops the lid: place_a is planned again, and the
    # person, who is better at it (eq. 21) and was asked first, is not asked again
    path = tmp_path / "lids2.yaml"
    far = "    arm2: {kind: robot, types: [robot], base: [0.0, 1.0, 0.4], rest: [0.2, 1.0, 0.5], reach: 3.0}\n"
    path.write_text(LIDS.replace("  actions:\n", far + "  actions:\n", 1))
    scenario = load_scenario(str(path), seed=0)
    fail = InjectedFailure("carry", agent="arm")
    answer = _on("place_a", ("cannot", "my back"))
    result = LocalCell(scenario, replies=answer, failures=[fail]).run()
    assert result.outcome == "solved", result.reason
    asked = [s["element"] for s in _events(result, "suggestion")]
    assert asked.count("place_a") == 1
    assert len(_events(result, "action_failed")) == 1
    [said] = _events(result, "human_declined")
    assert said["reply"] == "cannot" and said["reason"] == "my back"  # the reason, in the log
    assert _done_by(result)["arm2"][0] == "carry(arm2, lid_a, box)"


def test_a_cannot_with_no_one_else_to_do_it_ends_the_cooperation(lids: Any) -> None:
    fail = InjectedFailure("carry", agent="arm")
    result = LocalCell(lids, replies=_on("place_a", ("cannot", "my back")), failures=[fail]).run()
    assert result.outcome == "failed"  # the arm failed, the person cannot: place_a is infeasible
    [infeasible] = _events(result, "infeasible")
    assert infeasible["element"] == "place_a"
    assert [s["element"] for s in _events(result, "suggestion")].count("place_a") == 1


def test_a_declined_step_whose_arm_failed_is_put_to_the_person_again(lids: Any) -> None:
    # the contrast: "not now" holds until the cooperation moves on
    fail = InjectedFailure("carry", agent="arm")
    answers = iter(["decline"])
    result = LocalCell(
        lids,
        replies=lambda el, actions, k: next(answers, None) if el == "place_a" else None,
        failures=[fail],
    ).run()
    assert result.outcome == "solved", result.reason
    assert len(_events(result, "action_failed")) == 1
    assert [s["element"] for s in _events(result, "suggestion")].count("place_a") >= 1


def test_an_unanswered_request_is_declined_after_the_answer_timeout(lids: Any) -> None:
    result = LocalCell(lids, replies=_on("place_a", "ignore"), answer_timeout=5.0).run()
    assert result.outcome == "solved", result.reason
    [said] = _events(result, "human_declined")
    assert said["reply"] == "decline" and said["t"] == 5.0
    assert "no answer after 5 s" in said["reason"]
    [cmd] = [c for c in _events(result, "command") if c["element"] == "place_a"]
    assert cmd["t"] == 5.0 and cmd["agents"] == ["arm"]


def test_without_a_timeout_an_unanswered_request_leaves_the_cell_stuck(lids: Any) -> None:
    result = LocalCell(lids, replies=_on("place_a", "ignore")).run()  # what the issue saw
    assert result.outcome == "failed"


def test_the_scenario_key_answer_timeout_and_bad_values(lids: Any) -> None:
    from dataclasses import replace

    timed = replace(lids, answer_timeout=2.5)
    result = LocalCell(timed, replies=_on("place_a", "ignore")).run()
    assert _events(result, "human_declined")[0]["t"] == 2.5
    with pytest.raises(FlexhrcError, match="--answer-timeout"):
        LocalCell(lids, answer_timeout=0)


def test_a_person_gives_back_a_step_they_had_taken(lids: Any) -> None:
    result = LocalCell(lids, replies=_on("place_a", "give_back")).run()
    assert result.outcome == "solved", result.reason
    [said] = _events(result, "human_declined")
    assert said["reply"] == "give_back" and said["element"] == "place_a"
    assert _done_by(result)["arm"][0] == "carry(arm, lid_a, box)"


def _cell(scenario: Any, store: EventStore, replies: Any, **kw: Any) -> tuple[Cell, Any]:
    bus = InProcessBus()
    cell = Cell(
        scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"), **kw
    )
    agents: list[Any] = [
        RobotAgent("arm", scenario, bus, execution=execution_model("analytic")),
        HumanAgent("human", scenario, bus, execution=execution_model("analytic"), replies=replies),
    ]
    return cell, pump_of(cell, bus, agents)


def test_a_start_without_a_start_in_the_report_reaches_replay(lids: Any, tmp_path: Path) -> None:
    # "I'm starting", then a "done" without its start (as the panel's done was): the cell
    # gives the report the start the person said, so replay counts the person's time
    path = tmp_path / "s.db"
    with EventStore(path) as store:
        cell, pump = _cell(lids, store, lambda el, actions, k: "start")
        data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    reports = [e.body for e in read_store(path) if e.kind == "human_action"]
    assert reports and all(r["start"] < r["t"] for r in reports)
    report = replay(path)
    assert report.json["timing"]["human_actions_s"] == pytest.approx(4.141421, abs=1e-5)
    lane = [e for e in report.events if e["type"] == "action_end" and e["agents"] == ["human"]]
    assert [e["t"] - e["start"] for e in lane] == [pytest.approx(2.141421), pytest.approx(2.0)]


@pytest.mark.parametrize(
    "answer", ["decline", ("cannot", "no tool"), "give_back", "ignore"], ids=str
)
def test_answers_are_stored_inputs_a_resumed_cell_decides_the_same(
    lids: Any, tmp_path: Path, answer: Any
) -> None:
    path = tmp_path / "s.db"
    with EventStore(path) as store:
        cell, pump = _cell(lids, store, _on("place_a", answer), answer_timeout=3.0)
        data = cell.run(pump=pump)
    assert data["outcome"] == "solved", data["reason"]
    stored = read_store(path)
    [reply] = [e for e in stored if e.kind == "human_reply"]
    assert reply.body["reply"] == (
        "decline" if answer == "ignore" else answer[0] if isinstance(answer, tuple) else answer
    )
    # a fresh manager replays the stored inputs: the same decisions, the same exclusions
    with EventStore(path, resume=True) as again_store:
        again = Cell(
            lids,
            InProcessBus(),
            store=again_store,
            resume=True,
            liveliness=False,
            simulator=execution_model("analytic"),
            answer_timeout=3.0,
        )
        assert again.tm.done and again.tm.outcome == "solved"
        assert again.tm.cannot == cell.tm.cannot
        assert again.kb.to_dict() == cell.kb.to_dict()


def test_a_reply_message_is_checked(lids: Any) -> None:
    ok = P.message("reply", id="h:1", agent="human", reply="decline", suggestion="s1", t=1.0)
    assert ok["reply"] == "decline"
    with pytest.raises(P.ProtocolError, match="one of decline, cannot, start, give_back"):
        P.parse({"v": 1, "type": "reply", "id": "h:2", "agent": "human", "reply": "maybe",
                 "suggestion": "s1", "t": 1.0})  # fmt: skip
    bus = InProcessBus()
    cell = Cell(lids, bus, liveliness=False, simulator=execution_model("analytic"))
    cell.started = True
    bus.publish(P.HUMAN_TOPIC, {**ok, "suggestion": "s9"})
    bus.publish(P.HUMAN_TOPIC, {**ok, "id": "h:4", "suggestion": None, "element": "closed"})
    bus.publish(P.HUMAN_TOPIC, {**ok, "id": "h:5", "suggestion": None})
    bus.flush()
    assert "human was sent no request s9" in cell.dropped[0]
    assert "'closed' is no hyper-arc" in cell.dropped[1]
    assert "human has no open request" in cell.dropped[2]
    assert not cell.pending


def test_an_operator_profile_that_answers_is_asked_once_per_request(lids: Any) -> None:
    """A profile with an ``answer`` (``reluctant``, :class:`SimulatedOperator`) says it when a
    request is put to it; "follow" does the step."""

    class Reluctant:
        def __init__(self) -> None:
            self.said: list[list[str]] = []

        def answer(self, actions: Any, domain: Any) -> tuple[str, str | None]:
            self.said.append([str(a) for a in actions])
            return ("cannot", "human cannot carry") if len(self.said) == 1 else ("follow", None)

    cell = LocalCell(lids)
    human = next(a for a in cell.agents if isinstance(a, HumanAgent))
    operator = Reluctant()
    human.operator = operator  # type: ignore[assignment]
    result = cell.run()
    assert result.outcome == "solved", result.reason
    [said] = _events(result, "human_declined")
    assert said["reply"] == "cannot" and said["reason"] == "human cannot carry"
    assert operator.said == [["carry(human, lid_a, box)"]]  # place_b went to the arm (a tie)
