"""Run identity (issue 20, build item 1): the probe of 2026-12-02, sections 1, 2, 3, 11 and 12.

Nothing used to tie a command id, an agent, a journal or a store to one run of one scenario:
agents answered a known command id from their memory whatever the run, two processes served one
arm, two managers one cell, ``--resume`` took a store of another task, agents of another scenario
joined silently. Each case of the report has a test here, named with its id; the process tests
run the manager and agents as ``python -m flexhrc`` over Zenoh on 127.0.0.1 (helpers.py).
"""

from __future__ import annotations

import importlib.util
import json
import logging
import os
import signal
import sqlite3
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell, HumanAgent, RobotAgent, identity
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model, run_agent, world_of
from flexhrc.cell.store import EventStore
from flexhrc.errors import FlexhrcError
from flexhrc.scenario import load_scenario
from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.transport import InProcessBus

from .helpers import (
    TABLE_NO_HUMAN,
    Crash,
    cell,
    executed,
    finish,
    flexhrc,
    human,
    kill_all,
    pump_of,
    robot,
    rows,
    simulated_agents,
    start_cell,
    wait_until,
)

RUN_A, RUN_B = "a" * 32, "b" * 32


def _command(cid: int, action: str = "rest(left)", run: str | None = None) -> dict[str, Any]:
    world = world_of(table_assembly(segments="legs").world())
    extra = {"run": run} if run is not None else {}
    return P.message(
        "command", id=cid, agents=["left"], action=action, t=1.0, expected_s=1.0, world=world,
        **extra,
    )  # fmt: skip


def _arm(bus: InProcessBus, journal: Path | None = None) -> RobotAgent:
    return RobotAgent(
        "left",
        table_assembly(segments="legs"),
        bus,
        execution=execution_model("analytic"),
        journal=journal,
    )


def _wait_for_text(path: Path, text: str, timeout: float = 60.0) -> str:
    """Poll a process's log until it holds ``text`` (a condition, not a fixed sleep)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = path.read_text() if path.exists() else ""
        if text in got:
            return got
        time.sleep(0.01)
    raise AssertionError(f"{path.name} never said {text!r}: {got[-1500:]}")


def _refused(proc: subprocess.Popen[str], log: Path, timeout: float = 60.0) -> str:
    """The process ended with exit 2 and one ``error:`` line (no traceback); returns it."""
    assert proc.wait(timeout) == 2, log.read_text()[-2000:]
    text = log.read_text()
    assert "Traceback" not in text, text[-2000:]
    errors = [line for line in text.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, text[-2000:]
    return errors[0]


# -- the identity module ------------------------------------------------------------------------
def test_the_fingerprint_is_stable_and_tells_scenarios_apart(tmp_path: Path) -> None:
    table = identity.fingerprint(load_scenario("table_assembly"))
    assert table == identity.fingerprint(load_scenario("table_assembly"))  # another object
    assert len(table) == 16 and int(table, 16) >= 0
    two_legs = tmp_path / "s2legs.yaml"
    two_legs.write_text("scenario: table_assembly\nlegs: 2\nunreachable_bolts: [1]\n")
    others = {identity.fingerprint(load_scenario(s)) for s in ("ball_in_box", "kitchen_drawer")}
    others.add(identity.fingerprint(load_scenario(str(two_legs))))
    assert table not in others and len(others) == 3


def test_a_legacy_start_gets_the_same_run_id_on_every_resume() -> None:
    legacy = {"agents": ["left"], "scenario": "table_assembly", "seed": 0, "realtime": 0.0}
    assert identity.run_of(legacy) == identity.run_of(dict(legacy))
    assert len(identity.run_of(legacy)) == 32
    assert identity.run_of({**legacy, "run": RUN_A}) == RUN_A
    assert identity.new_run_id() != identity.new_run_id()


# -- 1. a command id is trusted across runs: F01, P18, P34 (F02) -------------------------------
def test_f02_an_agent_answers_from_memory_only_within_one_run() -> None:
    """F02: a new run (a new manager without --resume) numbers its commands from 1 again; the
    agent executes them instead of answering the killed run's acks."""
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus)
    bus.publish(P.cmd_topic("left"), _command(1, run=RUN_A))
    bus.publish(P.cmd_topic("left"), _command(1, run=RUN_A))  # resent in run A: answered again
    bus.publish(P.cmd_topic("left"), _command(1, run=RUN_B))  # run B's command 1: executed
    assert arm.executed == [1, 1]
    assert [a["run"] for a in acks] == [RUN_A, RUN_A, RUN_B]
    assert acks[0] == acks[1]
    arm.close()


