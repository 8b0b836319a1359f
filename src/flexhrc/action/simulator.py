"""In-the-loop kinematic simulator: run an action's controller on the robot model, faster than
real time, and tell the Task Manager whether it succeeds, how long it takes and at what cost.

Paper 000, section III and V-A: the Simulator "replicates Controller operations, integrating its
output to simulate the robot behaviour", and returns success or failure, execution time, final
pose and an energy estimate; a simulation is successful "if the agent can reach its given goal in
a defined time interval". Here an action is:

* an :class:`ActionSpec` — data: which objectives, with which priorities and parameters (the
  hierarchy), where the goal lies relative to the target (above it, at it, a retreat, the rest
  posture, a screwing turn), and what the gripper does;
* a target :class:`Pose` (position in the world frame of :mod:`flexhrc.action.robots`, plus a yaw
  about the vertical for the top-down grasp) and the current :class:`RobotState`.

:meth:`KinematicSimulator.simulate` builds the objectives of :mod:`flexhrc.action.control`,
integrates ``q += qdot dt`` (explicit Euler, simulated time, fixed step ``dt``) and stops when

* every goal objective is within tolerance (success),
* the goal error has not improved for ``stall_s`` simulated seconds: success if it has settled
  within ``settle`` times the tolerances, else failure (stalled — the reason names the likely
  cause: out of reach, blocked by an obstacle, kept away by the human hand, a joint limit), or
* the time budget is spent (failure: timed out).

Actions (:data:`ACTIONS`): ``approach`` (TCP 10 cm above the target), ``grasp`` (down to the
target, close the gripper), ``transport`` (carry the held object so the TCP ends at the target),
``insert`` (as transport, at 30 % of the joint speed limits), ``screw`` (turn the TCP about the
vertical at the target), ``ungrasp`` (open, retreat 10 cm up),
``rest`` (joint posture of the arm's rest configuration), ``hand_over`` (bring the held object to
the middle pose where the human takes it), ``hold`` (keep what the hands hold where it is: the
behaviour of the node process ``hold``, below). ``arm="both"`` runs the two arms together: the
target is the object's centre, each hand grasps it ``span_m / 2`` to its own side, and while
transporting the :class:`~flexhrc.action.control.RelativePose` objective keeps the grasp rigid.

``hold`` is a behaviour rather than a motion (paper 000, section IV, eq. 5: "a robot behaviour
aimed at keeping a certain object in a given pose ... using two grippers, the effects of external
forces notwithstanding"). Its goal is the pose the hands have when it starts; its hierarchy
(:data:`HOLD_HIERARCHY`) puts the two-arm relative pose above every other equality objective, so a
push that moves the object (a :class:`SimEvent` with ``push``) moves both hands together and the
controller brings the object back without ever letting the grasp deform. It ends when its own
condition holds — the object is back at its pose and has stayed there, still, for ``still_s`` —
and never while a scheduled push is still to come; a push it cannot undo fails it (stalled).

Nothing here sleeps or reads a clock except ``wall_s`` (compute time, reported for benchmarks).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections import OrderedDict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import numpy as np

from flexhrc.action.control import (
    DEFAULT_HIERARCHY,
    ArmGoal,
    MinimumDistance,
    ObjectiveSpec,
    TaskPriorityController,
    build_objectives,
    load_lapack,
    parse_obstacle,
    top_down_rotation,
    yaw_of,
)
from flexhrc.action.robots import ARM_NAMES, DualArmRobot, load_robot
from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.knowledge.base import format_position

Array = np.ndarray

#: Where a hand-over happens: in the middle of the table, between robot and human (paper Fig. 12).
MIDDLE_POSE: tuple[float, float, float] = (0.55, 0.0, 0.30)
#: How far the tabletop leans on its stand before the robot places it (paper 000, Fig. 8 (a-d)):
#: ``reorient`` turns it back by as much, flat for the assembly pose.
TABLETOP_STAND_TILT_RAD = math.radians(30.0)


# ----------------------------------------------------------------------------------------------
# Data: poses, states, action definitions, outcomes
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Pose:
    """A top-down TCP target: position (m, world frame) and yaw about the vertical (rad)."""

    position: tuple[float, float, float]
    yaw: float = 0.0

    @classmethod
    def coerce(cls, value: Any, what: str = "target") -> Pose:
        """A :class:`Pose` from a Pose, 3 numbers ``x y z``, or a mapping with ``position``
        (and ``yaw``); raises :class:`FlexhrcError` naming ``what`` otherwise."""
        if isinstance(value, Pose):
            return value
        if isinstance(value, Mapping):
            pos = value.get("position", value.get("xyz"))
            yaw = value.get("yaw", 0.0)
        else:
            pos, yaw = value, 0.0
        if isinstance(pos, str | bytes):
            raise FlexhrcError(f"{what} must be 3 numbers (x y z in metres), got {pos!r}")
        try:
            nums = [float(v) for v in pos]
            yaw = float(yaw)
        except (TypeError, ValueError):
            raise FlexhrcError(
                f"{what} must be 3 numbers (x y z in metres), got {value!r}"
            ) from None
        if len(nums) != 3 or not all(math.isfinite(v) for v in [*nums, yaw]):
            raise FlexhrcError(f"{what} must be 3 finite numbers (x y z in metres), got {value!r}")
        return cls((nums[0], nums[1], nums[2]), yaw)

    @property
    def xyz(self) -> Array:
        return np.array(self.position, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        return {"position": list(self.position), "yaw": self.yaw}


@dataclass(frozen=True)
class SimEvent:
    """A change of the world during one simulated action, ``t_s`` seconds after it starts: an
    ``obstacle`` appears, the arm's ``velocity_scale`` changes and/or an external
    ``push`` moves what the hands hold by that offset (m, world frame): the hands give way with
    it (a disturbance)."""

    t_s: float
    obstacle: Any = None
    velocity_scale: float | None = None
    push: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if not math.isfinite(self.t_s) or self.t_s < 0:
            raise FlexhrcError(f"event time must be >= 0 s, got {self.t_s}")
        if self.velocity_scale is not None and not 0.0 < self.velocity_scale <= 1.0:
            raise FlexhrcError(f"velocity_scale must be in (0, 1], got {self.velocity_scale}")
        if self.obstacle is not None:
            parse_obstacle(self.obstacle, "event obstacle")
        if self.push is not None:
            object.__setattr__(self, "push", _push_offset(self.push, "event push"))


@dataclass
class RobotState:
    """Joint configuration of every arm and whether each arm holds an object."""

    q: dict[str, Array]
    holding: dict[str, bool] = field(default_factory=dict)

    @classmethod
    def rest(cls, robot: DualArmRobot) -> RobotState:
        return cls(robot.rest_configuration(), {a: False for a in robot.arm_names})

    def copy(self) -> RobotState:
        return RobotState({a: q.copy() for a, q in self.q.items()}, dict(self.holding))

    def to_dict(self) -> dict[str, Any]:
        return {
            "q": {a: [round(float(v), 6) for v in q] for a, q in self.q.items()},
            "holding": dict(self.holding),
        }


@dataclass(frozen=True)
class ActionSpec:
    """Definition of one control action, as data.

    ``goal`` says where the TCP goes: ``"above"`` (``approach_height`` above the target),
    ``"target"``, ``"retreat"`` (``approach_height`` above where the TCP is), ``"rest"`` (the arm's
    rest posture), ``"screw"`` (at the target, turned by ``turn_rad`` about the vertical),
    ``"tilt"`` (the held object turned by ``tilt_rad`` about the horizontal axis through both
    grippers — the world's y axis — without moving that axis: Fig. 8 (d), the tabletop turned
    flat; it needs no target).
    ``gripper`` is ``"close"`` (after the motion) or ``"open"`` (before it) or None; it takes
    ``gripper_time_s``. ``hierarchy`` lists the objectives and their priorities; ``speed_scale``
    scales the joint velocity limits (e.g. carrying a heavy part). ``yaw_period`` is the symmetry
    of the grasp about the vertical: a parallel gripper closing on a leg grasps it the same way at
    ``yaw`` and ``yaw + pi``, so the hand turns to whichever equivalent yaw keeps the last joint
    away from its limits with the least rotation (``0`` disables this: the yaw is taken as is).
    ``untargeted_offset``: called without a target, the action aims at the current TCP (the
    middle of both TCPs for ``both``) moved by this offset, at the current yaw — ``grasp`` goes
    straight down from where ``approach`` left the hand, ``screw`` turns the hand where it is.
    ``goal="hold"`` keeps the hands where they are (the ``hold`` behaviour of the module
    docstring): it ends once they have stayed at that pose, still, for ``still_s``.
    """

    name: str
    goal: str = "target"
    hierarchy: tuple[ObjectiveSpec, ...] = DEFAULT_HIERARCHY
    gripper: str | None = None
    gripper_time_s: float = 0.5
    approach_height: float = 0.10
    turn_rad: float = math.pi / 2
    tilt_rad: float = 0.0
    speed_scale: float = 1.0
    default_target: tuple[float, float, float] | None = None
    yaw_period: float = math.pi
    untargeted_offset: tuple[float, float, float] | None = None
    still_s: float = 0.5

    def __post_init__(self) -> None:
        if self.goal not in ("above", "target", "retreat", "rest", "screw", "hold", "tilt"):
            raise FlexhrcError(f"action {self.name!r}: unknown goal kind {self.goal!r}")
        if self.gripper not in (None, "open", "close"):
            raise FlexhrcError(f"action {self.name!r}: gripper must be 'open', 'close' or None")

    @property
    def needs_target(self) -> bool:
        return (
            self.goal in ("above", "target", "screw")
            and self.default_target is None
            and self.untargeted_offset is None
        )

    def with_priorities(self, **priorities: int) -> ActionSpec:
        """A copy whose objectives of the given kinds get new priorities (``obstacles=0``...)."""
        return replace(
            self,
            hierarchy=tuple(
                replace(s, priority=priorities.get(s.kind, s.priority)) for s in self.hierarchy
            ),
        )

    def with_params(self, kind: str, **params: float) -> ActionSpec:
        """A copy whose objectives of ``kind`` get extra parameters (``max_speed=0.1``...)."""
        return replace(
            self,
            hierarchy=tuple(
                replace(s, params={**s.params, **params}) if s.kind == kind else s
                for s in self.hierarchy
            ),
        )

    def without(self, *kinds: str) -> ActionSpec:
        """A copy without the objectives of the given kinds."""
        return replace(self, hierarchy=tuple(s for s in self.hierarchy if s.kind not in kinds))

    def to_dict(self) -> dict[str, Any]:
        """The fields, points as lists and the hierarchy last (what :meth:`from_dict` reads)."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        for key in ("default_target", "untargeted_offset"):
            d[key] = None if d[key] is None else list(d[key])
        d["hierarchy"] = [s.to_dict() for s in d.pop("hierarchy")]
        return d

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ActionSpec:
        """An action definition from data (e.g. a YAML file): the keys of :meth:`to_dict`;
        ``hierarchy`` is a list of ``{kind, priority, params}`` (default: the paper's)."""
        if "name" not in data:
            raise FlexhrcError("action definition needs a 'name'")
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(data) - known
        if unknown:
            raise FlexhrcError(
                f"action {data['name']!r}: unknown keys {', '.join(sorted(unknown))}"
            )
        kwargs = dict(data)
        if "hierarchy" in kwargs:
            try:
                kwargs["hierarchy"] = tuple(
                    ObjectiveSpec(str(o["kind"]), int(o["priority"]), dict(o.get("params", {})))
                    for o in kwargs["hierarchy"]
                )
            except UnknownNameError:
                raise
            except (KeyError, TypeError, ValueError) as exc:
                raise FlexhrcError(
                    f"action {data['name']!r}: each hierarchy entry needs 'kind' and an integer "
                    f"'priority' ({exc})"
                ) from None
        for key in ("default_target", "untargeted_offset"):
            if kwargs.get(key) is not None:
                kwargs[key] = Pose.coerce(kwargs[key], key).position
        return cls(**kwargs)


