"""A robot arm of the cell as a ROS 2 node, streaming standard messages.

:class:`ArmNode` *is* the cell's :class:`~flexhrc.cell.components.RobotAgent` (same protocol,
same "never execute one command id twice", same pacing by the cell's ``realtime``) on a
:class:`~flexhrc.ros2.transport.Ros2Transport`, plus what ROS 2 tools expect of an arm:

=======================================  ===================================  ==================
topic (under ``/flexhrc/<cell>/``)       type                                 when
=======================================  ===================================  ==================
``arm/<arm>/joint_states``               ``sensor_msgs/JointState``           ``rate_hz`` (50)
                                                                              while moving, 5 Hz
                                                                              idle
``arm/<arm>/pose``                       ``geometry_msgs/PoseStamped``        with each joint
                                                                              state
``arm/<arm>/joint_trajectory``           ``trajectory_msgs/JointTrajectory``  each command's plan
=======================================  ===================================  ==================

Two ways to execute a command:

* ``execute="sim"`` (default): the kinematic simulator (:mod:`flexhrc.action`, through
  :class:`~flexhrc.action.bridge.KinematicTaskSimulator`, the model the Task Manager simulates
  with) integrates the motion; the node plays it back on the wall clock at the cell's
  ``realtime`` speed and acknowledges at its end (``realtime`` 0: at once). A ``stop`` leaves the
  simulated arm where it was at that moment;
* ``execute="external"``: a real arm. The motion planned on the model from the arm's measured
  joints goes out as a ``JointTrajectory`` on ``trajectory_topic`` (e.g. a
  ``joint_trajectory_controller``); the command is ``done`` when the ``sensor_msgs/JointState``
  on ``joint_states_topic`` come within ``tolerance_rad`` of its last point, ``timed_out`` when
  they do not within ``1.5 x duration + 1 s``; a ``stop`` sends a one-point trajectory that holds
  the arm where it is.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexhrc.cell import protocol as P
from flexhrc.cell.components import RobotAgent
from flexhrc.errors import FlexhrcError
from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg

log = logging.getLogger("flexhrc.ros2.arm")

IDLE_RATE_HZ = 5.0
EXECUTE_MODES = ("sim", "external")

__all__ = ["EXECUTE_MODES", "ArmNode", "Motion"]


@dataclass
class Motion:
    """The planned motion of one command: samples of this arm's joints and the pace."""

    command_id: int
    t: np.ndarray  # (N,) seconds from the start, simulated time
    q: np.ndarray  # (N, dof)
    duration_s: float  # simulated
    speed: float  # simulated seconds per wall second (0: at once)
    started: float  # wall clock (monotonic) at the start
    timeout_s: float = math.inf  # wall seconds (external execution)
    t_cell: float = 0.0  # the cell's (simulated) time when the command was sent

    def sample(self, elapsed: float) -> np.ndarray:
        """Joint positions ``elapsed`` simulated seconds in (linear interpolation; the last
        sample is held, e.g. while the gripper closes)."""
        if elapsed <= self.t[0]:
            return self.q[0]
        if elapsed >= self.t[-1]:
            return self.q[-1]
        return np.array([np.interp(elapsed, self.t, self.q[:, j]) for j in range(self.q.shape[1])])