def test_p18_a_repeated_id_with_another_action_is_refused_not_answered(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """P18: command ids 1..N sent by someone else (no run) must not answer the manager's own
    command 1, nor may a repeated id of one run with another action be answered from memory."""
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus)
    bus.publish(P.cmd_topic("left"), _command(1))  # a stray command without a run
    bus.publish(P.cmd_topic("left"), _command(1, "approach(left, leg1)", run=RUN_A))
    assert arm.executed == [1, 1] and acks[-1]["run"] == RUN_A  # the run's command ran
    with caplog.at_level(logging.WARNING, logger="flexhrc.cell"):
        bus.publish(P.cmd_topic("left"), _command(1, "rest(left)", run=RUN_A))
    assert arm.executed == [1, 1] and len(acks) == 2 and arm.dropped == 1
    assert "command 1 repeated with another action: rest(left) (it was approach(left, leg1))" in (
        caplog.text
    )
    arm.close()


def test_p34_an_operator_answers_a_suggestion_id_only_within_its_run() -> None:
    """P34: a suggestion ``s1`` sent before the cell started (no run) must not make the operator
    resend that stale report for the manager's own ``s1``; a repeat of ``s1`` in one run with
    other actions is refused."""
    scenario = table_assembly(segments="legs")
    bus = InProcessBus(immediate=True)
    reports: list[dict[str, Any]] = []
    bus.subscribe(P.HUMAN_TOPIC, reports.append)
    operator = HumanAgent("human", scenario, bus, execution=execution_model("analytic"))
    world = world_of(scenario.world())

    def suggestion(actions: list[str], run: str | None) -> dict[str, Any]:
        extra = {"run": run} if run is not None else {}
        return P.message(
            "suggestion", id="s1", element="x", actions=actions, t=0.0, world=world, **extra
        )

    bus.publish(P.suggest_topic("human"), suggestion(["pick_up(human, leg3)"], None))
    bus.publish(P.suggest_topic("human"), suggestion(["pick_up(human, leg2)"], RUN_A))
    assert [r["action"] for r in reports] == ["pick_up(human, leg3)", "pick_up(human, leg2)"]
    assert "run" not in reports[0] and reports[1]["run"] == RUN_A
    bus.publish(P.suggest_topic("human"), suggestion(["pick_up(human, leg3)"], RUN_A))
    assert len(reports) == 2 and operator.dropped == 1
    bus.publish(P.suggest_topic("human"), suggestion(["pick_up(human, leg2)"], RUN_A))
    assert len(reports) == 3 and reports[2] == reports[1]  # the same step of the run: again
    operator.close()


def test_p34_the_manager_drops_answers_of_another_run_and_reports_before_its_start() -> None:
    scenario = table_assembly(segments="legs")
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = simulated_agents(scenario, bus)
    # a stale report before the cooperation started (the probe's P34 operator resends one)
    stale = P.message(
        "human_action", id="human:s1:0", agent="human", action="pick_up(human, leg3)", t=1.0
    )
    bus.publish(P.HUMAN_TOPIC, stale)
    bus.flush()
    sent: list[str] = []

    def pump(timeout: float) -> None:
        if not sent and cell.tm.busy:  # an ack of another run for a running command
            cmd = next(iter(cell.tm.busy.values()))
            ack = {"id": cmd.id, "agent": cmd.agents[0], "status": "done", "t": 99.0}
            bus.publish(P.ACK_TOPIC, P.message("ack", **ack, run=RUN_B))
            sent.append(str(cmd.id))
        pump_of(cell, bus, agents)(timeout)

    data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    assert any("before the cooperation started" in d for d in cell.dropped)
    assert f"ack for command {sent[0]} of another run ({RUN_B})" in cell.dropped
    ref, _, _ = _solved_in_process(scenario)
    assert data["knowledge"] == ref["knowledge"]
    assert data["robot_actions"] == ref["robot_actions"]