_NO_HUMAN = tuple(s for s in DEFAULT_HIERARCHY if s.kind != "human")

#: The hierarchy of the ``hold`` behaviour: the safety inequalities (inactive far from their
#: bounds) first, then the two-arm relative pose above every other objective — the grasp of a
#: rigid object never deforms, even while a push is undone — then the hands' poses (the object's
#: pose), then the posture. No human minimum distance: the person works at the held part (paper
#: 000, IV: "hold the housing while the robot fastens" is the mirror case).
HOLD_HIERARCHY: tuple[ObjectiveSpec, ...] = (
    ObjectiveSpec("joint_limits", 0),
    ObjectiveSpec("obstacles", 0, {"d_min": 0.05}),
    ObjectiveSpec("relative_pose", 1),
    ObjectiveSpec("ee_position", 2),
    ObjectiveSpec("ee_orientation", 2),
    ObjectiveSpec("posture", 3, {"gain": 0.3}),
)

#: The actions of the table assembly (paper 000, Fig. 8 and section VI), as data.
ACTIONS: dict[str, ActionSpec] = {
    "approach": ActionSpec("approach", goal="above"),
    "grasp": ActionSpec("grasp", goal="target", gripper="close", untargeted_offset=(0, 0, -0.1)),
    "transport": ActionSpec("transport", goal="target"),
    # a held part goes straight into its place, slowly (a dowel into its hole, a gear on a shaft)
    "insert": ActionSpec("insert", goal="target", speed_scale=0.3),
    "screw": ActionSpec("screw", goal="screw", untargeted_offset=(0.0, 0.0, 0.0)),
    "ungrasp": ActionSpec("ungrasp", goal="retreat", gripper="open"),
    "rest": ActionSpec("rest", goal="rest"),
    # Fig. 8 (d): the tabletop leans on its stand (TABLETOP_STAND_TILT_RAD); held in both hands
    # it is turned flat about the axis through the grippers (this way round the arms stay well
    # inside their joint ranges: the turn takes ~1 s, ~1.5 s with the paper's joint speeds)
    "reorient": ActionSpec("reorient", goal="tilt", tilt_rad=TABLETOP_STAND_TILT_RAD),
    # The human's hand is expected at the hand-over pose: no minimum distance to it there.
    "hand_over": ActionSpec("hand_over", goal="target", hierarchy=_NO_HUMAN,
                            default_target=MIDDLE_POSE),
    # a node process: keep what the hands hold at its pose, whatever pushes it (see above)
    "hold": ActionSpec("hold", goal="hold", hierarchy=HOLD_HIERARCHY),
}  # fmt: skip


