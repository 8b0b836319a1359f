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
``arm/<arm>/follow``                     JSON (``std_msgs/String``)           in: a joint
                                                                              command's part
=======================================  ===================================  ==================

Every command the arm takes part in gets one ``JointTrajectory`` (:mod:`flexhrc.ros2.motion`):
it starts at the joint state the arm published last and its last point's ``time_from_start`` is
the command's simulated duration (the ``duration`` of its ack); the joint states follow it while
the command runs. A joint command (``agents: {joint: [left, right]}``) reaches only its first
arm, the leader: it plans the motion of all its arms on the model — with the other arms' joints
as their own nodes last published them (``arm/<other>/joint_states``) — and sends each other
arm its part on ``arm/<other>/follow`` (``{"v": 1, "type": "follow", "id", "leader", "times",
"joints", "realtime"}``; ``{"v": 1, "type": "follow_stop", "id", "by"}`` when the command is
stopped — either way: a stop that reaches the follower stops the leader too). The follower
publishes that part as its own trajectory — moved to begin exactly where it is, should
the leader have planned from an older joint state — and plays it, without acknowledging: the
leader answers for the command.

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
from flexhrc.ros2 import motion as mp
from flexhrc.ros2._deps import msg

log = logging.getLogger("flexhrc.ros2.arm")

IDLE_RATE_HZ = 5.0
EXECUTE_MODES = ("sim", "external")

__all__ = ["EXECUTE_MODES", "ArmNode", "Motion", "check_arm_options"]


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
    follow: bool = False  # this arm's part of another arm's joint command (no ack of its own)
    leader: str | None = None  # the arm that leads it (follow)
    followers: tuple[str, ...] = ()  # the other arms of a joint command this arm leads

    def sample(self, elapsed: float) -> np.ndarray:
        """Joint positions ``elapsed`` simulated seconds in (linear interpolation; the last
        sample is held, e.g. while the gripper closes)."""
        if elapsed <= self.t[0]:
            return self.q[0]
        if elapsed >= self.t[-1]:
            return self.q[-1]
        return np.array([np.interp(elapsed, self.t, self.q[:, j]) for j in range(self.q.shape[1])])


def check_arm_options(
    rate_hz: float,
    execute: str,
    trajectory_topic: str | None,
    joint_states_topic: str | None,
    tolerance_rad: float,
) -> None:
    """The options of an arm node (:class:`ArmNode`, ``flexhrc ros2 arm``) as they are alone,
    or one :class:`~flexhrc.errors.FlexhrcError` naming the command's option."""
    if not (math.isfinite(rate_hz) and 30.0 <= rate_hz <= 1000.0):
        raise FlexhrcError(f"--rate must be between 30 and 1000 Hz, got {rate_hz}")
    if execute not in EXECUTE_MODES:
        raise FlexhrcError(f"--execute must be one of {', '.join(EXECUTE_MODES)}, not {execute!r}")
    if execute == "external" and not (trajectory_topic and joint_states_topic):
        raise FlexhrcError(
            "--execute external needs --trajectory-topic and --joint-states-topic "
            "(the real arm's controller command and its joint states)"
        )
    if not (math.isfinite(tolerance_rad) and tolerance_rad > 0):
        raise FlexhrcError(f"--tolerance must be a positive angle, got {tolerance_rad}")