def _solved_in_process(scenario: Any) -> tuple[dict[str, Any], Cell, list[Any]]:
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = simulated_agents(scenario, bus)
    return cell.run(pump=pump_of(cell, bus, agents)), cell, agents


def test_f01_a_journal_of_another_run_is_refused_in_process(tmp_path: Path) -> None:
    journal = tmp_path / "left.jsonl"
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus, journal)
    bus.publish(P.cmd_topic("left"), _command(1, run=RUN_A))
    arm.close()
    lines = [json.loads(x) for x in journal.read_text().splitlines()]
    assert {rec["run"] for rec in lines} == {RUN_A}  # every journal line names its run
    again = _arm(bus, journal)
    bus.publish(P.cmd_topic("left"), _command(1, run=RUN_B))
    assert again.executed == [] and len(acks) == 1  # neither executed nor answered
    with pytest.raises(FlexhrcError, match=f"journal is of run {RUN_A}, the cell runs run {RUN_B}"):
        run_agent(again, bus)
    again.close()


# -- processes ----------------------------------------------------------------------------------
pytestmark_slow = pytest.mark.slow
zenoh_only = pytest.mark.skipif(importlib.util.find_spec("zenoh") is None, reason="no zenoh")


def _watch_until_alive(port: int, agent: str) -> Any:
    """A Zenoh session of the test that has seen ``agent``'s liveliness token (so the agent's
    subscriptions are declared too); the caller closes it."""
    from flexhrc.transport.zenoh import ZenohTransport, loopback_config

    bus = ZenohTransport(loopback_config(connect=port), prefix="flexhrc/default")
    alive: list[bool] = []
    bus.watch_liveliness(P.alive_key(agent), lambda key, up: alive.append(up))
    deadline = time.monotonic() + 60
    while not alive and time.monotonic() < deadline:
        bus.wait(0.1)
        bus.flush()
    if not alive:
        bus.close()
        raise AssertionError(f"agent {agent} never came up")
    return bus


@zenoh_only
@pytestmark_slow
def test_f01_a_reused_journal_is_refused_at_the_next_runs_start(tmp_path: Path) -> None:
    """F01: the same four commands run twice with one ``--journal``: the second run's left arm
    refuses the first run's journal (exit 2, one error naming both runs) instead of answering
    every command from it while no arm moves."""
    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    journal = tmp_path / "left.jsonl"
    procs: list[subprocess.Popen[str]] = []
    try:
        manager, port = start_cell(str(scenario), tmp_path / "j1.db", log=tmp_path / "c1.err")
        procs += [manager, robot(str(scenario), "right", port, tmp_path / "r1.err")]
        left = robot(str(scenario), "left", port, tmp_path / "l1.err", "--journal", str(journal))
        procs.append(left)
        assert finish(manager)["outcome"] == "solved"
        assert left.wait(30) == 0
        first = rows(tmp_path / "j1.db")[0][3]["run"]
        manager2, port2 = start_cell(str(scenario), tmp_path / "j2.db", log=tmp_path / "c2.err")
        procs += [manager2, robot(str(scenario), "right", port2, tmp_path / "r2.err")]
        left2 = robot(str(scenario), "left", port2, tmp_path / "l2.err", "--journal", str(journal))
        procs.append(left2)
        error = _refused(left2, tmp_path / "l2.err")
        second = rows(tmp_path / "j2.db")[0][3]["run"]
    finally:
        kill_all(procs)
    assert first != second
    assert error == (
        f"error: --journal {journal}: the journal is of run {first}, the cell runs run "
        f"{second}: a journal keeps one run; give this agent a new journal file"
    )
    assert executed(tmp_path / "l2.err") == []  # nothing answered from the old journal either
    assert "repeated: ack sent again" not in (tmp_path / "l2.err").read_text()


