"""The live cell's knowledge base (issue 21, item 10): a percept message reaches the knowledge
base through the manager's percept path (``Cell._on_percept_message``); continuity is checked
there, and a compatible percept ends the wait (paper 000, VI-E)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import Cell
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model
from flexhrc.scenario import load_scenario
from flexhrc.transport import InProcessBus

from .helpers import (
    TABLE_NO_HUMAN,
    finish,
    kill_all,
    robot,
    rows,
    simulated_agents,
    start_cell,
    wait_until,
)


def _cell() -> tuple[Cell, list[Any], InProcessBus]:
    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    return cell, simulated_agents(scenario, bus), bus


def test_a_leg_that_teleports_makes_the_live_cell_wait_until_a_compatible_percept() -> None:
    cell, agents, bus = _cell()
    seen: dict[str, Any] = {}
    step = [0]

    def percept(n: int, where: list[float], t: float) -> dict[str, Any]:
        return P.message(
            "percept", id=f"cam:{n}", object="leg2", object_type="leg", pose=where, t=t
        )

    def pump(timeout: float) -> None:
        if cell.started:
            if step[0] == 0:  # leg2 where it lies, then 4 m away 0.2 s later
                where = list(cell.kb.position("leg2"))
                seen["where"] = where
                bus.publish(P.PERCEPT_TOPIC, percept(1, where, 0.0))
                bus.publish(P.PERCEPT_TOPIC, percept(2, [where[0] + 4.0, *where[1:]], 0.2))
            elif step[0] == 1:  # the manager waits: the base is inconsistent
                seen["consistent"] = cell.kb.consistent
                seen["waiting"] = cell.tm.waiting_for_consistency
                seen["leg2"] = list(cell.kb.position("leg2"))
                bus.publish(P.PERCEPT_TOPIC, percept(3, seen["where"], 0.3))  # compatible
            step[0] += 1
        bus.flush()
        for a in agents:
            a.poll()

    data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    assert seen["consistent"] is False and seen["waiting"] is True
    assert seen["leg2"] == seen["where"]  # the jump was not applied
    kinds = [(e.kind, e.body.get("object")) for e in cell.events if e.kind != "command"]
    i = kinds.index(("inconsistent", "leg2"))
    assert kinds[i + 1 : i + 4] == [
        ("waiting", None),  # the manager says why it does nothing
        ("percept", "leg2"),
        ("consistent_again", "leg2"),
    ]
    (inc,) = [e for e in cell.events if e.kind == "inconsistent"]
    assert inc.body["reason"].startswith("leg2 perceived 4.00 m from where it was perceived 0.20")
    assert "no agent moves it faster than 1.5 m/s" in inc.body["reason"]
    assert cell.kb.consistent


def test_a_percept_without_a_time_is_taken_at_the_cells_time() -> None:
    """No wall clock: an untimed percept is checked at the time the cell stores it (so a
    replay of the store decides the same)."""
    cell, agents, bus = _cell()
    sent: list[bool] = []

    def pump(timeout: float) -> None:
        if cell.started and not sent:
            where = list(cell.kb.position("leg2"))
            far = [where[0] + 4.0, *where[1:]]
            for n, pose in enumerate((where, far, where)):
                msg = P.message("percept", id=f"cam:{n}", object="leg2", object_type="leg",
                                pose=pose)  # fmt: skip
                bus.publish(P.PERCEPT_TOPIC, msg)
            sent.append(True)
        bus.flush()
        for a in agents:
            a.poll()

    data = cell.run(pump=pump)
    assert data["outcome"] == "solved"
    kinds = [e.kind for e in cell.events if e.body.get("object") == "leg2"]
    assert kinds[:5] == ["percept", "percept", "inconsistent", "percept", "consistent_again"]
    assert cell.kb.last_percept["leg2"][1] == 0.0  # the cell's time when they came


@pytest.mark.slow
def test_the_cell_process_over_zenoh_checks_continuity_and_waits(tmp_path: Path) -> None:
    """The same with the manager and the arms as processes: a perception process (this test's
    own Zenoh session) reports leg4 — the last leg the arms take — where it lies, 4 m away
    0.1 s later, and where it lies again; the stored run has the inconsistency and its end."""
    pytest.importorskip("zenoh")
    from flexhrc.transport.zenoh import ZenohTransport, loopback_config

    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    where = list(load_scenario(str(scenario)).world().position("leg4"))
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(scenario), store, "--realtime", "10", log=tmp_path / "c.err")
    procs = [manager]
    procs += [robot(str(scenario), arm, port, tmp_path / f"{arm}.err") for arm in ("left", "right")]
    bus = ZenohTransport(loopback_config(connect=port), prefix="flexhrc/default")
    try:
        wait_until(store, lambda r: any(k == "start" for _, _, k, _ in r), 60)
        far = [where[0] + 4.0, *where[1:]]
        for n, (pose, t) in enumerate(((where, 0.5), (far, 0.6), (where, 0.7))):
            msg = P.message("percept", id=f"cam:{n}", object="leg4", object_type="leg",
                            pose=pose, t=t)  # fmt: skip
            bus.publish(P.PERCEPT_TOPIC, msg)
        data = finish(procs[0])
    finally:
        bus.close()
        kill_all(procs)
    log = (tmp_path / "c.err").read_text()
    assert data["outcome"] == "solved", log[-2000:]
    got = [(k, b) for _, _, k, b in rows(store) if b.get("object") == "leg4"]
    assert [k for k, _ in got][:5] == ["percept", "percept", "inconsistent", "percept",
                                   "consistent_again"], got  # fmt: skip
    assert got[2][1]["reason"].startswith("leg4 perceived 4.00 m from where it was perceived 0.10")