@dataclass
class Trajectory:
    """Sampled motion: times (N,), stacked joint positions (N, 7 x arms) and TCP positions."""

    arms: tuple[str, ...]
    t: Array
    q: Array
    tcp: dict[str, Array]

    def arm_q(self, arm: str) -> Array:
        i = self.arms.index(arm)
        return self.q[:, 7 * i : 7 * i + 7]

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def to_dict(self) -> dict[str, Any]:
        return {
            "t": np.round(self.t, 4).tolist(),
            "q": {a: np.round(self.arm_q(a), 5).tolist() for a in self.arms},
            "tcp": {a: np.round(p, 5).tolist() for a, p in self.tcp.items()},
        }

    @staticmethod
    def concatenate(parts: Sequence[Trajectory]) -> Trajectory:
        """Chain trajectories in time (each part starts where the previous ended)."""
        arms = tuple(dict.fromkeys(a for p in parts for a in p.arms))
        ts: list[Array] = []
        qs: dict[str, list[Array]] = {a: [] for a in arms}
        tcps: dict[str, list[Array]] = {a: [] for a in arms}
        last = {a: np.full(7, np.nan) for a in arms}  # NaN until the arm first moves
        offset = 0.0
        for p in parts:
            if len(p) == 0:
                continue
            ts.append(p.t + offset)
            offset = float(ts[-1][-1])
            for a in arms:
                if a in p.arms:
                    qs[a].append(p.arm_q(a))
                    tcps[a].append(p.tcp[a])
                else:  # arm idle in this part: hold its last known value
                    qs[a].append(np.tile(last[a], (len(p), 1)))
                    tcps[a].append(np.full((len(p), 3), np.nan))
                last[a] = qs[a][-1][-1]
        if not ts:
            empty = {a: np.zeros((0, 3)) for a in arms}
            return Trajectory(arms, np.zeros(0), np.zeros((0, 7 * len(arms))), empty)
        q = np.hstack([np.concatenate(qs[a]) for a in arms])
        return Trajectory(arms, np.concatenate(ts), q, {a: np.concatenate(tcps[a]) for a in arms})