@zenoh_only
@pytestmark_slow
def test_p18_commands_sent_before_the_cell_starts_do_not_answer_its_own(tmp_path: Path) -> None:
    """P18: someone publishes ``rest(left)`` as commands 1..60 on ``cmd/left`` before the cell
    starts; the left arm must then execute the manager's commands 1, 2, ... all the same."""
    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(scenario), store, "--wait", "60", log=tmp_path / "cell.err")
    procs = [manager, robot(str(scenario), "left", port, tmp_path / "left.err")]
    bus: Any = None
    try:
        bus = _watch_until_alive(port, "left")
        world = world_of(load_scenario(str(scenario)).world())
        for i in range(1, 61):
            msg = {"v": 1, "type": "command", "id": i, "agents": ["left"],
                   "action": "rest(left)", "t": 0, "world": world}  # fmt: skip
            bus.publish(P.cmd_topic("left"), msg)
        _wait_for_text(tmp_path / "left.err", "] cmd 60 done")
        procs.append(robot(str(scenario), "right", port, tmp_path / "right.err"))
        data = finish(manager)
    finally:
        if bus is not None:
            bus.close()
        kill_all(procs)
    assert data["outcome"] == "solved", (tmp_path / "cell.err").read_text()[-2000:]
    events = rows(store)
    led = [b["id"] for _, _, k, b in events if k == "command" and b["agents"][0] == "left"]
    ids = executed(tmp_path / "left.err")
    assert ids[:60] == list(range(1, 61))
    assert ids[60:] == led  # every command of the manager's run was executed, once
    assert "repeated: ack sent again" not in (tmp_path / "left.err").read_text()
    ref = finish(flexhrc("cell", str(scenario), "--json", "--quiet"))
    assert data["knowledge"] == ref["knowledge"]
    assert data["robot_actions"] == ref["robot_actions"]


# -- 2. two processes for one arm: K09 ----------------------------------------------------------
@zenoh_only
@pytestmark_slow
def test_k09_a_second_process_for_an_arm_is_refused_and_the_first_keeps_it(
    tmp_path: Path,
) -> None:
    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(scenario), store, "--wait", "60", log=tmp_path / "c.err")
    procs = [manager, robot(str(scenario), "left", port, tmp_path / "left.err")]
    bus: Any = None
    try:
        bus = _watch_until_alive(port, "left")  # the first process holds the name
        twin = robot(str(scenario), "left", port, tmp_path / "twin.err")
        procs.append(twin)
        error = _refused(twin, tmp_path / "twin.err")
        procs.append(robot(str(scenario), "right", port, tmp_path / "right.err"))
        data = finish(manager)
    finally:
        if bus is not None:
            bus.close()
        kill_all(procs)
    assert error == (
        "error: agent left: another process already serves this agent in the cell (its "
        "liveliness token alive/left is alive); a second one is refused (a process that just "
        "died keeps it until its liveliness lease ends: about 10 s over Zenoh, 1 s over ROS 2)"
    )
    assert data["outcome"] == "solved", (tmp_path / "c.err").read_text()[-2000:]
    assert data["cell"]["dropped"] == 0  # no duplicate acks
    led = [b["id"] for _, _, k, b in rows(store) if k == "command" and b["agents"][0] == "left"]
    assert executed(tmp_path / "left.err") == led and executed(tmp_path / "twin.err") == []


# -- 12. two managers on one cell name: K08, K08b -----------------------------------------------
@zenoh_only
@pytestmark_slow
@pytest.mark.parametrize("case", ["K08", "K08b"])
def test_k08_a_second_manager_for_a_cell_name_is_refused(tmp_path: Path, case: str) -> None:
    """K08: a second manager of the same scenario on the first one's cell name; K08b: of
    another table (two legs). Both are refused before they store anything; the first runs on."""
    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    other = tmp_path / "s2legs.yaml"
    other.write_text("scenario: table_assembly\nhuman: false\nlegs: 2\n")
    second = str(scenario if case == "K08" else other)
    manager, port = start_cell(str(scenario), tmp_path / "a.db", log=tmp_path / "a.err")
    procs = [manager]
    try:
        log = tmp_path / "b.err"
        twin = cell(second, 0, tmp_path / "b.db", "--connect", f"tcp/127.0.0.1:{port}", log=log)
        procs.append(twin)
        error = _refused(twin, log)
        procs += [
            robot(str(scenario), arm, port, tmp_path / f"{arm}.err") for arm in ("left", "right")
        ]
        data = finish(manager)
    finally:
        kill_all(procs)
    assert error == (
        "error: --cell default: another manager already runs this cell (its liveliness token "
        "alive/manager is alive); a second one is refused: stop it first or choose another "
        "--cell name (a manager that just died keeps it until its liveliness lease ends: about "
        "10 s over Zenoh, 1 s over ROS 2)"
    )
    assert data["outcome"] == "solved"
    assert rows(tmp_path / "b.db") == []


