"""``flexhrc agent perception``: the cell's perception as an agent (issue 13, item 1)."""

from __future__ import annotations

from typing import Any

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("scipy")

from flexhrc.cell import Cell, HumanAgent, RobotAgent
from flexhrc.cell.components import execution_model
from flexhrc.scenario import load_scenario
from flexhrc.sensing.agent import PerceptionAgent
from flexhrc.transport import InProcessBus


def test_the_perception_agent_sends_percepts_the_cell_applies() -> None:
    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    cell = Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"))
    agents: list[Any] = []
    for a in scenario.domain.agents.values():
        cls = HumanAgent if a.is_human else RobotAgent
        agents.append(cls(a.name, scenario, bus, execution=execution_model("analytic")))
    eye = PerceptionAgent(scenario, bus)
    lines: list[str] = []
    eye.trace = lines.append

    def pump(timeout: float) -> None:
        bus.flush()
        for a in agents:
            a.poll()

    try:
        data = cell.run(pump=pump)
        bus.flush()
    finally:
        eye.close()
    assert data["outcome"] == "solved"
    assert eye.dropped == 0 and eye.sent > 0 and eye.ended == "solved"
    assert cell.percept_ids  # stored inputs of the manager
    assert cell.kb.consistent
    s = eye.summary()
    assert s["perception"]["frames"] >= 5 and s["perception"]["new_objects"] == []
    assert any("percepts sent" in line for line in lines)


def test_an_ack_that_overtakes_its_command_is_applied_when_the_command_arrives() -> None:
    # over Zenoh an arm's ack and the manager's command come from two publishers: the ack may
    # arrive first (CI saw it); its physical effect must not be lost
    from flexhrc.cell import protocol as P

    scenario = load_scenario("table_assembly")
    bus = InProcessBus()
    eye = PerceptionAgent(scenario, bus)
    lines: list[str] = []
    eye.trace = lines.append
    try:
        ack = P.message("ack", id=1, agent="left", status="done", t=2.0)
        bus.publish(P.ACK_TOPIC, ack)
        bus.flush()
        assert eye.perception.stats.frames == 0 and not lines  # it waits for its command
        cmd = P.message(
            "command", id=1, agents=["left"], action="place_tabletop(tabletop, assembly_pose)",
            t=0.0,
        )  # fmt: skip
        bus.publish(P.cmd_topic("left"), cmd)
        bus.flush()
        assert eye.perception.stats.frames == 1
        assert any("after place_tabletop(tabletop, assembly_pose)" in line for line in lines)
        bus.publish(P.ACK_TOPIC, ack)  # a duplicate is not applied twice
        bus.flush()
        assert eye.perception.stats.frames == 1 and eye.dropped == 0
    finally:
        eye.close()


@pytest.mark.slow
def test_flexhrc_agent_perception_joins_a_cell_over_zenoh(tmp_path) -> None:
    pytest.importorskip("zenoh")
    import json
    import threading
    import time

    from flexhrc.cell import protocol as P
    from flexhrc.transport.zenoh import ZenohTransport, zenoh_config

    from ..cell.helpers import finish, flexhrc, human, kill_all, robot, start_cell

    scenario = "table_assembly"
    manager, port = start_cell(scenario, tmp_path / "cell.db", log=tmp_path / "cell.err")
    procs = [manager]
    eye = flexhrc(
        "agent", "perception", scenario, "--connect", f"tcp/127.0.0.1:{port}", "--json",
        log=tmp_path / "perception.err",
    )  # fmt: skip
    procs.append(eye)
    # the camera is up before the arms join (the cell waits for the arms, not for it): the
    # arms come once its subscription to the left arm's commands has reached the cell, as Zenoh
    # itself tells a publisher on that key (only the camera subscribes to it before the arms)
    log = tmp_path / "perception.err"
    with ZenohTransport(zenoh_config(connect=[f"tcp/127.0.0.1:{port}"])) as probe:
        heard = threading.Event()
        publisher = probe.session.declare_publisher(f"flexhrc/default/{P.cmd_topic('left')}")
        listener = publisher.declare_matching_listener(
            lambda status: heard.set() if status.matching else None
        )
        deadline = time.monotonic() + 90
        while not (heard.wait(0.2) or publisher.matching_status.matching):
            assert eye.poll() is None and time.monotonic() < deadline, log.read_text()
        listener.undeclare()
        publisher.undeclare()
    procs += [robot(scenario, arm, port, tmp_path / f"{arm}.err") for arm in ("left", "right")]
    procs.append(human(scenario, "human", port, tmp_path / "human.err"))
    try:
        data = finish(procs[0], timeout=120)
        out, _ = eye.communicate(timeout=60)
    finally:
        kill_all(procs)
    assert data["outcome"] == "solved", (tmp_path / "cell.err").read_text()[-2000:]
    summary = json.loads(out)
    assert summary["kind"] == "perception" and summary["percepts_sent"] > 0
    assert summary["dropped"] == 0 and summary["perception"]["new_objects"] == []
    assert "percepts sent" in (tmp_path / "perception.err").read_text()