@dataclass
class ActionOutcome:
    """What the Simulator tells the Task Manager about one action."""

    action: str
    arm: str
    success: bool
    reason: str
    duration_s: float
    final_state: RobotState
    min_distance_m: float
    energy: float
    final_error_m: float
    final_error_rad: float
    trajectory: Trajectory
    wall_s: float
    steps: int
    peak_error_m: float = 0.0  # hold: the farthest a push took the hands from their pose

    @property
    def final_q(self) -> dict[str, Array]:
        return self.final_state.q

    def to_dict(self, trajectory: bool = False) -> dict[str, Any]:
        d: dict[str, Any] = {
            "action": self.action,
            "arm": self.arm,
            "success": self.success,
            "reason": self.reason,
            "duration_s": round(self.duration_s, 4),
            "wall_s": round(self.wall_s, 6),
            "final_error_m": _num(self.final_error_m, 6),
            "final_error_rad": _num(self.final_error_rad, 6),
            "min_distance_m": _num(self.min_distance_m, 5),
            "energy": round(self.energy, 5),
            "steps": self.steps,
            "final_q": self.final_state.to_dict()["q"],
            "holding": dict(self.final_state.holding),
        }
        if self.peak_error_m:
            d["peak_error_m"] = round(self.peak_error_m, 6)
        if trajectory:
            d["trajectory"] = self.trajectory.to_dict()
        return d


@dataclass
class SequenceOutcome:
    """Outcome of a chain of actions, each starting from the final state of the previous one."""

    success: bool
    reason: str
    outcomes: list[ActionOutcome]
    final_state: RobotState

    @property
    def duration_s(self) -> float:
        return sum(o.duration_s for o in self.outcomes)

    @property
    def energy(self) -> float:
        return sum(o.energy for o in self.outcomes)

    @property
    def min_distance_m(self) -> float:
        return min((o.min_distance_m for o in self.outcomes), default=math.inf)

    @property
    def wall_s(self) -> float:
        return sum(o.wall_s for o in self.outcomes)

    def trajectory(self) -> Trajectory:
        return Trajectory.concatenate([o.trajectory for o in self.outcomes])

    def to_dict(self) -> dict[str, Any]:
        return {
            "success": self.success,
            "reason": self.reason,
            "duration_s": round(self.duration_s, 4),
            "wall_s": round(self.wall_s, 6),
            "energy": round(self.energy, 5),
            "min_distance_m": _num(self.min_distance_m, 5),
            "actions": [o.to_dict() for o in self.outcomes],
        }


# ----------------------------------------------------------------------------------------------
# The simulator
# ----------------------------------------------------------------------------------------------


_POOL: Any = None


def _single_threaded() -> Any:
    """Keep BLAS/OpenMP single-threaded while integrating.

    The controller multiplies 7x7 and 14x14 matrices thousands of times per action; OpenBLAS
    worker threads only add wake-up latency at that size (measured: 45 ms -> 28 ms for a 5 s
    transport on a busy 2-core machine). ``threadpoolctl`` (in the ``sim`` extra) limits the pools
    for the duration of one simulation only (~30 us) and restores them afterwards; without it
    this is a no-op.
    """
    global _POOL
    if _POOL is None:
        try:
            from threadpoolctl import ThreadpoolController

            _POOL = ThreadpoolController()
        except ImportError:  # pragma: no cover - optional
            _POOL = False
    if _POOL is False:
        return contextlib.nullcontext()
    return _POOL.limit(limits=1)


def _cache_key(
    arm: Any, action: Any, target: Any, start: RobotState | None, obstacles: list[Any],
    human_hand: Any, budget: Any, velocity_scale: Any, record: bool, events: Sequence[Any],
) -> tuple[Any, ...] | None:  # fmt: skip
    """A hashable summary of a simulation request (None when something is not representable)."""
    try:
        state = None
        if start is not None:
            state = (
                tuple((a, np.asarray(q, dtype=float).round(10).tobytes()) for a, q in
                      sorted(start.q.items())),
                tuple(sorted(start.holding.items())),
            )  # fmt: skip
        tgt: Any = target
        if target is not None and not isinstance(target, Pose | Mapping):
            tgt = tuple(float(v) for v in target)  # exact, unlike the repr of an array
        elif isinstance(target, Mapping):
            tgt = repr(sorted(target.items()))
        act = action if isinstance(action, str) else repr(action)
        obs = tuple(parse_obstacle(o, f"obstacle {i + 1}") for i, o in enumerate(obstacles))
        hand = None if human_hand is None else tuple(float(v) for v in human_hand)
        evs = tuple(
            (
                e.t_s,
                None if e.obstacle is None else parse_obstacle(e.obstacle),
                e.velocity_scale,
                e.push,
            )
            for e in events
        )
        key = (arm, act, tgt, state, obs, hand, budget, velocity_scale, record, evs)
        hash(key)
        return key
    except (TypeError, ValueError, AttributeError):  # pragma: no cover - odd input: no caching
        return None


def _arms_of(arm: str, robot: DualArmRobot) -> list[str]:
    if arm == "both":
        return list(robot.arm_names)
    robot.arm(arm)  # raises UnknownNameError naming the argument
    return [arm]


def _action_spec(action: str | ActionSpec, actions: Mapping[str, ActionSpec]) -> ActionSpec:
    if isinstance(action, ActionSpec):
        return action
    key = str(action).replace("-", "_")
    if key == "handover":
        key = "hand_over"
    try:
        return actions[key]
    except KeyError:
        raise UnknownNameError(
            f"unknown action {action!r} (argument 'action'); known actions: {', '.join(actions)}"
        ) from None