class ArmNode(RobotAgent):
    """The cell's robot agent as a ROS 2 node (see the module docstring)."""

    def __init__(
        self,
        name: str,
        scenario: Any,
        transport: Any,
        *,
        execution: Any = None,
        rate_hz: float = 50.0,
        execute: str = "sim",
        trajectory_topic: str | None = None,
        joint_states_topic: str | None = None,
        tolerance_rad: float = 0.01,
        trace: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
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
        if execution is None:
            from flexhrc.cell.components import execution_model

            # the scenario's own kinematic world (as `flexhrc agent robot --simulator kinematic`)
            execution = execution_model("kinematic", scenario)
        if not hasattr(execution, "execution"):
            raise FlexhrcError(
                f"the ROS 2 arm streams joint motions and so needs the kinematic simulator; "
                f"scenario {getattr(scenario, 'name', '?')!r} runs on the analytic one"
            )
        self.robot = execution.execution.sim.robot
        self.rate_hz = float(rate_hz)
        self.execute_mode = execute
        self.tolerance_rad = float(tolerance_rad)
        self.clock = clock
        self.motion: Motion | None = None
        self._measured: np.ndarray | None = None
        self._last_publish = -math.inf
        self._external_finish: Callable[[], None] | None = None
        self._starting: int | None = None
        # the ROS side first, then the agent (its liveliness token announces a ready node)
        JointState = msg("sensor_msgs.msg", "JointState")
        JointTrajectory = msg("trajectory_msgs.msg", "JointTrajectory")
        self._js_pub = transport.create_publisher(JointState, f"arm/{name}/joint_states")
        self._pose_pub = transport.create_publisher(
            msg("geometry_msgs.msg", "PoseStamped"), f"arm/{name}/pose"
        )
        self._plan_pub = transport.create_publisher(JointTrajectory, f"arm/{name}/joint_trajectory")
        self._controller_pub = (
            transport.create_publisher(JointTrajectory, trajectory_topic)
            if execute == "external" and trajectory_topic
            else None
        )
        super().__init__(name, scenario, transport, execution=execution, trace=trace)
        self.robot.arm(name)  # the robot model must have this arm too
        self.names = rm.joint_names(name, self.robot.arm(name).dof)
        if execute == "external" and joint_states_topic:
            transport.create_subscription(JointState, joint_states_topic, self._on_joint_states)

    # -- where the arm is -------------------------------------------------------------------
    def _model_q(self) -> np.ndarray:
        return np.asarray(self.execution.execution.state.q[self.name], dtype=float)  # type: ignore[attr-defined]

    @property
    def q(self) -> np.ndarray:
        """The arm's joint positions now (measured on a real arm)."""
        if self.execute_mode == "external":
            return self._measured if self._measured is not None else self._model_q()
        if self.motion is not None:
            return self.motion.sample(self._elapsed(self.motion))
        return self._model_q()

    def _elapsed(self, motion: Motion) -> float:
        if motion.speed <= 0:
            return math.inf
        return (self.clock() - motion.started) * motion.speed

    def _on_joint_states(self, m: Any) -> None:
        index = {n: i for i, n in enumerate(m.name)}
        if all(n in index for n in self.names) and len(m.position) == len(m.name):
            q = np.array([float(m.position[index[n]]) for n in self.names])
            if np.all(np.isfinite(q)):
                self._measured = q

    # -- commands (the cell's RobotAgent does the protocol) ---------------------------------
    def _command(self, message: dict[str, Any]) -> None:
        cid = int(message["id"])
        fresh = cid not in self.acks and cid not in self.running and cid not in self.stopped
        em = self.execution.execution  # type: ignore[attr-defined]
        if fresh and self.execute_mode == "external" and self._measured is not None:
            em.state.q[self.name] = self._measured.copy()  # plan from where the real arm is
        q0 = self._model_q().copy()
        before = len(em.log)
        self._starting = cid if fresh else None
        try:
            super()._command(message)
        finally:
            self._starting = None
        if not fresh or len(em.log) == before:
            return
        report = em.log[-1]
        traj = report.outcome.trajectory if report.outcome is not None else None
        if traj is not None and self.name in traj.arms and len(traj) > 0:
            t = np.asarray(traj.t, dtype=float)
            t = t - t[0]
            q = np.asarray(traj.arm_q(self.name), dtype=float)
        else:
            t, q = np.zeros(1), q0[None, :]
        speed = float(message.get("realtime", 0.0))
        duration = max(float(report.duration_s), float(t[-1]))
        motion = Motion(cid, t, q, duration, speed, self.clock(), t_cell=float(message["t"]))
        if self.execute_mode == "external":
            motion.timeout_s = 1.5 * motion.duration_s + 1.0
        plan = rm.joint_trajectory(self.names, t.tolist(), q.tolist(), time.time())
        self._plan_pub.publish(plan)
        if self._controller_pub is not None:
            self._controller_pub.publish(plan)
        if cid in self.running:  # still going: play it (sim) or watch the real arm (external)
            self.motion = motion
        self._publish_state()

    def _later(self, delay: float, fn: Callable[[], None]) -> None:
        if self.execute_mode == "external" and self._starting is not None:
            # a real arm answers when it gets there, not after the simulated time
            self._external_finish = fn
            return
        super()._later(delay, fn)

    def _stop(self, message: dict[str, Any]) -> None:
        cid = int(message["id"])
        motion = self.motion
        super()._stop(message)
        if motion is None or motion.command_id != cid or cid not in self.stopped:
            return
        q = self.q.copy()
        self.motion = None
        self._external_finish = None
        # the arm stays where it stopped, not where the plan ended
        self.execution.execution.state.q[self.name] = q  # type: ignore[attr-defined]
        if self._controller_pub is not None:
            self._controller_pub.publish(
                rm.joint_trajectory(self.names, [0.0], [q.tolist()], time.time())
            )
        self._publish_state()

    # -- the loop ---------------------------------------------------------------------------
    def poll(self) -> None:
        """Answers that are due (the agent's timers), the real arm's progress, joint states."""
        super().poll()
        motion = self.motion
        if motion is not None:
            if motion.command_id not in self.running:  # answered (sim) or stopped
                self.motion = None
                self._publish_state()
            elif self.execute_mode == "external":
                self._watch_external(motion)
        period = 1.0 / (self.rate_hz if self.motion is not None else IDLE_RATE_HZ)
        if self.clock() - self._last_publish >= period - 1e-4:
            self._publish_state()

    def _watch_external(self, motion: Motion) -> None:
        reached = self._measured is not None and bool(
            np.max(np.abs(self._measured - motion.q[-1])) <= self.tolerance_rad
        )
        if reached:
            finish, self._external_finish = self._external_finish, None
            self.motion = None
            if finish is not None:
                finish()
        elif self.clock() - motion.started > motion.timeout_s:
            self.motion = None
            self._external_finish = None
            self.running.discard(motion.command_id)
            ack = P.message(
                "ack",
                id=motion.command_id,
                agent=self.name,
                status="timed_out",
                reason=f"the arm did not reach the end of its trajectory within "
                f"{motion.timeout_s:.2f} s",
                t=round(motion.t_cell + motion.timeout_s, 6),
                duration=round(motion.timeout_s, 6),
                positions={},
            )
            self.acks[motion.command_id] = ack
            self.transport.publish(P.ACK_TOPIC, ack)
            self.trace(f"cmd {motion.command_id} timed_out")

    def next_due(self) -> float | None:
        period = 1.0 / (self.rate_hz if self.motion is not None else IDLE_RATE_HZ)
        due = self._last_publish + period
        other = super().next_due()
        return due if other is None else min(due, other)

    def _publish_state(self) -> None:
        q = self.q
        stamp = time.time()
        self._js_pub.publish(rm.joint_state(self.names, [float(v) for v in q], stamp))
        xyz, R = self.robot.arm(self.name).pose(np.asarray(q, dtype=float))
        self._pose_pub.publish(rm.pose_stamped(xyz, stamp, rm.quaternion_from_matrix(R)))
        self._last_publish = self.clock()
