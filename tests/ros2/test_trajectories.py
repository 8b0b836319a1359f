"""ROS 2 for any task (issue 19, item 8): over `flexhrc ros2 cell FILE` with two `flexhrc ros2
arm` nodes and an operator node, every robot command of the scenario — a task of the user's own
as much as the table — gives each arm it moves a `JointTrajectory` that starts at the joint
state that arm published last and lasts the command's simulated duration; both arms' joint
states move during a joint command; the `MarkerArray` draws every object of the knowledge base
and deletes the arrow of each finished command.

One process run per scenario serves every assertion. Everything waits on conditions (the
manager's exit, the messages seen) with generous deadlines, never on fixed sleeps.
"""

from __future__ import annotations

import bisect
import itertools
import subprocess
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from flexhrc.cell import read_store
from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg
from flexhrc.ros2.transport import Ros2Transport
from tests.ros2.conftest import wait_for
from tests.ros2.test_cell import _finish, _node, _stop_all

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
ARMS = ("left", "right")

# a task of a user's own: a joint command of both arms, a part only the left arm reaches (and
# only arms handle), a step only the person may do, a check either arm may make
CRATE = """\
flexhrc: 1
name: crate_kit
description: A crate lifted onto its dock by both arms, a bracket fitted, labelled, checked.
graphs:
  crate_kit:
    root: checked
    nodes:
      - {name: kit, state: "crate(?c) & on_bench(?c)"}
      - {name: docked, state: "docked(crate)"}
      - {name: fitted, state: "fitted(bracket)"}
      - {name: labelled, state: "labelled(crate)"}
      - {name: checked, state: "inspected(crate)"}
    hyperarcs:
      - {name: arms_lift, children: [kit], parent: docked, weight: 1,
         actions: ["lift(?c, dock)"]}
      - {name: fit_bracket, children: [docked], parent: fitted, weight: 1,
         actions: ["pick(?who, bracket)", "fit(?who, bracket, crate)"]}
      - {name: label_crate, children: [fitted], parent: labelled, weight: 1,
         actions: ["stick(human, crate)"]}
      - {name: inspect, children: [labelled], parent: checked, weight: 1,
         actions: ["check(?who, crate)"]}
domain:
  agents:
    human: {kind: human, types: [human], hand: [1.1, 0.0, 0.1]}
    left: {kind: robot, types: [arm], base: [0.0, 0.15, 0.433], rest: [0.307, 0.15, 0.587],
           reach: 0.9}
    right: {kind: robot, types: [arm], base: [0.0, -0.15, 0.433],
            rest: [0.307, -0.15, 0.587], reach: 0.9}
  actions:
    lift:
      parameters: {"?c": crate, "?to": place}
      agents: {joint: [left, right]}
      kind: transport
      pre: ["on_bench(?c)"]
      add: ["docked(?c)"]
      delete: ["on_bench(?c)"]
      moves_to: "?to"
      carries: "?c"
      duration: 3.0
    pick:
      parameters: {"?who": arm, "?p": part}
      agents: {choice: "?who"}
      kind: grasp
      pre: ["on_bench(?p)"]
      add: ["holding(?who, ?p)"]
      delete: ["on_bench(?p)"]
      moves_to: "?p"
      duration: 1.0
    fit:
      parameters: {"?who": arm, "?p": part, "?into": crate}
      agents: {choice: "?who"}
      kind: insert
      pre: ["holding(?who, ?p)", "docked(?into)"]
      add: ["fitted(?p)"]
      delete: ["holding(?who, ?p)"]
      moves_to: "?into"
      carries: "?p"
      duration: 1.5
    stick:
      parameters: {"?who": human, "?c": crate}
      agents: {choice: "?who"}
      kind: none
      pre: ["fitted(bracket)"]
      add: ["labelled(?c)"]
      duration: 2.0
    check:
      parameters: {"?who": arm, "?c": crate}
      agents: {choice: "?who"}
      kind: check
      pre: ["labelled(?c)"]
      add: ["inspected(?c)"]
      moves_to: "?c"
      duration: 1.5
world:
  objects:
    crate: {type: crate, position: [0.42, -0.02, 0.0], size: [0.20, 0.16, 0.12]}
    bracket: {type: part, position: [0.35, 0.45, 0.0], size: [0.08, 0.04, 0.02],
              reachable_by: [left]}
    lamp: {type: lamp, position: [0.70, 0.30, 0.0], size: {radius: 0.03, height: 0.2}}
  places:
    dock: [0.58, 0.0, 0.05]
  facts: ["on_bench(crate)", "on_bench(bracket)"]
  supertypes: {lamp: part}
humans:
  - {name: human, profile: passive, speed: 1.0}
simulator: analytic
"""


