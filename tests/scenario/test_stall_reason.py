"""A run that cannot go on names what waits on what (taskmanager.diagnose.stall_reason)."""

from __future__ import annotations

from pathlib import Path

import pytest

from flexhrc import scenario
from flexhrc.taskmanager import TaskManager
from flexhrc.taskmanager.diagnose import DEADLOCK, stall_reason

#: put_cover puts the cover on the housing; the alternative that closes the housing needs it
#: unlocked, which nothing ever makes true: put_cover is solved, cover_on is never met
COVER = """\
flexhrc: 1
name: cover_task
graphs:
  cover_task:
    root: cover_on
    nodes:
      - {name: ready, state: "on_table(cover)"}
      - {name: cover_on, state: "on(cover, housing) & closed(housing)"}
    hyperarcs:
      - name: put_cover
        children: [ready]
        parent: cover_on
        weight: 1
        actions: ["pick(?who, cover)", "put(?who, cover, housing)"]
      - name: close_it
        children: [ready]
        parent: cover_on
        weight: CLOSE_WEIGHT
        actions: ["close(?who, housing)"]
domain:
  agents:
    human: {kind: human, types: [human], hand: [1.0, 0.0, 0.1]}
    arm: {kind: robot, types: [robot], base: [0.0, 0.0, 0.4], rest: [0.3, 0.0, 0.5], reach: 0.9}
  actions:
    pick:
      parameters: {"?who": agent, "?p": part}
      agents: {choice: "?who"}
      pre: ["on_table(?p)", "free(?who)"]
      add: ["holding(?who, ?p)"]
      delete: ["on_table(?p)", "free(?who)"]
      duration: 1.0
    put:
      parameters: {"?who": agent, "?p": part, "?on": part}
      agents: {choice: "?who"}
      pre: ["holding(?who, ?p)"]
      add: ["on(?p, ?on)", "free(?who)"]
      delete: ["holding(?who, ?p)"]
      duration: 1.0
    close:
      parameters: {"?who": agent, "?x": part}
      agents: {choice: "?who"}
      pre: ["unlocked(?x)"]
      add: ["closed(?x)"]
      duration: 1.0
world:
  objects:
    cover: {type: part, position: [0.4, 0.2, 0.0]}
    housing: {type: part, position: [0.5, 0.0, 0.0]}
  facts: ["on_table(cover)", "free(arm)", "free(human)"]
humans:
  - {name: human, profile: passive, speed: 1.0}
"""


def _load(tmp_path: Path, close_weight: float = 5, text: str = COVER) -> scenario.Scenario:
    path = tmp_path / "cover.yaml"
    path.write_text(text.replace("CLOSE_WEIGHT", str(close_weight)), encoding="utf-8")
    return scenario.load(path)


def test_the_old_sentence_starts_the_reason():
    assert DEADLOCK == "deadlock: no agent has anything to do and the task is not solved"


@pytest.mark.parametrize("seed", [0, 1])
def test_a_run_names_the_node_its_solved_hyper_arc_and_the_false_literal(tmp_path, seed):
    result = scenario.run(_load(tmp_path), seed=seed)
    assert result.outcome == "failed"
    assert result.reason == (
        f"{DEADLOCK}: node cover_on waits for closed(housing) (its hyper-arc put_cover is solved)"
    )


def test_a_precondition_no_agent_can_satisfy_is_named(tmp_path):
    # close_it is cheaper: tried first, every grounding fails its precondition -> infeasible
    result = scenario.run(_load(tmp_path, close_weight=0.5), seed=0)
    assert result.outcome == "failed"
    assert result.reason.startswith(f"{DEADLOCK}: ")
    parts = result.reason.removeprefix(f"{DEADLOCK}: ").split("; ")
    assert "node cover_on waits for closed(housing) (its hyper-arc put_cover is solved)" in parts
    infeasible = [p for p in parts if p.startswith("hyper-arc close_it (into cover_on)")]
    assert len(infeasible) == 1
    assert "is infeasible: every branch fails a precondition" in infeasible[0]
    assert "does not hold: unlocked(housing)" in infeasible[0]


def _manager(sc: scenario.Scenario) -> TaskManager:
    return TaskManager(sc.online_graph(), sc.domain, sc.world(), simulator=sc.make_simulator())


def test_an_execution_waiting_for_its_agent_is_named(tmp_path):
    tm = _manager(_load(tmp_path))
    directives = tm.start(0.0)
    assert directives  # the first step went out (to the arm or, suggested, to the human)
    reason = stall_reason(tm)
    (ex,) = tm.executions.values()
    step = ex.branch.steps[0]
    if ex.owner == "human":
        assert f"hyper-arc put_cover waits for human to do {step} (suggested)" in reason
    else:
        assert f"hyper-arc put_cover waits for {ex.agents[0]} to finish {step}" in reason


def test_an_agent_that_left_the_cell_is_named(tmp_path):
    # only the arm may pick and put: with the arm gone nothing can start
    text = COVER.replace(
        'parameters: {"?who": agent, "?p": part}\n      agents: {choice: "?who"}',
        'parameters: {"?who": robot, "?p": part}\n      agents: {choice: "?who"}',
    )
    tm = _manager(_load(tmp_path, close_weight=5, text=text))
    tm.set_available(0.0, "arm", False)
    assert tm.start(0.0) == []
    reason = stall_reason(tm)
    assert reason.startswith(f"{DEADLOCK}: ")
    assert (
        "hyper-arc put_cover (into cover_on) cannot start: it needs arm (arm has left the cell)"
        in reason
    )
    assert reason.endswith("agents that left the cell: arm")
