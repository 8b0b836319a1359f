"""Robot Execution Manager: turn Task Manager commands into control actions on the "real" robot.

Paper 000, section III: the Robot Execution Manager "maps action commands issued by the
representation level to control actions fed to the Simulator or the Controller module" and
reports back whether each one succeeded. Here the real robot is simulated too, but in **its own
world**: the same controller (:mod:`flexhrc.action.control`) runs on the same model, while the
world can differ from what the Task Manager believes, through injected :class:`Disturbance`\\ s:

* ``object_moved`` — an object is not where the knowledge base says (someone moved it): a command
  acting on it (``approach``/``grasp``) fails once the hand gets there and finds nothing;
* ``slow_arm`` — an arm runs at a fraction of its nominal speed: its actions exceed their timeout;
* ``blocked_path`` — an obstacle the Task Manager does not know about: the controller keeps its
  minimum distance, goes around it if it can, fails (stalled) if it cannot;
* ``push`` — an external force pushes what the hands hold by ``offset`` during a ``hold``
  (the node process of paper eq. 5): the hands give way, the hold behaviour brings the object
  back to its pose; the command lasts until it is back and still (or fails if it cannot be).

Each command gets a timeout: the duration the nominal model predicts (the prior simulation)
times ``timeout_factor`` plus ``timeout_margin_s``, unless the command sets one. The report says
``done``, ``failed`` or ``timed_out``, with the reason, so the Task Manager can re-plan.
Everything runs in simulated time; the manager keeps its own clock (``time_s``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from flexhrc.action.control import Obstacle, parse_obstacle
from flexhrc.action.simulator import ActionOutcome, KinematicSimulator, Pose, RobotState, SimEvent
from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.events import ACK_STATUSES as STATUSES  # what an agent may answer
from flexhrc.knowledge.base import format_position

DISTURBANCE_KINDS: tuple[str, ...] = ("object_moved", "slow_arm", "blocked_path", "push")
#: The controller actions a ``push`` waits for: behaviours that keep a held object's pose.
HOLD_ACTIONS = ("hold",)
#: Actions that need the object to be where the command says.
_OBJECT_ACTIONS = ("approach", "grasp")
#: How far (m) an object may be from where the command expects it and still be grasped.
GRASP_TOLERANCE_M = 0.01


@dataclass(frozen=True)
class Command:
    """One command of the Task Manager: ``action`` by ``arm`` (``left``/``right``/``both``) at
    ``target``, optionally on the named ``object``; ``timeout_s`` overrides the default."""

    action: str
    arm: str
    target: Pose | Sequence[float] | None = None
    object: str | None = None
    timeout_s: float | None = None
    id: str | None = None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Command:
        """From a mapping with ``action``, ``arm`` (or ``agent``), ``target``, ``object``..."""
        if "action" not in data:
            raise FlexhrcError("command needs an 'action'")
        arm = data.get("arm", data.get("agent"))
        if arm is None:
            raise FlexhrcError("command needs an 'arm'")
        timeout = data.get("timeout_s")
        return cls(
            str(data["action"]),
            str(arm),
            data.get("target"),
            None if data.get("object") is None else str(data["object"]),
            None if timeout is None else float(timeout),
            None if data.get("id") is None else str(data["id"]),
        )

    def to_dict(self) -> dict[str, Any]:
        target: Any = self.target
        if isinstance(target, Pose):
            target = target.to_dict()
        elif target is not None:
            target = [float(v) for v in target]
        return {**asdict(self), "target": target}


@dataclass(frozen=True)
class Disturbance:
    """Something that makes the real world differ from the Task Manager's belief.

    ``object_moved``: ``object`` is displaced by ``offset`` (m). ``slow_arm``: ``arm`` runs at
    ``factor`` (0 < factor <= 1) of its speed. ``blocked_path``: ``obstacle`` (sphere or box,
    see :func:`~flexhrc.action.control.parse_obstacle`) appears. ``push``: what the hands hold is
    pushed by ``offset`` (m, at most 0.2), ``at_s`` seconds into the next ``hold`` command (it
    waits for one; default at its start). ``once=True`` removes a ``slow_arm``/``blocked_path``
    disturbance after the next command it affects.
    """

    kind: str
    object: str | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    arm: str | None = None
    factor: float = 1.0
    obstacle: Any = None
    once: bool = False
    at_s: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in DISTURBANCE_KINDS:
            raise UnknownNameError(
                f"unknown disturbance {self.kind!r}; known: {', '.join(DISTURBANCE_KINDS)}"
            )
        if self.kind == "object_moved" and not self.object:
            raise FlexhrcError("disturbance 'object_moved' needs the 'object' that moved")
        if self.kind == "slow_arm" and not (0.0 < self.factor <= 1.0):
            raise FlexhrcError(f"disturbance 'slow_arm' needs 0 < factor <= 1, got {self.factor}")
        if self.kind == "blocked_path":
            parse_obstacle(self.obstacle, "disturbance obstacle")
        if self.kind == "push":
            SimEvent(0.0, push=self.offset)  # the offset's checks, in one place
            if not any(self.offset):
                raise FlexhrcError("disturbance 'push' needs a non-zero 'offset' (m)")
        if self.at_s is not None and not (math.isfinite(self.at_s) and self.at_s >= 0):
            raise FlexhrcError(f"disturbance at_s must be >= 0 s, got {self.at_s}")

    def affects(self, arms: Sequence[str]) -> bool:
        """Does this speed or obstacle disturbance act on a command of ``arms``?"""
        return self.kind not in ("object_moved", "push") and (self.arm is None or self.arm in arms)

    def describe(self) -> str:
        if self.kind == "object_moved":
            return f"object {self.object!r} moved by {list(self.offset)} m"
        if self.kind == "slow_arm":
            return f"arm {self.arm or 'all'} slowed to {self.factor:.0%} of its speed"
        if self.kind == "push":
            return f"held object pushed by {[round(v, 4) for v in self.offset]} m"
        return f"unexpected obstacle {parse_obstacle(self.obstacle).to_dict()}"


@dataclass
class ExecutionReport:
    """What the Execution Manager acknowledges to the Task Manager for one command."""

    command: Command
    status: str
    reason: str
    duration_s: float
    started_s: float
    expected_s: float | None
    timeout_s: float
    outcome: ActionOutcome | None = None
    disturbances: list[str] = field(default_factory=list)
    observed: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "command": self.command.to_dict(),
            "status": self.status,
            "reason": self.reason,
            "duration_s": round(self.duration_s, 4),
            "started_s": round(self.started_s, 4),
            "expected_s": None if self.expected_s is None else round(self.expected_s, 4),
            "timeout_s": round(self.timeout_s, 4),
            "disturbances": list(self.disturbances),
            "observed": dict(self.observed),
        }


class ExecutionManager:
    """Executes commands on the simulated real robot, one at a time, in simulated time.

    ``simulator`` is the nominal model (also used for the prior estimate behind each default
    timeout); ``objects`` maps object names to their real poses; ``obstacles`` and
    ``human_hand`` describe the real workspace.
    """

    def __init__(
        self,
        simulator: KinematicSimulator | None = None,
        *,
        state: RobotState | None = None,
        objects: Mapping[str, Pose | Sequence[float]] | None = None,
        obstacles: Iterable[Any] = (),
        human_hand: Sequence[float] | None = None,
        timeout_factor: float = 1.5,
        timeout_margin_s: float = 1.0,
    ):
        self.sim = simulator if simulator is not None else KinematicSimulator()
        self.state = (state or self.sim.rest_state()).copy()
        self.objects: dict[str, Pose] = {
            name: Pose.coerce(p, f"object {name!r}") for name, p in (objects or {}).items()
        }
        self.obstacles: list[Obstacle] = [
            parse_obstacle(o, f"obstacle {i + 1}") for i, o in enumerate(obstacles)
        ]
        self.human_hand = human_hand
        self.timeout_factor = timeout_factor
        self.timeout_margin_s = timeout_margin_s
        self.disturbances: list[Disturbance] = []
        self.scheduled: list[Disturbance] = []  # happen during the next command
        self.held: dict[str, str] = {}  # arm -> object name
        self.time_s = 0.0
        self.log: list[ExecutionReport] = []

    # -- the world ------------------------------------------------------------------------------

    def inject(self, disturbance: Disturbance | Mapping[str, Any]) -> Disturbance:
        """Inject a disturbance into the real world: in effect from the next command, or, with
        ``at_s``, happening ``at_s`` seconds into the next command (during its execution)."""
        d = disturbance if isinstance(disturbance, Disturbance) else Disturbance(**disturbance)
        if d.kind == "object_moved" and d.object not in self.objects:
            raise UnknownNameError(
                f"unknown object {d.object!r}; known: {', '.join(self.objects) or 'none'}"
            )
        if d.kind == "slow_arm" and d.arm is not None:
            self.sim.robot.arm(d.arm)
        if d.at_s is not None or d.kind == "push":  # a push happens during a hold
            self.scheduled.append(d)
            return d
        return self._apply(d)

    def _apply(self, d: Disturbance) -> Disturbance:
        if d.kind == "object_moved":
            assert d.object is not None
            if d.object in self.held.values():
                raise FlexhrcError(f"object {d.object!r} is in a gripper; it cannot be moved")
            old = self.objects[d.object]
            new = np.asarray(old.position) + np.asarray(d.offset, dtype=float)
            self.objects[d.object] = Pose((float(new[0]), float(new[1]), float(new[2])), old.yaw)
        d = replace(d, at_s=None)
        self.disturbances.append(d)
        return d

    def _real_obstacles(self) -> list[Obstacle]:
        extra = [parse_obstacle(d.obstacle) for d in self.disturbances if d.kind == "blocked_path"]
        return self.obstacles + extra

    def _speed(self, arms: Sequence[str]) -> float:
        slowed = [d.factor for d in self.disturbances if d.kind == "slow_arm" and d.affects(arms)]
        return min([1.0, *slowed])

    # -- commands -------------------------------------------------------------------------------

    def prior_simulation(self, command: Command) -> ActionOutcome:
        """The prior simulation: the command on the nominal model, in the believed world."""
        return self.sim.simulate(
            command.arm, command.action, command.target, start=self.state,
            obstacles=self.obstacles, human_hand=self.human_hand, record=False,
        )  # fmt: skip

    def execute(self, command: Command | Mapping[str, Any]) -> ExecutionReport:
        """Run one command on the real robot; returns (and logs) its report."""
        cmd = command if isinstance(command, Command) else Command.from_dict(command)
        arms = list(self.sim.robot.arm_names) if cmd.arm == "both" else [cmd.arm]
        if cmd.arm != "both":
            self.sim.robot.arm(cmd.arm)
        started = self.time_s
        expected: float | None = None
        if cmd.timeout_s is not None:
            if cmd.timeout_s <= 0:
                raise FlexhrcError(f"timeout_s must be positive, got {cmd.timeout_s}")
            timeout = float(cmd.timeout_s)
        else:
            prior = self.prior_simulation(cmd)
            expected = prior.duration_s if prior.success else None
            timeout = (
                expected or self.sim.time_budget_s
            ) * self.timeout_factor + self.timeout_margin_s
            if cmd.action in HOLD_ACTIONS:  # how long a hold lasts is the world's doing
                timeout = max(timeout, self.sim.time_budget_s)
        active = [d.describe() for d in self.disturbances if d.affects(arms)]
        speed = self._speed(arms)
        holds = cmd.action in HOLD_ACTIONS
        # a push waits for the next hold; everything else scheduled happens in this command
        scheduled = [d for d in self.scheduled if d.kind != "push" or holds]
        events = [
            SimEvent(
                float(d.at_s or 0.0),
                obstacle=d.obstacle if d.kind == "blocked_path" else None,
                velocity_scale=min(speed, d.factor)
                if d.kind == "slow_arm" and d.affects(arms)
                else None,
                push=d.offset if d.kind == "push" else None,
            )
            for d in scheduled
            if d.kind != "object_moved"
        ]
        out = self.sim.simulate(
            cmd.arm, cmd.action, cmd.target, start=self.state,
            obstacles=self._real_obstacles(), human_hand=self.human_hand,
            time_budget_s=timeout, velocity_scale=speed, events=events,
        )  # fmt: skip
        self.state = out.final_state
        self.scheduled = [d for d in self.scheduled if not any(d is x for x in scheduled)]
        # What happened during the command is now part of the world.
        moved_during = []
        for d in scheduled:
            if d.kind == "object_moved" and d.object in self.held.values():
                continue  # it was grasped before it could be moved
            if (d.at_s or 0.0) <= out.duration_s:
                active.append(f"{d.describe()} at {d.at_s or 0.0:g} s")
            if d.kind == "object_moved" and (d.at_s or 0.0) <= out.duration_s:
                moved_during.append(d)
            elif d.kind != "push":  # a push is over once it happened
                self._apply(d)
        for d in moved_during:
            self._apply(d)
        observed: dict[str, Any] = {}
        status, reason = ("done", "goal reached") if out.success else ("failed", out.reason)
        if out.success and holds:  # how the hold went: whether a push took the object away
            reason = out.reason
        if not out.success and out.reason.startswith("timed out"):
            status = "timed_out"
            reason = f"no acknowledgement within {timeout:.2f} s ({out.reason})"
        if out.success and cmd.object is not None and cmd.action in _OBJECT_ACTIONS:
            status, reason, observed = self._check_object(cmd, out)
        if status == "done":
            self._update_objects(cmd, arms)
        elif cmd.action == "grasp":  # a failed grasp holds nothing
            for a in arms:
                self.state.holding[a] = False
        self.time_s += out.duration_s
        self.disturbances = [d for d in self.disturbances if not (d.once and d.affects(arms))]
        report = ExecutionReport(
            cmd, status, reason, out.duration_s, started, expected, timeout, out, active, observed
        )
        self.log.append(report)
        return report

    def joint_path(self, since: int = 0) -> tuple[np.ndarray, dict[str, np.ndarray]] | None:
        """The joint motion of the commands logged from ``self.log[since]`` on, as they ran:
        times ``t`` (simulated seconds, strictly increasing from 0 to the commands' total
        duration) and the joint positions ``(len(t), 7)`` of every arm they moved. The arm
        stands still while its gripper opens (before the motion) or closes (after it), so the
        path lasts what the reports say. None when nothing was logged since."""
        parts = [r.outcome for r in self.log[since:] if r.outcome is not None]
        if not parts:
            return None
        arms = list(dict.fromkeys(a for out in parts for a in out.trajectory.arms))
        samples: list[tuple[float, dict[str, np.ndarray]]] = []
        offset = 0.0
        for out in parts:
            traj = out.trajectory
            if len(traj) == 0:
                continue
            spec = self.sim.actions.get(out.action)
            moving = float(traj.t[-1] - traj.t[0])
            total = max(float(out.duration_s), moving)
            lead = total - moving if spec is not None and spec.gripper == "open" else 0.0
            rows = [{a: np.asarray(traj.arm_q(a)[i], dtype=float) for a in traj.arms}
                    for i in range(len(traj))]  # fmt: skip
            if lead > 0:
                samples.append((offset, rows[0]))
            samples.extend(
                (offset + lead + float(traj.t[i] - traj.t[0]), row) for i, row in enumerate(rows)
            )
            if lead + moving < total:
                samples.append((offset + total, rows[-1]))
            offset += total
        if not samples:
            return None
        times: list[float] = []
        kept: list[dict[str, np.ndarray]] = []
        for t, row in samples:  # one sample per instant: the later one (a command's start)
            if times and t <= times[-1] + 1e-9:
                kept[-1] = {**kept[-1], **row}
            else:
                times.append(t)
                kept.append(dict(row))
        q: dict[str, np.ndarray] = {}
        for a in arms:
            first = next(row[a] for row in kept if a in row)  # still until it first moves
            column, held = [], first
            for row in kept:
                held = row.get(a, held)
                column.append(held)
            q[a] = np.vstack(column)
        return np.asarray(times, dtype=float), q

    def _check_object(self, cmd: Command, out: ActionOutcome) -> tuple[str, str, dict[str, Any]]:
        name = cmd.object
        assert name is not None
        real = self.objects.get(name)
        if real is None:
            return "failed", f"object {name!r} is not in the workspace", {}
        expected = Pose.coerce(cmd.target) if cmd.target is not None else None
        if expected is None:
            return "done", "goal reached", {}
        off = float(np.linalg.norm(np.asarray(real.position) - np.asarray(expected.position)))
        if off > GRASP_TOLERANCE_M:
            if cmd.action == "grasp":
                for a in [cmd.arm] if cmd.arm != "both" else self.sim.robot.arm_names:
                    self.state.holding[a] = False
            return (
                "failed",
                f"object {name!r} is not where expected: it is {off:.3f} m away "
                f"(now at {format_position(real.position)})",
                {"object": name, "position": list(real.position)},
            )
        return "done", "goal reached", {}

    def _update_objects(self, cmd: Command, arms: Sequence[str]) -> None:
        """Keep the real world consistent: grasped objects follow the hand, released ones stay."""
        if cmd.action == "grasp" and cmd.object is not None:
            for a in arms:
                self.held[a] = cmd.object
        elif cmd.action in ("transport", "insert", "hand_over", "screw"):
            names = {self.held[a] for a in arms if a in self.held}
            for name in names:
                tcps = [self.sim.robot.arm(a).pose(self.state.q[a])[0] for a in arms]
                centre = np.mean(tcps, axis=0)
                xyz = (float(centre[0]), float(centre[1]), float(centre[2]))
                self.objects[name] = Pose(xyz, self.objects[name].yaw)
        elif cmd.action == "ungrasp":
            for a in arms:
                self.held.pop(a, None)


__all__ = [
    "DISTURBANCE_KINDS",
    "GRASP_TOLERANCE_M",
    "HOLD_ACTIONS",
    "STATUSES",
    "Command",
    "Disturbance",
    "ExecutionManager",
    "ExecutionReport",
]