def _seconds(d: Any) -> float:
    return float(d.sec) + float(d.nanosec) * 1e-9


class Recorder:
    """The arms' joint states and trajectories (stamped by their node), and the markers."""

    def __init__(self, cell: str, domain_id: int) -> None:
        self.bus = Ros2Transport(prefix=f"flexhrc/{cell}", domain_id=domain_id, deliver="thread")
        self.lock = threading.Lock()
        self.states: dict[str, list[tuple[float, np.ndarray]]] = {a: [] for a in ARMS}
        self.plans: dict[str, list[tuple[float, Any]]] = {a: [] for a in ARMS}
        self.markers: list[Any] = []
        JointState = msg("sensor_msgs.msg", "JointState")
        JointTrajectory = msg("trajectory_msgs.msg", "JointTrajectory")
        for arm in ARMS:
            self.bus.create_subscription(
                JointState, f"arm/{arm}/joint_states", lambda m, a=arm: self._state(a, m)
            )
            self.bus.create_subscription(
                JointTrajectory, f"arm/{arm}/joint_trajectory", lambda m, a=arm: self._plan(a, m)
            )
        self.bus.create_subscription(
            msg("visualization_msgs.msg", "MarkerArray"), "markers", self._markers
        )

    def _state(self, arm: str, m: Any) -> None:
        with self.lock:
            self.states[arm].append((rm.stamp_seconds(m.header.stamp), np.array(m.position)))

    def _plan(self, arm: str, m: Any) -> None:
        with self.lock:
            self.plans[arm].append((rm.stamp_seconds(m.header.stamp), m))

    def _markers(self, m: Any) -> None:
        with self.lock:
            self.markers.append(m)

    def deleted(self) -> set[int]:
        with self.lock:
            return {
                mk.id
                for array in self.markers
                for mk in array.markers
                if mk.ns == "flexhrc/commands" and mk.action == mk.DELETE
            }

    def close(self) -> None:
        self.bus.close()


def _run(tmp_path: Path, scenario: str, env: dict[str, str], domain_id: int, cell: str):
    """The whole cell as processes; returns (the manager's JSON, the store's events, recorder)."""
    common = [scenario, "--cell", cell]
    store = tmp_path / "c.db"
    rec = Recorder(cell, domain_id)
    procs: list[subprocess.Popen[str]] = []
    try:
        # the recorder hears the arms and sees the manager's markers before anything moves: the
        # manager waits for the operator node, started last (DDS drops what it publishes to a
        # subscriber it has not discovered yet)
        for arm in ARMS:
            procs.append(_node(env, "arm", *common, "--arm", arm, log=tmp_path / f"{arm}.log"))

        def arms_heard() -> bool:
            with rec.lock:
                return all(len(rec.states[a]) >= 2 for a in ARMS)

        assert wait_for(arms_heard, 90.0), "the arm nodes publish no joint states"
        manager = _node(env, "cell", *common, "--json", "--realtime", "4", "--store", str(store),
                        "--markers-rate", "20", log=tmp_path / "manager.log")  # fmt: skip
        procs.append(manager)
        markers = rec.bus.ros_name("markers")
        assert wait_for(lambda: rec.bus.node.count_publishers(markers) >= 1, 90.0), (
            "the manager publishes no markers"
        )
        procs.append(_node(env, "human", *common, "--name", "human", log=tmp_path / "h.log"))
        data = _finish(manager, 240, tmp_path)
        events = read_store(store)
        commands = [e.body for e in events if e.kind == "command"]
        wanted = {a: sum(a in c["agents"] for c in commands) for a in ARMS}

        def all_seen() -> bool:
            with rec.lock:
                plans = {a: len(rec.plans[a]) for a in ARMS}
            return plans == wanted and {c["id"] for c in commands} <= rec.deleted()

        # the last messages may still be on their way when the manager has exited
        assert wait_for(all_seen, 30.0), (
            f"trajectories wanted {wanted}, seen { ({a: len(rec.plans[a]) for a in ARMS}) }; "
            f"no DELETE of commands {sorted({c['id'] for c in commands} - rec.deleted())}"
        )
    finally:
        rec.close()
        _stop_all(procs)
    return data, events, rec