# -- 11. agents of another scenario: F03, F04, F05 ---------------------------------------------
@zenoh_only
@pytestmark_slow
@pytest.mark.parametrize(
    ("case", "cell_scenario", "agent_scenario"),
    [
        ("F03", "kitchen_drawer", "table_assembly"),
        ("F04", "table_assembly", "ball_in_box"),
        ("F05", "ball_in_box", "kitchen_drawer"),
    ],
)
def test_f03_agents_of_another_scenario_are_refused(
    tmp_path: Path, case: str, cell_scenario: str, agent_scenario: str
) -> None:
    manager, port = start_cell(cell_scenario, tmp_path / "cell.db", log=tmp_path / "cell.err")
    procs = [manager]
    agents = {"left": robot(agent_scenario, "left", port, tmp_path / "left.err")}
    if case == "F03":  # an operator too
        agents["human"] = human(agent_scenario, "human", port, tmp_path / "human.err")
    procs += list(agents.values())
    try:
        errors = {name: _refused(p, tmp_path / f"{name}.err") for name, p in agents.items()}
        for name in agents:
            _wait_for_text(tmp_path / "cell.err", f"agent {name} refused")
    finally:
        kill_all(procs)
    mine = identity.fingerprint(load_scenario(agent_scenario))
    theirs = identity.fingerprint(load_scenario(cell_scenario))
    for name, error in errors.items():
        assert error == (
            f"error: agent {name}: the cell runs another scenario (scenario {cell_scenario}, "
            f"fingerprint {theirs}) than this agent's {agent_scenario} (fingerprint {mine}): "
            "start the agent with the cell's scenario and --seed"
        )
    log = (tmp_path / "cell.err").read_text()
    assert (
        f"agent left refused: its scenario {agent_scenario} (fingerprint {mine}) is not this "
        f"cell's {cell_scenario} (fingerprint {theirs})"
    ) in log
    assert not any(k == "start" for _, _, k, _ in rows(tmp_path / "cell.db"))  # never started