class KinematicSimulator:
    """Simulate actions of the dual-arm robot with the task-priority controller.

    Parameters: the robot (default: the shipped dual Panda), the control step ``dt`` (s), the
    default time budget per action (s), goal tolerances, the stall window (an action whose error
    has stopped improving for ``stall_s`` counts as reached if it is within ``settle`` times the
    tolerances — 0.9 mm and 0.009 rad by default — and fails otherwise), and the action
    definitions (default :data:`ACTIONS`; pass your own mapping to change hierarchies).
    ``joint_speed_limit`` (rad/s) caps the model's joint velocity limits (a slower robot: the
    paper's Baxter moves its joints at most 0.6 rad/s,
    :data:`flexhrc.taskmanager.kinds.PAPER_TIMING`).

    Simulations are deterministic, so the last ``cache_size`` outcomes are kept: asking again
    for the same action from the same state in the same world (as a Task Manager re-scoring its
    branches does) returns a copy at once, with ``wall_s = 0``. ``cache_size=0`` disables it.
    """

    def __init__(
        self,
        robot: DualArmRobot | None = None,
        *,
        dt: float = 0.02,
        time_budget_s: float = 10.0,
        position_tolerance_m: float = 5e-4,
        orientation_tolerance_rad: float = 5e-3,
        posture_tolerance_rad: float = 1e-2,
        stall_s: float = 1.5,
        settle: float = 1.8,
        span_m: float = 0.2,
        actions: Mapping[str, ActionSpec] | None = None,
        cache_size: int = 256,
        joint_speed_limit: float | None = None,
    ):
        if dt <= 0 or time_budget_s <= 0:
            raise FlexhrcError("dt and time_budget_s must be positive")
        if joint_speed_limit is not None and not joint_speed_limit > 0:
            raise FlexhrcError(f"joint_speed_limit must be positive, got {joint_speed_limit}")
        self.joint_speed_limit = joint_speed_limit
        self.robot = robot if robot is not None else load_robot()
        load_lapack()
        self.dt = float(dt)
        self.time_budget_s = float(time_budget_s)
        self.pos_tol = position_tolerance_m
        self.rot_tol = orientation_tolerance_rad
        self.posture_tol = posture_tolerance_rad
        self.stall_s = stall_s
        self.settle = settle
        self.span_m = span_m
        self.actions: dict[str, ActionSpec] = dict(ACTIONS if actions is None else actions)
        self._reach_cache: dict[tuple[Any, ...], bool] = {}
        self._coarse: KinematicSimulator | None = None
        self.cache_size = int(cache_size)
        self._cache: OrderedDict[Any, ActionOutcome] = OrderedDict()

    # -- public API ---------------------------------------------------------------------------

    def rest_state(self) -> RobotState:
        return RobotState.rest(self.robot)

    def simulate(
        self,
        arm: str,
        action: str | ActionSpec,
        target: Pose | Sequence[float] | None = None,
        *,
        start: RobotState | None = None,
        obstacles: Iterable[Any] = (),
        human_hand: Sequence[float] | None = None,
        time_budget_s: float | None = None,
        velocity_scale: float = 1.0,
        record: bool = True,
        events: Sequence[SimEvent] = (),
    ) -> ActionOutcome:
        """Simulate one action of ``arm`` (``left``, ``right`` or ``both``) from ``start``
        (default: rest) towards ``target``; see the module docstring for the stop rules.

        ``obstacles`` are spheres/boxes (see :func:`~flexhrc.action.control.parse_obstacle`);
        ``human_hand`` is a point the TCPs keep their human minimum distance from.
        ``velocity_scale`` < 1 makes the arm execute only that fraction of the commanded joint
        velocities (the execution manager's ``slow_arm`` disturbance); ``events`` change the
        world during the action (:class:`SimEvent`).
        """
        request = (arm, action, target, start, list(obstacles), human_hand, time_budget_s,
                   velocity_scale, record, events)  # fmt: skip
        key = _cache_key(*request) if self.cache_size > 0 else None
        hit = self._cache.get(key) if key is not None else None
        if hit is not None:
            self._cache.move_to_end(key)
            return replace(hit, final_state=hit.final_state.copy(), wall_s=0.0)
        with _single_threaded():
            out = self._simulate(*request)
        if key is not None:
            self._cache[key] = replace(out, final_state=out.final_state.copy())
            if len(self._cache) > self.cache_size:
                self._cache.popitem(last=False)
        return out

    def _simulate(
        self,
        arm: str,
        action: str | ActionSpec,
        target: Pose | Sequence[float] | None,
        start: RobotState | None,
        obstacles: list[Any],
        human_hand: Sequence[float] | None,
        time_budget_s: float | None,
        velocity_scale: float,
        record: bool,
        events: Sequence[SimEvent],
    ) -> ActionOutcome:
        """:meth:`simulate` without the cache (the same arguments, in their order)."""
        t_wall = time.perf_counter()
        spec = _action_spec(action, self.actions)
        arms = _arms_of(arm, self.robot)
        obs = [parse_obstacle(o, f"obstacle {i + 1}") for i, o in enumerate(obstacles)]
        if human_hand is not None:
            human_hand = tuple(Pose.coerce(human_hand, "human_hand").position)
        budget = self.time_budget_s if time_budget_s is None else float(time_budget_s)
        if budget <= 0:
            raise FlexhrcError(f"time_budget_s must be positive, got {budget}")
        state = (start or self.rest_state()).copy()
        for a in arms:
            if a not in state.q:
                raise FlexhrcError(f"start state has no configuration for arm {a!r}")
        if target is None and spec.default_target is not None:
            target = spec.default_target
        if target is None and spec.needs_target:
            raise FlexhrcError(f"action {spec.name!r} needs a target (argument 'target')")
        pose = Pose.coerce(target) if target is not None else None

        q = np.concatenate([state.q[a] for a in arms]).astype(float)
        goals, relative = self._goals(spec, arms, q, pose)

        # Fast geometric rejection: the wrist centre of a top-down goal must be within the sum
        # of the link lengths from the shoulder; no need to integrate to learn that.
        for a in arms:
            g = goals[a].position
            if g is None:
                continue
            model = self.robot.arm(a)
            far = model.wrist_distance(g)
            if far > model.reach_m:
                return self._outcome(
                    spec, arm, arms, state, False,
                    f"goal {format_position(g)} is out of reach of arm {a!r} (wrist centre "
                    f"{far:.3f} m from the shoulder, reach {model.reach_m:.3f} m)",
                    0.0, q, math.inf, 0.0, (math.inf, math.inf), None, t_wall, 0,
                )  # fmt: skip

        duration = 0.0
        if spec.gripper == "open":
            duration += spec.gripper_time_s
            for a in arms:
                state.holding[a] = False

        def controller() -> TaskPriorityController:
            objectives = build_objectives(
                spec.hierarchy, self.robot, arms, goals,
                obstacles=obs, human_hand=human_hand, relative=relative,
            )  # fmt: skip
            return TaskPriorityController(
                self.robot,
                arms,
                objectives,
                velocity_scale=spec.speed_scale,
                joint_speed_limit=self.joint_speed_limit,
            )

        ctrl = controller()
        pending = sorted(events, key=lambda e: e.t_s)
        if not 0.0 < velocity_scale <= 1.0:
            raise FlexhrcError(f"velocity_scale must be in (0, 1], got {velocity_scale}")
        posture_goal = spec.goal == "rest"
        tol_rot = self.posture_tol if posture_goal else self.rot_tol
        holding = spec.goal == "hold"
        still_from: float | None = None  # hold: since when the hands are back at their pose
        peak = 0.0

        dt = self.dt
        max_steps = math.ceil(budget / dt - 1e-9)
        rows = max_steps + 1 if record else 1
        traj_t = np.empty(rows)
        traj_q = np.empty((rows, ctrl.n))
        traj_p = {a: np.empty((rows, 3)) for a in arms}
        energy = 0.0
        min_dist = math.inf
        best = math.inf
        best_t = 0.0
        t = 0.0
        step = 0
        success = False
        reason = ""
        err = (math.inf, math.inf)
        ctx = None
        while True:
            while pending and t >= pending[0].t_s - 1e-9:
                ev = pending.pop(0)
                if ev.velocity_scale is not None:
                    velocity_scale = ev.velocity_scale
                if ev.obstacle is not None:  # the world changed: rebuild the hierarchy
                    obs.append(parse_obstacle(ev.obstacle, "event obstacle"))
                    ctrl = controller()
                if ev.push is not None:
                    q = self._pushed(arms, q, ev.push)
                best, best_t = math.inf, t  # judge progress afresh from here
            ctx = ctrl.context(q)
            qdot = ctrl.solve(ctx)
            err = ctrl.goal_error()
            min_dist = min(min_dist, ctx.min_distance)
            if record:
                traj_t[step] = t
                traj_q[step] = q
                for a in arms:
                    traj_p[a][step] = ctx.arms[a].p
            if holding:
                peak = max(peak, err[0])
                if err[0] > self.pos_tol or err[1] > tol_rot:
                    still_from = None
                elif still_from is None:
                    still_from = t
                # settled: back at its pose for still_s, and no push is still to come
                if still_from is not None and not pending and t - still_from >= spec.still_s - 1e-9:
                    success = True
                    reason = "held: the object is at its pose"
                    if peak > self.pos_tol:
                        reason += f" (a push took it {peak * 1e3:.1f} mm away; restored)"
                    break
            elif err[0] <= self.pos_tol and err[1] <= tol_rot:
                success = True
                reason = "goal reached"
                break
            progress = err[0] + 0.1 * err[1]  # 1 rad of orientation weighs like 10 cm
            if progress < best * 0.995 - 1e-6:
                best, best_t = progress, t
            elif holding and (pending or still_from is not None):
                pass  # holding still, or waiting for a push to come: not a stall
            elif t - best_t >= self.stall_s:
                if err[0] <= self.settle * self.pos_tol and err[1] <= self.settle * tol_rot:
                    # Converging too slowly to matter (at the edge of the workspace, or
                    # braked by a joint limit) but already close: the goal is reached.
                    success = True
                    reason = f"goal reached (settled {err[0] * 1e3:.2f} mm / {err[1]:.4f} rad away)"
                    break
                cause = self._diagnose(arms, goals, ctrl, ctx) or "no progress"
                reason = (
                    f"stalled for {self.stall_s:g} s at {err[0]:.4f} m / {err[1]:.4f} rad from "
                    f"the goal ({cause})"
                )
                break
            if step >= max_steps:
                cause = self._diagnose(arms, goals, ctrl, ctx)
                reason = (
                    f"timed out: time budget of {budget:g} s spent, still "
                    f"{err[0]:.4f} m / {err[1]:.4f} rad from the goal"
                    + (f" ({cause})" if cause else "")
                )
                break
            # A slowed arm (velocity_scale < 1) executes a fraction of what is commanded.
            if velocity_scale != 1.0:
                qdot = qdot * velocity_scale
            qdot = ctrl.saturate(q, qdot, dt)
            q = q + qdot * dt
            energy += 0.5 * float(qdot @ qdot) * dt
            step += 1
            t = step * dt  # not a running sum: no drift over thousands of steps
        duration += t
        if success and spec.gripper == "close":
            duration += spec.gripper_time_s
            for a in arms:
                state.holding[a] = True
        traj = None
        if record:
            traj = Trajectory(
                tuple(arms),
                traj_t[: step + 1].copy(),
                traj_q[: step + 1].copy(),
                {a: traj_p[a][: step + 1].copy() for a in arms},
            )
        out = self._outcome(
            spec, arm, arms, state, success, reason, duration, q, min_dist, energy, err, traj,
            t_wall, step,
        )  # fmt: skip
        out.peak_error_m = peak
        return out

    def simulate_sequence(
        self,
        arm: str,
        steps: Sequence[tuple[str | ActionSpec, Pose | Sequence[float] | None]],
        *,
        start: RobotState | None = None,
        obstacles: Iterable[Any] = (),
        human_hand: Sequence[float] | None = None,
        time_budget_s: float | None = None,
        record: bool = True,
    ) -> SequenceOutcome:
        """Chain ``(action, target)`` steps, each from the final state of the previous one;
        stops at the first failure (its reason becomes the sequence's reason)."""
        obs = [parse_obstacle(o, f"obstacle {i + 1}") for i, o in enumerate(obstacles)]
        state = (start or self.rest_state()).copy()
        outcomes: list[ActionOutcome] = []
        for action, target in steps:
            out = self.simulate(
                arm, action, target, start=state, obstacles=obs, human_hand=human_hand,
                time_budget_s=time_budget_s, record=record,
            )  # fmt: skip
            outcomes.append(out)
            state = out.final_state
            if not out.success:
                return SequenceOutcome(False, f"{out.action}: {out.reason}", outcomes, state)
        return SequenceOutcome(True, "all actions succeeded", outcomes, state)

    def pick_and_place(
        self,
        arm: str,
        pick: Pose | Sequence[float],
        place: Pose | Sequence[float],
        **kwargs: Any,
    ) -> SequenceOutcome:
        """approach -> grasp -> transport -> ungrasp -> rest (the leg cycle of the table)."""
        return self.simulate_sequence(
            arm,
            [
                ("approach", pick),
                ("grasp", pick),
                ("transport", place),
                ("ungrasp", None),
                ("rest", None),
            ],
            **kwargs,
        )

    def reachable(self, arm: str, xyz: Sequence[float] | Pose, yaw: float | None = None) -> bool:
        """Can ``arm`` put its TCP at ``xyz`` with a top-down grasp (within joint limits)?

        A geometric bound first (wrist centre within the arm's reach), then the same controller
        run from the rest posture with a coarser step (50 ms) and no obstacles, so the answer
        agrees with what :meth:`simulate` will find. A few milliseconds; results are cached.
        """
        pose = Pose.coerce(xyz, "xyz")
        if yaw is not None:
            pose = Pose(pose.position, float(yaw))
        self.robot.arm(arm)
        key = (arm, *(round(v * 1000) for v in pose.position), round(pose.yaw * 1000))
        hit = self._reach_cache.get(key)
        if hit is None:
            if self._coarse is None:
                self._coarse = KinematicSimulator(
                    self.robot, dt=0.05, time_budget_s=8.0, stall_s=1.0, actions=self.actions
                )
            model = self.robot.arm(arm)
            hit = model.wrist_distance(pose.xyz) <= model.reach_m and (
                self._coarse.simulate(arm, "transport", pose, record=False).success
            )
            self._reach_cache[key] = hit
        return hit

    # -- internals ------------------------------------------------------------------------------

    def _goals(
        self, spec: ActionSpec, arms: list[str], q: Array, pose: Pose | None
    ) -> tuple[dict[str, ArmGoal], tuple[Array, Array] | None]:
        cur: dict[str, tuple[Array, Array]] = {}
        for i, a in enumerate(arms):
            cur[a] = self.robot.arm(a).pose(q[7 * i : 7 * i + 7])
        goals: dict[str, ArmGoal] = {}
        relative = None
        if spec.goal == "rest":
            return {a: ArmGoal(posture=self.robot.arm(a).q_rest) for a in arms}, None
        if spec.goal == "retreat":
            up = np.array([0.0, 0.0, spec.approach_height])
            return {a: ArmGoal(cur[a][0] + up, cur[a][1]) for a in arms}, None
        if spec.goal in ("tilt", "hold"):
            if spec.goal == "tilt":
                # a rigid turn about the y axis through the grippers' midpoint: every hand keeps
                # its place on the object, so the two-arm grasp (relative pose) is unchanged
                c, s_ = math.cos(spec.tilt_rad), math.sin(spec.tilt_rad)
                turn = np.array([[c, 0.0, s_], [0.0, 1.0, 0.0], [-s_, 0.0, c]])
                mid = np.mean([cur[a][0] for a in arms], axis=0)
                for a in arms:
                    goals[a] = ArmGoal(mid + turn @ (cur[a][0] - mid), turn @ cur[a][1])
            else:  # keep the hands, and what they hold, where they are
                goals = {a: ArmGoal(cur[a][0].copy(), cur[a][1].copy()) for a in arms}
            if len(arms) == 2:
                (p1, R1), (p2, R2) = cur[arms[0]], cur[arms[1]]
                relative = (R1.T @ (p2 - p1), R1.T @ R2)
            return goals, relative
        if pose is None:
            if spec.untargeted_offset is None:  # pragma: no cover - simulate checks needs_target
                raise FlexhrcError(f"action {spec.name!r} needs a target (argument 'target')")
            mid = np.mean([cur[a][0] for a in arms], axis=0)
            here = mid + np.asarray(spec.untargeted_offset, dtype=float)
            pose = Pose((float(here[0]), float(here[1]), float(here[2])), yaw_of(cur[arms[0]][1]))
        centre = pose.xyz
        if spec.goal == "above":
            centre = centre + np.array([0.0, 0.0, spec.approach_height])
        if len(arms) == 1:
            a = arms[0]
            if spec.goal == "screw":
                rot = top_down_rotation(yaw_of(cur[a][1]) + spec.turn_rad)
            else:
                rot = top_down_rotation(self._grasp_yaw(a, q[:7], pose.yaw, spec.yaw_period))
            return {a: ArmGoal(centre, rot)}, None
        # Two arms, one object centred at the target.
        holding = spec.goal == "target" and spec.gripper is None  # transport / hand over
        if holding:
            mid = 0.5 * (cur[arms[0]][0] + cur[arms[1]][0])
            for a in arms:
                goals[a] = ArmGoal(centre + (cur[a][0] - mid), cur[a][1])
            (p1, R1), (p2, R2) = cur[arms[0]], cur[arms[1]]
            relative = (R1.T @ (p2 - p1), R1.T @ R2)
        else:
            half = 0.5 * self.span_m
            for i, a in enumerate(arms):
                side = 1.0 if self.robot.arm(a).shoulder_xyz[1] > 0 else -1.0
                yaw = self._grasp_yaw(a, q[7 * i : 7 * i + 7], pose.yaw, spec.yaw_period)
                goals[a] = ArmGoal(
                    centre + np.array([0.0, side * half, 0.0]), top_down_rotation(yaw)
                )
        return goals, relative

    def _pushed(self, arms: list[str], q: Array, offset: tuple[float, float, float]) -> Array:
        """The joints after an external push moved every hand by ``offset`` (the hands give way
        compliantly: the least joint motion that moves each TCP so, by damped least squares),
        kept inside the joint ranges."""
        dx = np.asarray(offset, dtype=float)
        out = q.copy()
        for i, a in enumerate(arms):
            model = self.robot.arm(a)
            cols = slice(7 * i, 7 * i + 7)
            _, _, J = model.kinematics(out[cols])
            Jp = J[:3]
            dq = Jp.T @ np.linalg.solve(Jp @ Jp.T + 1e-4 * np.eye(3), dx)
            out[cols] = np.clip(out[cols] + dq, model.q_min, model.q_max)
        return out

    def _grasp_yaw(self, arm: str, q: Array, yaw: float, period: float) -> float:
        """Among the yaws equivalent to ``yaw`` (modulo ``period``), the one reached by turning
        the hand less than half a turn that leaves the last joint farthest inside its range
        (ties: the smallest turn). The last joint turns the hand about the vertical at about
        one radian per radian when the hand points down, which the Jacobian confirms."""
        if period <= 0:
            return yaw
        model = self.robot.arm(arm)
        _, R, J = model.kinematics(q)
        current = yaw_of(R)
        rate = float(J[5, 6])  # world yaw rate per unit speed of the last joint
        if abs(rate) < 0.5:  # hand far from vertical: no reliable prediction
            rate = 0.0
        best: tuple[float, float, float] | None = None
        for k in range(-4, 5):
            cand = yaw + k * period
            turn = math.remainder(cand - current, 2 * math.pi)
            if abs(turn) >= math.pi - 1e-9:
                continue
            margin = 0.0
            if rate:
                q7 = q[6] + turn / rate
                margin = min(q7 - model.q_min[6], model.q_max[6] - q7)
            key = (-min(margin, 0.5), abs(turn), cand)
            if best is None or key < best:
                best = key
        return yaw if best is None else current + math.remainder(best[2] - current, 2 * math.pi)

    def _diagnose(
        self,
        arms: list[str],
        goals: Mapping[str, ArmGoal],
        ctrl: TaskPriorityController,
        ctx: Any,
    ) -> str:
        """What holds the arm back: reach, an obstacle or the human hand, a joint limit."""
        causes = []
        for a in arms:
            g = goals[a].position
            model = self.robot.arm(a)
            if g is not None and model.wrist_distance(g) > model.reach_m - 0.03:
                causes.append(f"target at the edge of or beyond the reach of arm {a!r}")
        for level in ctrl.levels:
            for obj in level:
                if not isinstance(obj, MinimumDistance):
                    continue
                if any(
                    o.distance(ctx.arms[a].p)[0] < obj.d_min + obj.width
                    for o in obj.obstacles
                    for a in arms
                ):
                    causes.append(
                        "kept away by the human hand"
                        if obj.label == "human hand"
                        else "path blocked by an obstacle"
                    )
        q = np.concatenate([ctx.arms[a].q for a in arms])
        lim = np.minimum(q - ctrl.q_min, ctrl.q_max - q)
        if float(np.min(lim)) < 0.2:
            j = int(np.argmin(lim))
            causes.append(f"joint {arms[j // 7]}_joint{j % 7 + 1} at its limit")
        return "; ".join(dict.fromkeys(causes))

    def _outcome(
        self, spec: ActionSpec, arm: str, arms: list[str], state: RobotState, success: bool,
        reason: str, duration: float, q: Array, min_dist: float, energy: float,
        err: tuple[float, float], traj: Trajectory | None, t_wall: float, steps: int,
    ) -> ActionOutcome:  # fmt: skip
        final = state.copy()
        for i, a in enumerate(arms):
            final.q[a] = q[7 * i : 7 * i + 7].copy()
        if traj is None:
            traj = Trajectory(
                tuple(arms), np.zeros(1), q[None, :].copy(),
                {a: self.robot.arm(a).pose(final.q[a])[0][None, :] for a in arms},
            )  # fmt: skip
        return ActionOutcome(
            action=spec.name, arm=arm, success=success, reason=reason, duration_s=duration,
            final_state=final, min_distance_m=min_dist, energy=energy,
            final_error_m=err[0], final_error_rad=err[1], trajectory=traj,
            wall_s=time.perf_counter() - t_wall, steps=steps,
        )  # fmt: skip


