"""The arm node: `flexhrc ros2 arm` executes commands, streams joint states >= 30 Hz while
moving, publishes its end-effector pose and plan; a real arm driven through JointTrajectory."""

from __future__ import annotations

import json
import random
import subprocess
import sys
import threading
import time
import uuid

import numpy as np
import pytest

from flexhrc.ros2._deps import msg
from flexhrc.ros2.transport import Ros2Transport
from tests.ros2.conftest import wait_for


def _cmd(cid, action, **kw):
    """A command of the cell protocol (docs/protocol.md), paced at 2x real time."""
    return {"v": 1, "type": "command", "id": cid, "action": action, "agents": ["left"],
            "t": 0.0, "expected_s": 3.0, "realtime": 2.0, **kw}  # fmt: skip


@pytest.fixture(scope="module")
def arm_node():
    """One `flexhrc ros2 arm ... --arm left` process for the module, and a client transport."""
    from tests.conftest import subprocess_env

    domain = random.SystemRandom().randint(1, 100)
    cell = f"a{uuid.uuid4().hex[:8]}"
    env = subprocess_env()
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    proc = subprocess.Popen(
        [sys.executable, "-m", "flexhrc", "ros2", "arm", "table_assembly", "--arm", "left",
         "--cell", cell, "--json"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    client = Ros2Transport(prefix=f"flexhrc/{cell}", domain_id=domain)
    rec: dict[str, list] = {"acks": [], "js": [], "poses": [], "plans": [], "alive": []}
    client.subscribe("ack", rec["acks"].append)
    client.create_subscription(
        msg("sensor_msgs.msg", "JointState"),
        "arm/left/joint_states",
        lambda m: rec["js"].append((time.monotonic(), m)),
    )
    client.create_subscription(
        msg("geometry_msgs.msg", "PoseStamped"), "arm/left/pose", rec["poses"].append
    )
    client.create_subscription(
        msg("trajectory_msgs.msg", "JointTrajectory"),
        "arm/left/joint_trajectory",
        rec["plans"].append,
    )
    client.watch_liveliness("alive/*", lambda k, a: rec["alive"].append((k, a)))
    try:
        assert wait_for(lambda: ("alive/left", True) in rec["alive"], 30.0, client.flush), (
            "the arm node never announced itself"
        )
        assert client.wait_matched("cmd/left", minimum=1, timeout=10.0)
        yield client, rec, proc
    finally:
        client.close()
        proc.terminate()
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()


def _cmd_bytes(cid, t: str) -> bytes:
    return (
        f'{{"v": 1, "type": "command", "id": {cid}, "action": "rest(left)", '
        f'"agents": ["left"], "t": {t}}}'
    ).encode()


def _ack(rec, cid):
    return next((a for a in rec["acks"] if a["id"] == cid), None)


@pytest.mark.slow
def test_a_command_moves_the_arm_streams_joint_states_and_is_acknowledged(arm_node):
    client, rec, _ = arm_node
    t0 = time.monotonic()
    client.publish("cmd/left", _cmd(1, "approach(left, leg1)"))
    assert wait_for(lambda: _ack(rec, 1) is not None, 15.0, client.flush)
    t1 = time.monotonic()
    ack = _ack(rec, 1)
    assert ack["status"] == "done" and ack["agent"] == "left" and ack["v"] == 1
    assert ack["type"] == "ack" and ack["t"] == pytest.approx(ack["duration"])
    moving = [(t, m) for t, m in rec["js"] if t0 + 0.05 < t < t1 - 0.05]
    rate = len(moving) / (t1 - t0 - 0.1)
    assert rate >= 30.0, f"joint states at {rate:.1f} Hz while moving"
    assert moving[0][1].name[0] == "left_joint1" and len(moving[0][1].position) == 7
    q_first, q_last = np.array(moving[0][1].position), np.array(moving[-1][1].position)
    assert np.max(np.abs(q_last - q_first)) > 0.05  # it moved
    assert rec["plans"] and rec["plans"][-1].joint_names[6] == "left_joint7"
    last_pose = rec["poses"][-1].pose.position
    assert 0.3 < last_pose.x < 0.8  # the hand went out over the table
    # the same id again: answered again, not executed again (no second plan)
    plans = len(rec["plans"])
    n_acks = len(rec["acks"])
    client.publish("cmd/left", _cmd(1, "approach(left, leg1)"))
    assert wait_for(lambda: len(rec["acks"]) == n_acks + 1, 5.0, client.flush)
    assert rec["acks"][-1] == ack and len(rec["plans"]) == plans


@pytest.mark.slow
def test_bad_commands_are_dropped_and_the_node_goes_on(arm_node):
    client, rec, _ = arm_node
    n_acks = len(rec["acks"])
    for bad in ([1, 2], _cmd(5, "rest(left)", v=2), {"v": 1, "type": "dance", "id": 6},
                {"v": 1, "type": "command", "action": "x"}, _cmd(8, "fly(left, leg1)"),
                _cmd(9, "rest(right)", agents=["right"])):  # fmt: skip
        client.publish("cmd/left", bad)
    client.publish_bytes("cmd/left", _cmd_bytes(7, t="1e999"))  # infinite time
    client.publish_bytes("cmd/left", b"{garbage")
    client.publish("cmd/left", _cmd(10, "rest(left)"))
    assert wait_for(lambda: _ack(rec, 10) is not None, 15.0, client.flush)
    assert _ack(rec, 10)["status"] == "done"
    assert len(rec["acks"]) == n_acks + 1  # none of the bad ones got an answer


@pytest.mark.slow
def test_a_stop_ends_the_motion_where_the_arm_is(arm_node):
    client, rec, _ = arm_node
    plans = len(rec["plans"])
    client.publish("cmd/left", _cmd(11, "approach(left, leg3)"))
    assert wait_for(lambda: len(rec["plans"]) > plans, 10.0, client.flush)
    started = time.monotonic()
    assert wait_for(lambda: time.monotonic() - started > 0.3, 1.0)  # into the motion
    client.publish("cmd/left", {"v": 1, "type": "stop", "id": 11, "reason": "human takes it"})
    stopped = time.monotonic()
    planned = rec["plans"][-1].points[-1].time_from_start
    end = started + (planned.sec + planned.nanosec * 1e-9) / 2.0  # when it would have ended
    assert wait_for(lambda: time.monotonic() > end + 0.3, 10.0, client.flush)
    client.flush()
    assert _ack(rec, 11) is None  # a stopped command is not acknowledged (the cell dropped it)
    late = [np.array(m.position) for t, m in rec["js"] if t > stopped + 0.2]
    assert len(late) >= 2 and np.max(np.abs(late[-1] - late[0])) < 1e-9  # it stays put
    final = np.array(rec["plans"][-1].points[-1].positions)
    assert np.max(np.abs(late[-1] - final)) > 1e-3  # and not at the planned end


@pytest.mark.slow
def test_k09_a_second_node_for_the_arm_is_refused_and_the_first_keeps_it(arm_node):
    # K09 over ROS 2: the second node asks the graph whether alive/left is held (its DDS
    # writer alive, its heartbeats coming) before it declares its own, and exits with code 2
    from tests.conftest import subprocess_env

    client, rec, proc = arm_node
    env = subprocess_env()
    env.update(ROS_DOMAIN_ID=str(client.domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env["FLEXHRC_ROS2_DISCOVERY_S"] = "30"  # as long as a loaded machine's DDS may need
    cell = client.prefix.split("/")[-1]
    twin = subprocess.run(
        [sys.executable, "-m", "flexhrc", "ros2", "arm", "table_assembly", "--arm", "left",
         "--cell", cell],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert twin.returncode == 2, twin.stderr[-2000:]
    assert "error: agent left: another process already serves this agent" in twin.stderr
    assert "Traceback" not in twin.stderr
    client.flush()
    assert proc.poll() is None and ("alive/left", False) not in rec["alive"]
    acks = len(rec["acks"])
    client.publish("cmd/left", _cmd(21, "rest(left)"))  # the first still serves the arm
    assert wait_for(lambda: _ack(rec, 21) is not None, 20.0, client.flush)
    assert [a["id"] for a in rec["acks"][acks:]] == [21]  # once: the twin executed nothing


@pytest.mark.slow
def test_the_node_exits_when_the_cell_ends(arm_node):
    client, _, proc = arm_node
    client.publish("state", {"v": 1, "type": "end", "outcome": "solved"})
    out, _ = proc.communicate(timeout=20)
    assert proc.returncode == 0
    data = json.loads(out)
    assert data["outcome"] == "solved" and data["agent"] == "left"
    assert data["executed"][:1] == [1] and data["executed"].count(1) == 1
    assert data["dropped"] >= 6


def test_a_real_arm_is_driven_through_joint_trajectory(domain_id: int, cell_name: str):
    """--execute external: the plan goes to the controller's topic; done when the arm's joint
    states reach its last point (a fake controller that jumps there)."""
    from flexhrc.cell.components import run_agent
    from flexhrc.ros2.arm import ArmNode
    from flexhrc.scenario.builtin.table import table_assembly

    sc = table_assembly(segments="legs")
    prefix = f"flexhrc/{cell_name}"
    node_bus = Ros2Transport(prefix=prefix, domain_id=domain_id)
    robot = Ros2Transport(prefix="", domain_id=domain_id)  # the real arm's driver
    client = Ros2Transport(prefix=prefix, domain_id=domain_id)
    JointState = msg("sensor_msgs.msg", "JointState")
    JointTrajectory = msg("trajectory_msgs.msg", "JointTrajectory")
    js_pub = robot.create_publisher(JointState, "/fake_arm/joint_states")
    received: list = []

    def controller(traj) -> None:  # executes at once: reports the last point
        received.append(traj)
        out = JointState()
        out.name = list(traj.joint_names)
        out.position = list(traj.points[-1].positions)
        js_pub.publish(out)

    robot.create_subscription(JointTrajectory, "/fake_arm/joint_trajectory", controller)
    node = ArmNode(
        "left", sc, node_bus, execute="external",
        trajectory_topic="/fake_arm/joint_trajectory", joint_states_topic="/fake_arm/joint_states",
    )  # fmt: skip
    done = threading.Event()
    runner = threading.Thread(
        target=run_agent, args=(node, node_bus), kwargs={"until": done.is_set}, daemon=True
    )
    runner.start()
    acks: list = []
    client.subscribe("ack", acks.append)
    try:
        assert client.wait_matched("cmd/left", minimum=1, timeout=10.0)
        assert robot.wait_matched("/fake_arm/joint_states", minimum=1, timeout=10.0)
        assert node_bus.wait_matched("/fake_arm/joint_trajectory", minimum=1, timeout=10.0)
        assert node_bus.wait_matched("ack", minimum=1, timeout=10.0)
        client.publish("cmd/left", _cmd(1, "approach(left, leg1)"))

        def pump() -> None:
            client.flush()
            robot.flush()

        assert wait_for(lambda: bool(acks), 15.0, pump)
        assert acks[0]["status"] == "done" and acks[0]["id"] == 1 and acks[0]["agent"] == "left"
        assert received and received[0].joint_names[0] == "left_joint1"
        assert len(received[0].points) > 2
    finally:
        done.set()
        runner.join(5)
        for t in (client, robot, node_bus):
            t.close()


def test_a_joint_command_moves_both_arm_nodes_and_a_stop_to_either_halts_both(
    domain_id: int, cell_name: str
):
    """The leader (the joint command's first arm) sends the other arm its part; each publishes
    a trajectory from its own joint state; the cell's stop reaching the follower stops both."""
    from flexhrc.cell.components import run_agent
    from flexhrc.ros2.arm import ArmNode
    from flexhrc.scenario import load_scenario

    sc = load_scenario("table_assembly")  # with the tabletop's joint command
    prefix = f"flexhrc/{cell_name}"
    buses = {arm: Ros2Transport(prefix=prefix, domain_id=domain_id) for arm in ("left", "right")}
    client = Ros2Transport(prefix=prefix, domain_id=domain_id, deliver="thread")
    JointState = msg("sensor_msgs.msg", "JointState")
    JointTrajectory = msg("trajectory_msgs.msg", "JointTrajectory")
    lock = threading.Lock()
    states: dict[str, list] = {"left": [], "right": []}
    plans: dict[str, list] = {"left": [], "right": []}
    acks: list = []

    def keep(box: list, item) -> None:
        with lock:
            box.append(item)

    for arm in ("left", "right"):
        client.create_subscription(
            JointState,
            f"arm/{arm}/joint_states",
            lambda m, a=arm: keep(states[a], np.array(m.position)),
        )
        client.create_subscription(JointTrajectory, f"arm/{arm}/joint_trajectory",
                                   lambda m, a=arm: keep(plans[a], m))  # fmt: skip
    client.subscribe("ack", lambda a: keep(acks, a))
    nodes = {arm: ArmNode(arm, sc, buses[arm]) for arm in ("left", "right")}
    done = threading.Event()
    runners = [
        threading.Thread(target=run_agent, args=(nodes[a], buses[a]),
                         kwargs={"until": done.is_set}, daemon=True)
        for a in ("left", "right")
    ]  # fmt: skip
    for r in runners:
        r.start()
    try:
        for arm in ("left", "right"):
            assert client.wait_matched(f"cmd/{arm}", minimum=1, timeout=10.0)
        assert wait_for(lambda: all(len(states[a]) >= 2 for a in states), 15.0)
        # the right arm moves first: the leader's model of it is then out of date unless it
        # takes the right arm's joints from its joint states (or the follower blends them in)
        client.publish("cmd/right", _cmd(9, "approach(right, leg3)", agents=["right"],
                                         realtime=0.0))  # fmt: skip
        assert wait_for(lambda: any(a["id"] == 9 for a in acks) and bool(plans["right"]), 15.0)
        there = np.array(plans["right"][0].points[-1].positions)

        def arrived() -> bool:
            with lock:
                return np.abs(states["right"][-1] - there).max() < 1e-9

        assert wait_for(arrived, 15.0)
        start_right = there
        del plans["right"][:]
        client.publish("cmd/left", _cmd(1, "place_tabletop(tabletop, assembly_pose)",
                                        agents=["left", "right"], realtime=1.0))  # fmt: skip
        assert wait_for(lambda: plans["left"] and plans["right"], 15.0)
        left, right = plans["left"][0], plans["right"][0]
        assert right.joint_names[0] == "right_joint1"
        assert np.abs(np.array(right.points[0].positions) - start_right).max() <= 1e-3
        end = left.points[-1].time_from_start
        assert right.points[-1].time_from_start == end  # one command, one duration
        with lock:
            n = {a: len(states[a]) for a in states}
        assert wait_for(lambda: all(len(states[a]) > n[a] + 10 for a in states), 15.0)
        client.publish("cmd/right", {"v": 1, "type": "stop", "id": 1, "reason": "human"})

        def still(arm: str) -> bool:  # the last ten joint states are equal
            with lock:
                last = states[arm][-10:]
            return len(last) == 10 and all(np.abs(q - last[0]).max() < 1e-12 for q in last)

        assert wait_for(lambda: still("left") and still("right"), 15.0)
        for arm, plan in (("left", left), ("right", right)):
            final = np.array(plan.points[-1].positions)
            assert np.abs(states[arm][-1] - final).max() > 1e-3, f"{arm} went on to the end"
        assert not [a for a in acks if a["id"] == 1]  # stopped: not acknowledged
        # a malformed part is dropped and counted; the arm stays where it is
        dropped = nodes["right"].dropped
        for bad in (
            {
                "v": 1,
                "type": "follow",
                "id": 5,
                "leader": "left",
                "times": [0.0, 1.0],
                "joints": [[0.0] * 3, [0.1] * 3],
            },  # 3 joints, not 7
            {
                "v": 1,
                "type": "follow",
                "id": 6,
                "leader": "left",
                "times": [1.0, 0.5],
                "joints": [[0.0] * 7, [0.1] * 7],
            },  # time runs backwards
            {"v": 1, "type": "follow", "id": 7, "times": [0.0], "joints": [[0.0] * 7]},
        ):
            client.publish("arm/right/follow", bad)  # fmt: skip
        assert wait_for(lambda: nodes["right"].dropped == dropped + 3, 10.0)
        assert still("right")
    finally:
        done.set()
        for r in runners:
            r.join(5)
        for bus in (*buses.values(), client):
            bus.close()