def _check_trajectories(data: dict, events: list, rec: Recorder) -> dict[int, dict[str, Any]]:
    """Each arm: one trajectory per command it takes part in, in order, from its last joint
    state, lasting the command's duration; returns command id -> arm -> (stamp, trajectory)."""
    commands = [e.body for e in events if e.kind == "command"]
    acks = {e.body["id"]: e.body for e in events if e.kind == "ack"}
    stopped = {e.body["id"] for e in events if e.kind == "stop"}
    by_command: dict[int, dict[str, Any]] = {}
    for arm in ARMS:
        mine = [c for c in commands if arm in c["agents"]]
        plans = sorted(rec.plans[arm], key=lambda p: p[0])
        states = sorted(rec.states[arm], key=lambda s: s[0])
        stamps = [s[0] for s in states]
        assert len(plans) == len(mine), (arm, len(plans), len(mine))
        for cmd, (stamp, plan) in zip(mine, plans, strict=True):
            assert plan.joint_names == rm.joint_names(arm)
            times = [_seconds(p.time_from_start) for p in plan.points]
            assert times[0] == 0.0 and all(b > a for a, b in itertools.pairwise(times))
            ack = acks.get(cmd["id"])
            if ack is None:  # stopped (a process round whose end came): no answer to compare
                assert cmd["id"] in stopped, cmd
            else:
                assert times[-1] == pytest.approx(ack["duration"], abs=2e-6), (arm, cmd)
            before = bisect.bisect_right(stamps, stamp) - 1
            assert before >= 0, f"{arm}: no joint state before its trajectory for {cmd}"
            gap = np.max(np.abs(np.array(plan.points[0].positions) - states[before][1]))
            assert gap <= 1e-3, (arm, cmd["action"], gap)
            by_command.setdefault(cmd["id"], {})[arm] = (stamp, plan)
    return by_command


def _check_joint_motion(events: list, rec: Recorder, by_command: dict) -> None:
    """During each joint command both arms' joint states move along their trajectories."""
    joint = [e.body for e in events if e.kind == "command" and len(e.body["agents"]) == 2]
    assert joint, "the scenario ran no joint command"
    done = {e.body["id"] for e in events if e.kind == "ack" and e.body["status"] == "done"}
    for cmd in joint:
        for arm in cmd["agents"]:
            stamp, plan = by_command[cmd["id"]][arm]
            first = np.array(plan.points[0].positions)
            last = np.array(plan.points[-1].positions)
            # the farthest the path goes, not where it ends: a hold (a node process) takes the
            # part and lets go of it again, ending about where it began
            farthest = max(np.max(np.abs(np.array(p.positions) - first)) for p in plan.points)
            assert farthest > 0.05, f"{arm} does not move in {cmd}"
            later = [s for s in rec.plans[arm] if s[0] > stamp]
            until = min((s[0] for s in later), default=float("inf"))
            during = [q for t, q in rec.states[arm] if stamp <= t < until]
            between = [
                q for q in during
                if np.max(np.abs(q - first)) > 1e-4 and np.max(np.abs(q - last)) > 1e-4
            ]  # fmt: skip
            assert between, f"{arm}: no joint state on the way during {cmd['action']}"
            if cmd["id"] in done:  # (a stopped one ends where it was stopped)
                assert any(np.max(np.abs(q - last)) < 1e-6 for q in during), f"{arm} stopped"


def _check_markers(data: dict, events: list, rec: Recorder) -> None:
    agents = set(data["cell"]["agents"])
    objects = {o["id"] for o in data["knowledge"]["objects"]} - agents
    shown = {
        mk.text
        for array in rec.markers
        for mk in array.markers
        if mk.ns == "flexhrc" and mk.type != mk.TEXT_VIEW_FACING and mk.action == mk.ADD
    }
    assert objects <= shown, objects - shown
    assert not shown & agents
    commands = {e.body["id"] for e in events if e.kind == "command"}
    assert commands <= rec.deleted()


SCENARIOS = ["crate", "table_assembly"] + (
    ["gearbox"] if (ROOT / "examples" / "scenarios" / "gearbox.yaml").exists() else []
)


@pytest.mark.parametrize("name", SCENARIOS)
def test_every_command_gives_each_of_its_arms_a_trajectory_from_where_it_is(
    name: str, tmp_path: Path, ros_env: dict[str, str], domain_id: int, cell_name: str
):
    if name == "crate":
        path = tmp_path / "crate.yaml"
        path.write_text(CRATE)
        scenario = str(path)
    elif name == "gearbox":
        scenario = str(ROOT / "examples" / "scenarios" / "gearbox.yaml")
    else:
        scenario = name
    data, events, rec = _run(tmp_path, scenario, ros_env, domain_id, cell_name)
    assert data["outcome"] == "solved", data.get("reason")
    by_command = _check_trajectories(data, events, rec)
    assert all(rec.plans[a] for a in ARMS)  # both arms worked
    _check_joint_motion(events, rec, by_command)
    _check_markers(data, events, rec)
    if name == "crate":  # the person-only step went to the person, the bracket to the left arm
        done = [e.body["action"] for e in events if e.kind == "human_action"]
        assert any(a.startswith("stick(human") for a in done)
        assert not any("bracket" in c.body["action"] and "right" in c.body["agents"]
                       for c in events if c.kind == "command")  # fmt: skip
