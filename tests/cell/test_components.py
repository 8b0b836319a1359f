"""The simulated agents on their own: idempotent command ids, the journal, malformed input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from flexhrc.cell import RobotAgent
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model, world_of
from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.transport import InProcessBus


def _command(cid: int, action: str = "rest(left)") -> dict[str, Any]:
    world = world_of(table_assembly(segments="legs").world())
    return P.message(
        "command", id=cid, agents=["left"], action=action, t=1.0, expected_s=1.0, world=world
    )


def _arm(bus: InProcessBus, journal: Path | None = None) -> RobotAgent:
    return RobotAgent(
        "left",
        table_assembly(segments="legs"),
        bus,
        execution=execution_model("analytic"),
        journal=journal,
    )


def test_a_repeated_id_is_answered_not_executed_and_the_journal_survives_a_restart(
    tmp_path: Path,
) -> None:
    journal = tmp_path / "left.jsonl"
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus, journal)
    bus.publish(P.cmd_topic("left"), _command(1))
    bus.publish(P.cmd_topic("left"), _command(1))  # the manager resent it
    assert arm.executed == [1] and len(acks) == 2 and acks[0] == acks[1]
    assert acks[0]["status"] == "done" and acks[0]["t"] >= 1.0  # (already at rest: 0 s)
    arm.close()
    # the process died while executing command 2: its start is in the journal, no ack
    with journal.open("a") as fh:
        fh.write(json.dumps({"id": 2, "event": "start", "action": "rest(left)"}) + "\n")
        fh.write('{"id": 3, "ev')  # a write cut short by SIGKILL
    again = _arm(bus, journal)
    bus.publish(P.cmd_topic("left"), _command(1))
    bus.publish(P.cmd_topic("left"), _command(2))
    bus.publish(P.cmd_topic("left"), _command(4))
    assert again.executed == [4]  # 1 was done, 2 was interrupted: neither runs again
    assert acks[2] == acks[0]
    assert acks[3]["id"] == 2 and acks[3]["status"] == "failed"
    assert "interrupted" in acks[3]["reason"]
    assert acks[4]["id"] == 4 and acks[4]["status"] == "done"
    again.close()


def test_malformed_commands_are_dropped_by_the_agent() -> None:
    bus = InProcessBus(immediate=True)
    acks: list[dict[str, Any]] = []
    bus.subscribe(P.ACK_TOPIC, acks.append)
    arm = _arm(bus)
    bad: list[Any] = [
        {"v": 1, "type": "command", "id": 5},
        {**_command(6), "agents": ["right"]},
        _command(7, "fly(left)"),
        _command(8, "rest(?arm)"),
        "garbage",
    ]
    for msg in bad:
        bus.publish(P.cmd_topic("left"), msg)
    assert arm.dropped == len(bad) and arm.executed == [] and acks == []
    bus.publish(P.cmd_topic("left"), _command(9))
    assert arm.executed == [9] and acks[0]["status"] == "done"
