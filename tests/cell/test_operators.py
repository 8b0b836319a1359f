"""Operators that act on their own in a live cell: ``options`` -> ``intent`` (issue 11, item 1).

The operator agent decides (its profile, its seed); the manager says what is possible and keeps
the time order. These tests run the cell and its agents on the in-process bus; the processes over
Zenoh are in ``test_cell_processes.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell, EventStore, HumanAgent, RobotAgent
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model
from flexhrc.cell.store import read_store
from flexhrc.scenario import load_scenario
from flexhrc.transport import InProcessBus

from .helpers import Crash, pump_of


def _agents(scenario: Any, bus: InProcessBus, profile: str, seed: int) -> list[Any]:
    out: list[Any] = []
    for a in scenario.domain.agents.values():
        model = execution_model("analytic")
        if a.is_human:
            out.append(
                HumanAgent(a.name, scenario, bus, profile=profile, seed=seed, execution=model)
            )
        else:
            out.append(RobotAgent(a.name, scenario, bus, execution=model))
    return out


def _run(profile: str, seed: int = 0, store: EventStore | None = None) -> tuple[dict, Cell]:
    scenario = load_scenario("table_assembly", seed=seed)
    bus = InProcessBus()
    cell = Cell(
        scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"),
        seed=seed,
    )  # fmt: skip
    agents = _agents(scenario, bus, profile, seed)
    bus.flush()  # the operator's profile reaches the cell before the start
    data = cell.run(pump=pump_of(cell, bus, agents))
    return data, cell


def _trail(cell: Cell) -> list[tuple[str, Any]]:
    return [(e.kind, e.body) for e in cell.events if e.kind != "summary"]


@pytest.mark.parametrize("profile", ["passive", "takeover", "cooperative", "random"])
def test_every_profile_cooperates_and_decides_the_same_on_every_run(profile: str) -> None:
    data, cell = _run(profile, seed=3)
    assert data["outcome"] == "solved", data["reason"]
    kinds = [e.kind for e in cell.events]
    if profile == "passive":  # only when asked: the manager never offers it anything
        assert "options" not in kinds and "intent" not in kinds
        assert data["human_actions"] == 4  # the four checks it is asked for
    else:
        assert cell.events[0].body["operators"] == {"human": profile}
        assert kinds.count("options") == kinds.count("intent") > 0
    again, cell2 = _run(profile, seed=3)
    assert _trail(cell2) == _trail(cell)  # the discrete-event loop orders the operator too
    assert again["knowledge"] == data["knowledge"]


def test_a_takeover_operator_takes_every_leg_it_can() -> None:
    data, cell = _run("takeover")
    assert data["outcome"] == "solved"
    decides = [e.body for e in cell.events if e.kind == "human_decides"]
    assert len(decides) == 4  # one per bolt: it screws every leg itself
    screws = [e.body["action"] for e in cell.events if e.kind == "human_action"]
    assert sum(a.startswith("screw(human") for a in screws) == 4
    # the robots it overtook were stopped, their acks ignored; nothing was done twice
    fixed = [e.body["object"] for e in cell.events if e.kind == "fixed"]
    assert sorted(fixed) == sorted(set(fixed)) and len(fixed) == 4


def test_a_cooperative_operator_takes_some_steps_and_leaves_the_rest() -> None:
    data, cell = _run("cooperative")
    assert data["outcome"] == "solved"
    decides = [e.body for e in cell.events if e.kind == "human_decides"]
    intents = [e.body for e in cell.events if e.kind == "intent"]
    assert 0 < len(decides) < 4
    assert any(not i["act"] for i in intents)  # it let some steps go
    assert all(0.5 <= i["delay"] <= 2.0 for i in intents if i["act"])  # it thinks first


@pytest.mark.parametrize("profile", ["takeover", "cooperative"])
@pytest.mark.parametrize("crash_after", [12, 40])
def test_a_resumed_cell_decides_with_its_operator_as_before(
    tmp_path: Path, profile: str, crash_after: int
) -> None:
    """The manager dies (its operator and arms keep running); the resumed manager rebuilds the
    open ``options`` from the store, the operator answers them again, and the cooperation ends
    as the uninterrupted one."""
    ref, _ = _run(profile, seed=1)
    path = tmp_path / "s.db"
    scenario = load_scenario("table_assembly", seed=1)
    bus = InProcessBus()
    agents = _agents(scenario, bus, profile, 1)
    store = EventStore(path)
    cell = Cell(
        scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"),
        seed=1,
    )  # fmt: skip
    bus.flush()
    with pytest.raises(Crash):
        cell.run(pump=pump_of(cell, bus, agents, crash_after))
    cell.close()
    store.close()
    n = len(read_store(path))
    store = EventStore(path, resume=True)
    again = Cell(
        scenario, bus, store=store, resume=True, liveliness=False,
        simulator=execution_model("analytic"), seed=1,
    )  # fmt: skip
    data = again.run(pump=pump_of(again, bus, agents))
    store.close()
    assert data["outcome"] == "solved" and data["cell"]["resumed"]
    assert data["knowledge"] == ref["knowledge"]
    assert data["human_actions"] == ref["human_actions"]
    events = read_store(path)
    assert [e.seq for e in events] == list(range(1, len(events) + 1)) and len(events) > n
    oids = [e.body["id"] for e in events if e.kind == "options"]
    assert len(oids) == len(set(oids))  # an open options is sent again, never offered anew


@pytest.mark.parametrize("profile", ["takeover", "random"])
def test_flexhrc_cell_human_profile_is_the_run_cooperation(profile: str) -> None:
    import json
    import subprocess
    import sys

    from ..conftest import subprocess_env

    def cli(*args: str) -> dict[str, Any]:
        res = subprocess.run(
            [sys.executable, "-m", "flexhrc", *args, "--human", profile, "--json", "--quiet"],
            capture_output=True, text=True, env=subprocess_env(), timeout=120,
        )  # fmt: skip
        assert res.returncode == 0, res.stderr
        data: dict[str, Any] = json.loads(res.stdout)
        return data

    c, d = cli("cell", "table_assembly"), cli("run", "table_assembly")
    for key in ("outcome", "robot_actions", "human_actions", "decisions", "by_agent"):
        assert c[key] == d[key], key
    assert c["timing"]["total_s"] == d["timing"]["total_s"]


def test_bad_intents_and_options_are_dropped_and_logged() -> None:
    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents = _agents(scenario, bus, "takeover", 0)
    human = next(a for a in agents if isinstance(a, HumanAgent))
    bus.flush()
    bad: list[Any] = [
        {"v": 1, "type": "intent", "id": "x", "agent": "human", "options": "o99", "act": False,
         "decided": [], "t": 0.0},  # answers nothing it was asked
        {"v": 1, "type": "intent", "id": "y", "agent": "left", "options": "o1", "act": False,
         "decided": [], "t": 0.0},  # not an operator
        {"v": 1, "type": "intent", "id": "z", "agent": "human", "options": "o1", "act": True,
         "decided": [], "t": 0.0},  # to act, but on what?
        {"v": 1, "type": "intent", "id": "w", "agent": "human", "options": "o1", "act": True,
         "decided": ["s"], "step": "s", "hyperarc": "h", "actions": ["fly(human)"], "t": 1.0},
        {"v": 1, "type": "operator", "agent": "human", "profile": "lazy"},
        {"v": 2, "type": "intent"},
    ]  # fmt: skip
    for msg in bad:
        bus.publish(P.INTENT_TOPIC, msg)
    bus.flush()
    assert len(cell.dropped) == len(bad), cell.dropped
    assert "was not asked" in cell.dropped[0] and "not a human agent" in cell.dropped[1]
    assert "needs 'step'" in cell.dropped[2] and "fly" in cell.dropped[3]
    assert "unknown profile 'lazy'" in cell.dropped[4]
    assert cell.operators == {"human": "takeover"}
    # options the operator cannot read are dropped by it, never acted on
    bus.publish(P.options_topic("human"), {"v": 1, "type": "options", "id": "o7", "t": 0.0,
                                          "steps": [{"step": "s", "arcs": "all"}]})  # fmt: skip
    bus.flush()
    assert human.dropped == 1 and not human.intents
    data = cell.run(pump=pump_of(cell, bus, agents))
    assert data["outcome"] == "solved"  # the cooperation unaffected


def test_the_operator_answers_repeated_options_the_same_way() -> None:
    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    operator = HumanAgent("human", scenario, bus, profile="random", seed=5)
    sent: list[Any] = []
    bus.subscribe(P.INTENT_TOPIC, sent.append)
    steps = [
        {"step": f"connected_{k}", "arcs": [{"hyperarc": f"human_{k}", "cost": 1.0, "branches": [
            [f"pick_up(human, leg{k})", f"screw(human, leg{k}, bolt_{k})"]]}]}
        for k in (1, 2, 3)
    ]  # fmt: skip
    for _ in range(2):
        bus.publish(P.options_topic("human"), P.message("options", id="o1", t=2.0, steps=steps))
        bus.flush()
    bus.flush()  # the second answer
    intents = [m for m in sent if m["type"] == "intent"]
    assert operator.received == 2 and len(operator.intents) == 1
    assert len(intents) == 2 and intents[0] == intents[1]
    first = intents[0]
    if first["act"]:
        assert first["t"] == pytest.approx(2.0 + first["delay"])
        assert first["decided"][-1] == first["step"]  # it stops deciding once it acts
    else:
        assert first["decided"] == ["connected_1", "connected_2", "connected_3"]


def test_a_take_at_the_panel_is_a_stored_input_a_resumed_cell_replays(tmp_path: Path) -> None:
    """`Cell.human_take` ("I'll do this"): checked, stored as `human_take`, replayed by
    `--resume` — the resumed cooperation ends as the uninterrupted one with the same take."""
    from flexhrc.taskmanager.manager import TakeRefused

    def run(store: EventStore | None, crash_after: int | None) -> tuple[dict | None, Cell]:
        scenario = load_scenario("table_assembly")
        bus = InProcessBus()
        cell = Cell(
            scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic")
        )
        agents = _agents(scenario, bus, "passive", 0)
        taken: list[str] = []

        def pump(timeout: float) -> None:
            if crash_after is not None and len(cell.events) >= crash_after:
                raise Crash
            if not taken and len(cell.events) >= 8:
                for h in sorted(cell.tm.feasible_hyperarcs()):
                    try:
                        cell.tm.check_take(h)
                    except TakeRefused:
                        continue
                    assert cell.human_take(h)  # the actions the operator is asked to do
                    taken.append(h)
                    break
            bus.flush()
            for a in agents:
                a.poll()

        try:
            return cell.run(pump=pump), cell
        except Crash:
            return None, cell

    ref, ref_cell = run(None, None)
    assert ref is not None and ref["outcome"] == "solved"
    takes = [e.body for e in ref_cell.events if e.kind == "human_take"]
    assert len(takes) == 1 and ref["human_actions"] > 4  # it did a leg besides the checks
    with pytest.raises(TakeRefused, match="unknown hyper-arc"):
        ref_cell.tm.check_take("no_such_arc")

    path = tmp_path / "s.db"
    store = EventStore(path)
    _, cell = run(store, 20)
    cell.close()
    store.close()
    assert [e.kind for e in read_store(path)].count("human_take") == 1
    store = EventStore(path, resume=True)
    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    again = Cell(
        scenario, bus, store=store, resume=True, liveliness=False,
        simulator=execution_model("analytic"),
    )  # fmt: skip
    agents = _agents(scenario, bus, "passive", 0)
    data = again.run(pump=pump_of(again, bus, agents))
    store.close()
    assert data["outcome"] == "solved"
    assert data["knowledge"] == ref["knowledge"]
    assert data["human_actions"] == ref["human_actions"]
    assert [e.kind for e in read_store(path)].count("human_take") == 1
