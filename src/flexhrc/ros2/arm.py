"""A robot arm as a ROS 2 node: executes the cell's commands and streams standard messages.

:class:`ArmNode` is one arm of the cell (``flexhrc ros2 arm SCENARIO --arm NAME``). It speaks the
cell's JSON protocol on its :class:`~flexhrc.ros2.transport.Ros2Transport` (commands in, acks
out, a liveliness token ``alive/<arm>``) and publishes, for ROS 2 tools (RViz,
``robot_state_publisher``, rosbag):

=======================================  =================================  ===================
topic (under ``/flexhrc/<cell>/``)       type                               when
=======================================  =================================  ===================
``arm/<arm>/joint_states``               ``sensor_msgs/JointState``         ``rate_hz`` while
                                                                            moving, 5 Hz idle
``arm/<arm>/pose``                       ``geometry_msgs/PoseStamped``      with each joint state
``arm/<arm>/joint_trajectory``           ``trajectory_msgs/JointTrajectory`` each command's plan
=======================================  =================================  ===================

Two ways to execute a command:

* ``execute="sim"`` (default): the kinematic simulator of :mod:`flexhrc.action` (through
  :class:`~flexhrc.action.bridge.KinematicTaskSimulator`, the same model the Task Manager
  simulates with) integrates the motion; the node plays it back on the wall clock at
  ``realtime`` x speed (``0``: at once) and acknowledges at its end;
* ``execute="external"``: a real arm. The planned motion goes out as a ``JointTrajectory`` on
  ``trajectory_topic`` (e.g. ``/joint_trajectory_controller/joint_trajectory`` of
  ``ros2_control``) and the command is ``done`` when the arm's ``sensor_msgs/JointState`` on
  ``joint_states_topic`` come within ``tolerance_rad`` of the last point, ``timed_out`` when they
  do not within ``1.5 x duration + 1 s``.

A command id seen again (a cell resuming after a crash re-sends what was outstanding) is never
executed twice: while it runs it is ignored, once finished its ack is sent again.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from flexhrc.errors import FlexhrcError
from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg
from flexhrc.ros2.protocol import (
    PROTOCOL_VERSION,
    ack_topic,
    alive_key,
    command_topic,
    parse_agent_message,
)

log = logging.getLogger("flexhrc.ros2.arm")

IDLE_RATE_HZ = 5.0
EXECUTE_MODES = ("sim", "external")

__all__ = ["EXECUTE_MODES", "ArmNode", "Motion"]


@dataclass
class Motion:
    """One command being carried out: its planned motion of this arm and its outcome."""

    command_id: Any
    action: str
    t: np.ndarray  # (N,) seconds from the start
    q: np.ndarray  # (N, dof)
    status: str
    reason: str | None
    duration_s: float
    started: float = 0.0  # wall clock (monotonic)
    timeout_s: float = math.inf
    extra: dict[str, Any] = field(default_factory=dict)

    def sample(self, elapsed: float) -> np.ndarray:
        """Joint positions ``elapsed`` seconds into the motion (linear interpolation; the last
        sample is held, e.g. while a gripper closes)."""
        if len(self.t) == 0:
            return self.q[-1]
        if elapsed <= self.t[0]:
            return self.q[0]
        if elapsed >= self.t[-1]:
            return self.q[-1]
        return np.array([np.interp(elapsed, self.t, self.q[:, j]) for j in range(self.q.shape[1])])


class ArmNode:
    """A simulated (or real, ``execute="external"``) arm of the cell on ROS 2."""

    def __init__(
        self,
        transport: Any,
        arm: str,
        kb: Any,
        domain: Any,
        *,
        realtime: float = 1.0,
        rate_hz: float = 50.0,
        execute: str = "sim",
        trajectory_topic: str | None = None,
        joint_states_topic: str | None = None,
        tolerance_rad: float = 0.01,
        clock: Callable[[], float] = time.monotonic,
        simulator: Any = None,
    ) -> None:
        if not (math.isfinite(realtime) and realtime >= 0):
            raise FlexhrcError(f"--realtime must be a finite number >= 0, got {realtime}")
        if not (math.isfinite(rate_hz) and 30.0 <= rate_hz <= 1000.0):
            raise FlexhrcError(f"--rate must be between 30 and 1000 Hz, got {rate_hz}")
        if execute not in EXECUTE_MODES:
            raise FlexhrcError(
                f"--execute must be one of {', '.join(EXECUTE_MODES)}, not {execute!r}"
            )
        if execute == "external" and not (trajectory_topic and joint_states_topic):
            raise FlexhrcError(
                "--execute external needs --trajectory-topic and --joint-states-topic "
                "(the real arm's controller command and its joint states)"
            )
        if not (math.isfinite(tolerance_rad) and tolerance_rad > 0):
            raise FlexhrcError(f"--tolerance must be a positive angle, got {tolerance_rad}")
        agent = domain.agents.get(arm)
        if agent is None or agent.is_human:
            robots = [a.name for a in domain.agents.values() if not a.is_human]
            raise FlexhrcError(
                f"unknown arm {arm!r} (argument --arm); the scenario's arms: {', '.join(robots)}"
            )
        if simulator is None:
            from flexhrc.action.bridge import KinematicTaskSimulator

            simulator = KinematicTaskSimulator()
        self.sim = simulator
        robot = self.sim.execution.sim.robot
        robot.arm(arm)  # the robot model must have it too
        self.transport = transport
        self.arm = arm
        self.kb = kb
        self.domain = domain
        self.realtime = float(realtime)
        self.rate_hz = float(rate_hz)
        self.execute_mode = execute
        self.tolerance_rad = float(tolerance_rad)
        self.clock = clock
        self.names = rm.joint_names(arm, robot.arm(arm).dof)
        self.positions: dict[str, tuple[float, float, float]] = {}
        self.motion: Motion | None = None
        self.finished: dict[Any, dict[str, Any]] = {}  # command id -> its ack
        self.executed: list[Any] = []  # command ids, in execution order
        self.malformed = 0
        self._last_publish = -math.inf
        self._measured: np.ndarray | None = None
        self._t0 = clock()
        self._sub = transport.subscribe(command_topic(arm), self._on_message)
        self._js_pub = transport.create_publisher(
            msg("sensor_msgs.msg", "JointState"), f"arm/{arm}/joint_states"
        )
        self._pose_pub = transport.create_publisher(
            msg("geometry_msgs.msg", "PoseStamped"), f"arm/{arm}/pose"
        )
        JointTrajectory = msg("trajectory_msgs.msg", "JointTrajectory")
        self._plan_pub = transport.create_publisher(JointTrajectory, f"arm/{arm}/joint_trajectory")
        self._controller_pub = (
            transport.create_publisher(JointTrajectory, trajectory_topic)
            if execute == "external" and trajectory_topic
            else None
        )
        if execute == "external" and joint_states_topic:
            transport.create_subscription(
                msg("sensor_msgs.msg", "JointState"), joint_states_topic, self._on_joint_states
            )
        # announce only once the command subscription exists (see Ros2Transport.publish)
        self._token = transport.declare_token(alive_key(arm))

    # -- time -------------------------------------------------------------------------------
    def _stamp(self) -> float:
        return max(time.time(), 0.0)

    @property
    def q(self) -> np.ndarray:
        """The arm's current joint positions."""
        if self.motion is not None and self.execute_mode == "sim":
            return self.motion.sample(self._elapsed(self.motion))
        if self.execute_mode == "external" and self._measured is not None:
            return self._measured
        return np.asarray(self.sim.execution.state.q[self.arm], dtype=float)

    def _elapsed(self, motion: Motion) -> float:
        if self.realtime == 0:
            return math.inf
        return (self.clock() - motion.started) * self.realtime

    # -- messages in ------------------------------------------------------------------------
    def _on_message(self, payload: Any) -> None:
        try:
            m = parse_agent_message(payload)
        except ValueError as exc:
            self.malformed += 1
            log.warning("%s: dropped a malformed message: %s", self.arm, exc)
            return
        if m["kind"] == "stop":
            self.stop(m["id"], m.get("reason") or "stopped")
        else:
            self.command(m["id"], m["action"], m.get("agents") or [self.arm])

    def _on_joint_states(self, m: Any) -> None:
        index = {n: i for i, n in enumerate(m.name)}
        if not all(n in index for n in self.names):
            return  # another arm's joints
        self._measured = np.array([float(m.position[index[n]]) for n in self.names])

    # -- commands ---------------------------------------------------------------------------
    def command(self, command_id: Any, action: str, agents: list[str]) -> None:
        """Start a command (the protocol's ``command`` message)."""
        if command_id in self.finished:
            self._publish_ack(self.finished[command_id])  # a resent command: the same answer
            return
        if self.motion is not None:
            if self.motion.command_id == command_id:
                return  # already running
            # the manager never sends a busy arm a command; if it does, the old one is over
            self.stop(self.motion.command_id, f"superseded by command {command_id}")
        motion = self._plan(command_id, action, agents)
        self.executed.append(command_id)
        motion.started = self.clock()
        self.motion = motion
        plan = rm.joint_trajectory(self.names, motion.t.tolist(), motion.q.tolist(), self._stamp())
        self._plan_pub.publish(plan)
        if self._controller_pub is not None:
            self._controller_pub.publish(plan)
        log.info("%s: command %s %s (%.2f s)", self.arm, command_id, action, motion.duration_s)
        self.step()

    def _plan(self, command_id: Any, action: str, agents: list[str]) -> Motion:
        q0 = np.asarray(self.sim.execution.state.q[self.arm], dtype=float)
        hold = Motion(command_id, action, np.zeros(1), q0[None, :], "failed", None, 0.0)
        try:
            schema, args = self.domain.invocation(action)
        except Exception as exc:  # a malformed or unknown action: answered, not raised
            hold.reason = f"cannot execute {action!r}: {exc}"
            return hold
        if list(agents) != [self.arm]:
            hold.reason = f"{action}: this node is arm {self.arm!r}, the command is for {agents}"
            return hold
        from flexhrc.taskmanager.domain import GroundAction

        ground = GroundAction(schema, tuple(args), (self.arm,))
        em = self.sim.execution
        if self.execute_mode == "external" and self._measured is not None:
            # plan on the model from where the real arm is
            em.state.q[self.arm] = self._measured.copy()
        before = len(em.log)
        try:
            report = self.sim.execute(ground, self.positions, self.kb, self.domain)
        except FlexhrcError as exc:
            hold.reason = f"{action}: {exc}"
            return hold
        if len(em.log) > before:
            traj = em.log[-1].outcome.trajectory
            t = np.asarray(traj.t, dtype=float)
            q = np.asarray(traj.arm_q(self.arm), dtype=float) if self.arm in traj.arms else q0[None]
        else:  # answered without moving (e.g. an action the simulator does not know)
            t, q = np.zeros(1), q0[None, :]
        if len(t) == 0:
            t, q = np.zeros(1), q0[None, :]
        motion = Motion(
            command_id,
            action,
            t - t[0],
            q,
            report.status,
            report.reason,
            max(float(report.duration_s), float(t[-1] - t[0])),
        )
        if self.execute_mode == "external":
            motion.timeout_s = 1.5 * motion.duration_s + 1.0
        return motion

    def stop(self, command_id: Any, reason: str) -> None:
        """Stop the running command where the arm is (the protocol's ``stop`` message); its ack
        says ``failed`` with the reason."""
        motion = self.motion
        if motion is None or motion.command_id != command_id:
            return
        q = self.q
        self.motion = None
        # the simulated arm stays where it stopped, not where the plan ended
        self.sim.execution.state.q[self.arm] = np.asarray(q, dtype=float).copy()
        if self._controller_pub is not None:
            hold = rm.joint_trajectory(self.names, [0.0], [list(q)], self._stamp())
            self._controller_pub.publish(hold)
        self._finish(motion, "failed", f"stopped: {reason}")

    def _finish(self, motion: Motion, status: str, reason: str | None) -> None:
        ack = {
            "v": PROTOCOL_VERSION,
            "kind": "ack",
            "id": motion.command_id,
            "agent": self.arm,
            "status": status,
            "reason": reason,
            "duration_s": round(motion.duration_s, 4),
        }
        self.finished[motion.command_id] = ack
        self._publish_state(self.q)
        self._publish_ack(ack)
        log.info("%s: command %s %s", self.arm, motion.command_id, status)

    def _publish_ack(self, ack: dict[str, Any]) -> None:
        self.transport.publish(ack_topic(), ack)

    # -- the loop ---------------------------------------------------------------------------
    def step(self) -> float:
        """Publish what is due and finish a motion that ended; returns the seconds until the
        next thing is due (for the caller's wait)."""
        now = self.clock()
        motion = self.motion
        period = 1.0 / (self.rate_hz if motion is not None else IDLE_RATE_HZ)
        if motion is not None:
            if self.execute_mode == "sim":
                if self._elapsed(motion) >= motion.duration_s:
                    self.motion = None
                    self._finish(motion, motion.status, motion.reason)
                    return period
            else:
                if self._reached(motion):
                    self.motion = None
                    self._finish(
                        motion, "done" if motion.status == "done" else motion.status, motion.reason
                    )
                    return period
                if now - motion.started > motion.timeout_s:
                    self.motion = None
                    self._finish(
                        motion,
                        "timed_out",
                        f"the arm did not reach the end of the trajectory within "
                        f"{motion.timeout_s:.2f} s",
                    )
                    return period
        if now - self._last_publish >= period - 1e-4:
            self._publish_state(self.q)
        return max(0.0, self._last_publish + period - self.clock())

    def _reached(self, motion: Motion) -> bool:
        if self._measured is None:
            return False
        return bool(np.max(np.abs(self._measured - motion.q[-1])) <= self.tolerance_rad)

    def _publish_state(self, q: np.ndarray) -> None:
        stamp = self._stamp()
        self._js_pub.publish(rm.joint_state(self.names, [float(v) for v in q], stamp))
        xyz, R = self.sim.execution.sim.robot.arm(self.arm).pose(np.asarray(q, dtype=float))
        self._pose_pub.publish(rm.pose_stamped(xyz, stamp, rm.quaternion_from_matrix(R)))
        self._last_publish = self.clock()

    def run(self, until: Callable[[], bool] = lambda: False) -> None:
        """Serve commands until ``until()`` is true (or forever)."""
        while not until():
            delay = self.step()
            if self.transport.wait(min(delay, 0.05)):
                self.transport.flush()

    def close(self) -> None:
        self._token.undeclare()
        self._sub.cancel()