# -- 3. --resume of a store of another run: ST28-ST31b ------------------------------------------
@pytest.fixture(scope="module")
def mid_store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A table-assembly store whose manager was killed mid-run (``--realtime 20``, seed 0)."""
    path = tmp_path_factory.mktemp("mid") / "mid.db"
    proc = flexhrc("cell", "table_assembly", "--realtime", "20", "--store", str(path), "--quiet")
    try:
        wait_until(path, lambda r: len(r) >= 12, 60)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        kill_all([proc])
    assert not any(k == "outcome" for _, _, k, _ in rows(path)), "killed too late"
    return path


def _copy(store: Path, to: Path) -> Path:
    src = sqlite3.connect(store)
    dst = sqlite3.connect(to)
    src.backup(dst)
    src.close()
    dst.close()
    return to


@pytestmark_slow
@pytest.mark.parametrize(
    ("case", "args", "differs"),
    [
        ("ST31b", ["ball_in_box", "--realtime", "20"],
         "scenario table_assembly (this cell: ball_in_box)"),
        ("ST31", ["S2LEGS", "--realtime", "20"],
         "scenario table_assembly with another graph, domain or world (fingerprint "),
        ("ST28", ["kitchen_drawer", "--realtime", "20"],
         "scenario table_assembly (this cell: kitchen_drawer)"),
        ("ST29", ["table_assembly", "--realtime", "20", "--seed", "7"],
         "seed 0 (this cell: --seed 7)"),
        ("ST30", ["table_assembly", "--realtime", "0.5"],
         "realtime 20 (this cell: --realtime 0.5)"),
    ],
)  # fmt: skip
def test_st28_resume_refuses_a_store_of_another_scenario_seed_or_pace(
    tmp_path: Path, mid_store: Path, case: str, args: list[str], differs: str
) -> None:
    store = _copy(mid_store, tmp_path / "a.db")
    before = rows(store)
    s2legs = tmp_path / "s2legs.yaml"
    s2legs.write_text("scenario: table_assembly\nlegs: 2\nunreachable_bolts: [1]\n")
    args = [str(s2legs) if a == "S2LEGS" else a for a in args]
    proc = flexhrc("cell", *args, "--store", str(store), "--resume", log=tmp_path / "err")
    try:
        error = _refused(proc, tmp_path / "err")
    finally:
        kill_all([proc])
    assert error.startswith(f"error: --store {store}: the store is of another run: {differs}")
    assert error.endswith(
        "--resume continues only the run it was given: use its scenario, --seed and "
        "--realtime, or a new --store"
    )
    assert rows(store) == before  # nothing appended


@pytestmark_slow
def test_resume_continues_its_own_run_under_its_run_id(tmp_path: Path, mid_store: Path) -> None:
    store = _copy(mid_store, tmp_path / "a.db")
    run = rows(store)[0][3]["run"]
    out = flexhrc("cell", "table_assembly", "--realtime", "20", "--store", str(store),
                  "--resume", "--json", "--quiet")  # fmt: skip
    data = finish(out)
    assert data["outcome"] == "solved" and data["cell"]["resumed"] is True
    assert {b["run"] for _, _, _, b in rows(store)} == {run}  # every row, before and after


def test_a_store_that_mixes_two_runs_is_refused(tmp_path: Path) -> None:
    """ST31b's aftermath: a store another run was appended to is refused as such."""
    scenario = table_assembly(segments="legs")
    path = tmp_path / "cell.db"
    store = EventStore(path)
    bus = InProcessBus()
    cell = Cell(scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = simulated_agents(scenario, bus)
    with pytest.raises(Crash):
        cell.run(pump=pump_of(cell, bus, agents, limit=10))
    store.append("ack", {"id": 1, "agent": "left", "status": "done", "run": RUN_B}, 5.0)
    store.close()
    with (
        EventStore(path, resume=True) as again,
        pytest.raises(FlexhrcError, match=rf"event \d+ \(ack\) is of run {RUN_B}, not of the"),
    ):
        Cell(scenario, InProcessBus(), store=again, resume=True, liveliness=False)


def test_a_legacy_store_without_run_ids_still_resumes(tmp_path: Path) -> None:
    """Stores written before run ids: their rows carry none, and they resume as before."""
    scenario = table_assembly(segments="legs")
    path = tmp_path / "cell.db"
    store = EventStore(path)
    bus = InProcessBus()
    cell = Cell(scenario, bus, store=store, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = simulated_agents(scenario, bus)
    with pytest.raises(Crash):
        cell.run(pump=pump_of(cell, bus, agents, limit=10))
    store.close()
    db = sqlite3.connect(path)
    for seq, body in db.execute("SELECT seq, body FROM events").fetchall():
        legacy = {k: v for k, v in json.loads(body).items() if k not in ("run", "fingerprint")}
        db.execute("UPDATE events SET body = ? WHERE seq = ?", (json.dumps(legacy), seq))
    db.commit()
    db.close()
    start = rows(path)[0][3]
    crashed = len(rows(path))
    with EventStore(path, resume=True) as again:
        bus2 = InProcessBus()
        resumed = Cell(
            scenario, bus2, store=again, resume=True, liveliness=False,
            simulator=execution_model("analytic"),
        )  # fmt: skip
        assert resumed.run_id == identity.run_of(start)
        agents2: list[Any] = simulated_agents(scenario, bus2)
        data = resumed.run(pump=pump_of(resumed, bus2, agents2))
    assert data["outcome"] == "solved"
    after = rows(path)
    assert all("run" not in b for _, _, _, b in after[:crashed])  # the legacy rows as they were
    assert {b.get("run") for _, _, _, b in after[crashed:]} == {identity.run_of(start)}