def _joints(m: Any, names: list[str]) -> np.ndarray | None:
    """The positions of joints ``names`` in a ``JointState`` that may list others too (None
    unless it has them all, finite)."""
    index = {n: i for i, n in enumerate(m.name)}
    if all(n in index for n in names) and len(m.position) == len(m.name):
        q = np.array([float(m.position[index[n]]) for n in names])
        if np.all(np.isfinite(q)):
            return q
    return None


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
        check_arm_options(rate_hz, execute, trajectory_topic, joint_states_topic, tolerance_rad)
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
        self._start_q: dict[str, np.ndarray] = {}
        self._log_at = 0
        self._message: dict[str, Any] = {}
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
        # the other arms: where they are (to plan a joint command from there), what they follow
        self.robot.arm(name)  # the robot model must have this arm too
        self._others: dict[str, np.ndarray] = {}
        self.others = tuple(a for a in self.robot.arm_names if a != name)
        for other in self.others:
            transport.create_subscription(
                JointState, f"arm/{other}/joint_states", lambda m, o=other: self._on_other(o, m)
            )
        self._follow_sub = transport.subscribe(f"arm/{name}/follow", self._on_follow)
        super().__init__(name, scenario, transport, execution=execution, trace=trace)
        self._subs.append(self._follow_sub)
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
        q = _joints(m, self.names)
        if q is not None:
            self._measured = q

    def _on_other(self, arm: str, m: Any) -> None:
        q = _joints(m, rm.joint_names(arm, self.robot.arm(arm).dof))
        if q is not None:
            self._others[arm] = q

    # -- commands (the cell's RobotAgent does the protocol) ---------------------------------
    def _command(self, message: dict[str, Any]) -> None:
        cid = int(message["id"])
        if not self._of_this_scenario(message) or not self._enter_run(message):
            return  # the agent stops with the error (``fatal``)
        fresh = cid not in self.acks and cid not in self.running and cid not in self.stopped
        em = self.execution.execution  # type: ignore[attr-defined]
        if fresh:
            if self.motion is not None and self.motion.follow:
                # the leader has answered the joint command: its part is over
                self.motion = None
                self._publish_state()
            if self.execute_mode == "external" and self._measured is not None:
                em.state.q[self.name] = self._measured.copy()  # plan from where the real arm is
            for other, q in self._others.items():  # the other arms as they last reported
                em.state.q[other] = q.copy()
        self._keep_start(em)
        self._log_at = len(em.log)
        self._message = message
        self._starting = cid if fresh else None
        try:
            super()._command(message)
        finally:
            self._starting = None

    def _take_joints(self, joints: dict[str, list[float]]) -> None:
        """The manager's model has the arms where their acks left them — the other arms more
        exactly than their last published joint states, which may lag. A real arm
        (``external``) keeps its measured joints."""
        if self.execute_mode == "external":
            joints = {a: q for a, q in joints.items() if a != self.name}
        super()._take_joints(joints)
        self._keep_start(self.execution.execution)  # type: ignore[attr-defined]

    def _keep_start(self, em: Any) -> None:
        """Where the arms are as the command begins: its trajectory starts there (the joints
        a command carries move them before it runs, see :meth:`_take_joints`)."""
        self._start_q = {a: np.asarray(v, dtype=float).copy() for a, v in em.state.q.items()}

    def _started(self, cid: int, action: Any, ack: dict[str, Any]) -> None:
        """The command runs: its joint trajectory out (and the followers' parts), then play it."""
        message = self._message
        t, paths = mp.command_path(
            self.execution,
            action,
            since=self._log_at,
            start=self._start_q,
            duration=float(ack["duration"]),
            positions={k: o.position for k, o in self.kb.objects.items()},
        )
        if self.name not in paths:  # the model could not place this arm: it stays
            t, paths = mp.fit_duration(
                np.zeros(1), {self.name: self._start_q[self.name][None, :]}, float(t[-1])
            )
        q = paths[self.name]
        speed = float(message.get("realtime", 0.0))
        followers = tuple(a for a in paths if a != self.name and a in action.agents)
        motion = Motion(
            cid, t, q, float(t[-1]), speed, self.clock(), t_cell=float(message["t"]),
            followers=followers,
        )  # fmt: skip
        if self.execute_mode == "external":
            motion.timeout_s = 1.5 * motion.duration_s + 1.0
        plan = rm.joint_trajectory(self.names, t.tolist(), q.tolist(), time.time())
        self._send_plan(plan)
        for other in followers:
            self.transport.publish(
                f"arm/{other}/follow",
                {"v": 1, "type": "follow", "id": cid, "leader": self.name,
                 "times": [round(float(v), 6) for v in t],
                 "joints": [[round(float(v), 9) for v in row] for row in paths[other]],
                 "realtime": speed},
            )  # fmt: skip
        self.motion = motion
        self._publish_state()

    def _later(self, delay: float, fn: Callable[[], None]) -> None:
        cid = self._starting
        if cid is not None:
            answer = fn

            def fn() -> None:
                # the arm's last joint state is the end of its trajectory, before the answer
                motion = self.motion
                if cid in self.running and motion is not None and motion.command_id == cid:
                    self.motion = None
                    self._publish_state()
                answer()

        if self.execute_mode == "external" and cid is not None:
            # a real arm answers when it gets there, not after the simulated time
            self._external_finish = fn
            return
        super()._later(delay, fn)

    def _stop(self, message: dict[str, Any]) -> None:
        cid = int(message["id"])
        motion = self.motion
        if motion is not None and motion.follow and motion.command_id == cid:
            # the stop of a joint command came to this arm: it stops, and so does its leader
            self._halt()
            if motion.leader is not None:
                self._tell(motion.leader, cid)
            return
        super()._stop(message)
        if motion is None or motion.command_id != cid or cid not in self.stopped:
            return
        for other in motion.followers:
            self._tell(other, cid)
        self._halt()
        self._external_finish = None

    def _tell(self, arm: str, cid: int) -> None:
        """Stop ``arm``'s part of joint command ``cid`` too."""
        self.transport.publish(
            f"arm/{arm}/follow", {"v": 1, "type": "follow_stop", "id": cid, "by": self.name}
        )

    def _send_plan(self, plan: Any) -> None:
        """A command's trajectory, once: to every subscriber already known (and the real
        arm's controller)."""
        send = getattr(self.transport, "publish_message", None)
        for pub in (self._plan_pub, self._controller_pub):
            if pub is None:
                continue
            if send is not None:
                send(pub, plan)
            else:
                pub.publish(plan)

    def _halt(self) -> None:
        """The arm stays where it is now, not where its plan ended."""
        q = self.q.copy()
        self.motion = None
        self.execution.execution.state.q[self.name] = q  # type: ignore[attr-defined]
        if self._controller_pub is not None:
            self._controller_pub.publish(
                rm.joint_trajectory(self.names, [0.0], [q.tolist()], time.time())
            )
        self._publish_state()

    # -- this arm's part of another arm's joint command -------------------------------------
    def _on_follow(self, data: Any) -> None:
        try:
            cid, t, q, speed = self._parse_follow(data)
        except FlexhrcError as exc:
            self._bad(data, exc)
            return
        except (KeyError, TypeError, ValueError) as exc:
            self._bad(data, FlexhrcError(f"follow: {exc}"))
            return
        if t is None:  # follow_stop: of this arm's part, or of the joint command it leads
            if self.motion is not None and self.motion.follow and self.motion.command_id == cid:
                self._halt()
            elif cid in self.running:
                self._stop({"id": cid, "reason": f"stopped on {data.get('by', 'another arm')}"})
            return
        if self.motion is not None and not self.motion.follow:
            self._bad(data, FlexhrcError(f"follow {cid}: busy with command "
                                         f"{self.motion.command_id}"))  # fmt: skip
            return
        if self.motion is not None:  # a former joint command's part: over, at its end
            self.motion = None
            self._publish_state()
        q = mp.blend_start(t, q, self.q)  # begins where this arm is, ends where it was planned
        self.trace(f"follow cmd {cid} of {data.get('leader')} ({float(t[-1]):.2f} s)")
        plan = rm.joint_trajectory(self.names, t.tolist(), q.tolist(), time.time())
        self._send_plan(plan)
        self.execution.execution.state.q[self.name] = q[-1].copy()  # type: ignore[attr-defined]
        self.motion = Motion(
            cid, t, q, float(t[-1]), speed, self.clock(), follow=True,
            leader=str(data.get("leader")) if data.get("leader") in self.others else None,
        )  # fmt: skip
        self._publish_state()

    def _parse_follow(self, data: Any) -> tuple[int, np.ndarray | None, np.ndarray, float]:
        m = P.parse(data, expect=("follow", "follow_stop"))  # the catalogue's schema
        cid = int(m["id"])
        if m["type"] == "follow_stop":
            return cid, None, np.zeros((0, 0)), 0.0
        t = np.asarray(m["times"], dtype=float)
        q = np.asarray(m["joints"], dtype=float)
        dof = len(self.names)
        if t.ndim != 1 or len(t) == 0 or q.shape != (len(t), dof):
            raise ValueError(f"needs times (N) and joints (N x {dof})")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))) or np.any(np.diff(t) <= 0):
            raise ValueError("times must be finite and increasing, joints finite")
        speed = float(data.get("realtime", 0.0))
        if not (np.isfinite(speed) and speed >= 0):
            raise ValueError(f"realtime must be >= 0, not {speed}")
        return cid, t - t[0], q, speed

    # -- the loop ---------------------------------------------------------------------------
    def poll(self) -> None:
        """Answers that are due (the agent's timers), the real arm's progress, joint states."""
        super().poll()
        motion = self.motion
        if motion is not None:
            if motion.follow:
                if self._elapsed(motion) >= motion.duration_s:  # its part played to the end
                    self.motion = None
                    self._publish_state()
            elif motion.command_id not in self.running:  # answered (sim) or stopped
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
                **self._run_field(),
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