def _push_offset(value: Any, what: str) -> tuple[float, float, float]:
    """A push offset: 3 finite numbers (m), at most 0.2 m (a push, not a throw)."""
    try:
        nums = [float(v) for v in value]
    except (TypeError, ValueError):
        raise FlexhrcError(f"{what} must be 3 numbers (x y z in metres), got {value!r}") from None
    if len(nums) != 3 or not all(math.isfinite(v) for v in nums):
        raise FlexhrcError(f"{what} must be 3 finite numbers (x y z in metres), got {value!r}")
    if math.dist(nums, (0.0, 0.0, 0.0)) > 0.2:
        raise FlexhrcError(f"{what} must be at most 0.2 m long, got {value!r}")
    return nums[0], nums[1], nums[2]


def _num(x: float, digits: int) -> float | None:
    """JSON has no infinity: an unknown/unbounded figure is ``null``."""
    return None if not math.isfinite(x) else round(float(x), digits)


__all__ = [
    "ACTIONS",
    "ARM_NAMES",
    "HOLD_HIERARCHY",
    "MIDDLE_POSE",
    "TABLETOP_STAND_TILT_RAD",
    "ActionOutcome",
    "ActionSpec",
    "KinematicSimulator",
    "Pose",
    "RobotState",
    "SequenceOutcome",
    "SimEvent",
    "Trajectory",
]
