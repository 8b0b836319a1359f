"""Kinematic task-priority control: a hierarchy of equality and inequality objectives.

This is the Controller of the FlexHRC+ action level (paper 000, section III; refs. [51], [52]).
A control action is a **prioritised list of objectives**. Each objective ``k`` provides, at the
current configuration ``q``:

* a Jacobian ``J_k`` (rows x joints) linking joint velocities to the rate of its variable ``x_k``;
* a reference rate ``xdot_k`` (feedback towards its goal or towards the safe side of its bound);
* an **activation** ``a_k`` in [0, 1] per row. Equality objectives (reach a pose) are always
  active (``a = 1``). Inequality objectives (stay away from a joint limit, keep a minimum distance
  from an obstacle or a human hand) are active only near their bound: ``a = 1`` past the bound,
  falling smoothly (a cosine bell) to 0 over a transition width ``beta``, and 0 beyond, so they
  never over-constrain the arm when it is far from the bound and can sit at the highest priority.

Objectives with the same priority number share one level; smaller numbers are more important.
The joint velocity ``rho`` is computed level by level with the regularised task-priority inverse
kinematics of Simetti & Casalino ("A novel practical technique to integrate inequality control
objectives and task transitions in priority based control", J. Intell. Robot. Syst., 2016)::

    rho_0 = 0,  Q_0 = I
    X_k   = J_k Q_{k-1}
    W_k   = X_k  X_k^{#, A_k, Q_{k-1}}
    rho_k = rho_{k-1} + Q_{k-1} X_k^{#, A_k, I} W_k (xdot_k - J_k rho_{k-1})
    Q_k   = Q_{k-1} (I - X_k^{#, A_k, I} X_k)

with the regularised pseudo-inverse (``A`` diagonal activations, ``eta`` the control-direction
weight, ``lambda`` a damping that keeps the inverse bounded near singularities — the damped
least squares of Nakamura/Wampler in place of the paper's singular-value bell)::

    X^{#, A, Q} = (X^T A X + eta (I - Q)^T (I - Q) + lambda^2 I)^{-1} X^T A A

``X^T A X`` is the sum of the activation-weighted term ``X^T A^2 X`` and the task-oriented
regularisation ``X^T (I - A) A X`` of the iCAT formulation, so a row whose activation goes to zero
fades out continuously as the arm approaches or leaves the transition zone.

Inequality rows are one-sided. Their reference ``K (bound - x)`` is, inside the transition zone,
the fastest approach allowed, shrinking to zero at the bound (a velocity damper), and past the
bound a push back; a row is switched off for a step when a first solution of the equality
objectives alone already respects it (moves away, or approaches slowly enough), so it never holds
back a safe motion and a goal inside the transition zone is reached at full speed.

The lowest joint-space level (the posture used for redundancy resolution) is the null-space term
``rho += Q (xdot - rho)`` of Liegeois, which is what the recursion gives for an identity Jacobian
and a projector ``Q``.

Velocity limits are the top priority in the form of the paper's saturation: the final ``rho`` is
scaled uniformly (direction, hence the hierarchy, kept) so no joint exceeds its velocity limit, and
each joint velocity is clamped so that one integration step can never leave the joint range.

Everything here is plain numpy on small matrices (7 or 14 columns); objectives whose activations
are all zero are skipped, which is what makes a step cost tens of microseconds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from flexhrc.errors import FlexhrcError, UnknownNameError

if TYPE_CHECKING:  # pragma: no cover
    from flexhrc.action.robots import ArmModel, DualArmRobot

Array = np.ndarray

# ----------------------------------------------------------------------------------------------
# Activation functions
# ----------------------------------------------------------------------------------------------


def bell_below(x: float | Array, bound: float | Array, width: float | Array) -> Array:
    """Activation of an inequality ``x >= bound``: 1 at or below the bound, a cosine bell down to
    0 at ``bound + width``, 0 above (the smooth sigmoid of the iCAT activation functions)."""
    s = np.clip((np.asarray(x, dtype=float) - bound) / width, 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * s))


def bell_above(x: float | Array, bound: float | Array, width: float | Array) -> Array:
    """Activation of an inequality ``x <= bound``: mirror image of :func:`bell_below`."""
    s = np.clip((bound - np.asarray(x, dtype=float)) / width, 0.0, 1.0)
    return 0.5 * (1.0 + np.cos(np.pi * s))


# ----------------------------------------------------------------------------------------------
# Geometry: obstacles and small SO(3) helpers
# ----------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Sphere:
    """A spherical obstacle (centre in world frame, radius), e.g. a human hand with radius 0."""

    center: tuple[float, float, float]
    radius: float = 0.0
    name: str = "sphere"

    def distance(self, p: Array) -> tuple[float, Array]:
        """Signed distance from ``p`` to the surface and the unit normal pointing away."""
        d = p - np.asarray(self.center)
        n = math.sqrt(float(d @ d))
        if n < 1e-12:
            return -self.radius, np.array([0.0, 0.0, 1.0])
        return n - self.radius, d / n

    def to_dict(self) -> dict[str, Any]:
        return {"type": "sphere", "center": list(self.center), "radius": self.radius}


@dataclass(frozen=True)
class Box:
    """An axis-aligned box obstacle (centre and half extents, world frame)."""

    center: tuple[float, float, float]
    half_extents: tuple[float, float, float]
    name: str = "box"

    def distance(self, p: Array) -> tuple[float, Array]:
        c = np.asarray(self.center)
        h = np.asarray(self.half_extents)
        rel = p - c
        q = np.abs(rel) - h
        if np.all(q <= 0.0):  # inside: distance to the nearest face, negative
            i = int(np.argmax(q))
            n = np.zeros(3)
            n[i] = 1.0 if rel[i] >= 0 else -1.0
            return float(q[i]), n
        closest = c + np.clip(rel, -h, h)
        d = p - closest
        dist = math.sqrt(float(d @ d))
        return dist, d / dist

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "box",
            "center": list(self.center),
            "half_extents": list(self.half_extents),
        }


Obstacle = Sphere | Box


def _three(value: Any, what: str) -> tuple[float, float, float]:
    try:
        seq = [float(v) for v in value]
    except (TypeError, ValueError):
        raise FlexhrcError(f"{what} must be 3 numbers (x y z in metres), got {value!r}") from None
    if len(seq) != 3 or not all(math.isfinite(v) for v in seq):
        raise FlexhrcError(f"{what} must be 3 finite numbers (x y z in metres), got {value!r}")
    return seq[0], seq[1], seq[2]


def parse_obstacle(value: Any, what: str = "obstacle") -> Obstacle:
    """An obstacle from data: a :class:`Sphere`/:class:`Box`, a mapping
    (``{"type": "sphere", "center": [x, y, z], "radius": r}`` or ``{"type": "box", "center": ...,
    "half_extents": [hx, hy, hz]}``), 4 numbers ``x y z r`` (sphere) or 6 numbers
    ``x y z hx hy hz`` (box)."""
    if isinstance(value, Sphere | Box):
        return value
    if not isinstance(value, Mapping):  # numbers: checked as the mapping they stand for
        try:
            nums = [float(v) for v in value]
        except (TypeError, ValueError):
            raise FlexhrcError(
                f"{what} must be 'x y z r' (sphere) or 'x y z hx hy hz' (box), got {value!r}"
            ) from None
        if not all(math.isfinite(v) for v in nums):
            raise FlexhrcError(f"{what} must be finite numbers, got {value!r}")
        if len(nums) not in (4, 6):
            raise FlexhrcError(
                f"{what} must be 4 numbers 'x y z r' (sphere) or 6 numbers 'x y z hx hy hz' "
                f"(box), got {len(nums)}"
            )
        size = {"radius": nums[3]} if len(nums) == 4 else {"half_extents": nums[3:]}
        value = {"type": "sphere" if len(nums) == 4 else "box", "center": nums[:3], **size}
    kind = value.get("type", "sphere")
    if kind == "sphere":
        r = _nonneg(value.get("radius", 0.0), f"{what} radius")
        return Sphere(_three(value.get("center"), f"{what} center"), r)
    if kind == "box":
        he = _three(value.get("half_extents"), f"{what} half_extents")
        if min(he) <= 0:
            raise FlexhrcError(f"{what} half_extents must be positive, got {list(he)}")
        return Box(_three(value.get("center"), f"{what} center"), he)
    raise FlexhrcError(f"{what}: unknown obstacle type {kind!r} (expected 'sphere' or 'box')")


def _nonneg(v: Any, what: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise FlexhrcError(f"{what} must be a number, got {v!r}") from None
    if not math.isfinite(f) or f < 0:
        raise FlexhrcError(f"{what} must be a non-negative number, got {v!r}")
    return f


def skew(v: Array) -> Array:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotation_log(R: Array) -> Array:
    """Rotation vector (axis * angle) of a rotation matrix (the SO(3) logarithm).

    Plain float arithmetic on the nine entries (read at once with ``tolist``): this runs at
    every control step, where numpy's per-call overhead would dominate a 3x3 computation.
    """
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = R.tolist()
    cos = min(1.0, max(-1.0, (r00 + r11 + r22 - 1.0) * 0.5))
    angle = math.acos(cos)
    wx, wy, wz = r21 - r12, r02 - r20, r10 - r01
    if angle < 1e-9:
        return np.array([0.5 * wx, 0.5 * wy, 0.5 * wz])
    if math.pi - angle < 1e-6:  # near pi: axis from the symmetric part (R + I) / 2
        B = 0.5 * (np.asarray(R) + np.eye(3))
        i = int(np.argmax(np.diag(B)))
        axis = B[:, i] / math.sqrt(max(float(B[i, i]), 1e-12))
        if wx * axis[0] + wy * axis[1] + wz * axis[2] < 0:
            axis = -axis
        return angle * axis
    k = angle / (2.0 * math.sin(angle))
    return np.array([k * wx, k * wy, k * wz])


def top_down_rotation(yaw: float = 0.0) -> Array:
    """TCP orientation of a top-down grasp: approach axis along world -z, fingers turned by
    ``yaw`` about the vertical (the Panda "ready" pose has yaw 0)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


def yaw_of(R: Array) -> float:
    """Yaw (about world z) of a TCP rotation close to top-down."""
    return math.atan2(R[1, 0], R[0, 0])


# ----------------------------------------------------------------------------------------------
# Per-step kinematic context
# ----------------------------------------------------------------------------------------------


@dataclass
class ArmKinematics:
    """Kinematics of one arm at the current step, and where its joints sit in the stacked vector."""

    arm: ArmModel
    cols: slice
    q: Array
    p: Array = field(default_factory=lambda: np.zeros(3))
    R: Array = field(default_factory=lambda: np.eye(3))
    J: Array = field(default_factory=lambda: np.zeros((6, 7)))


@dataclass
class StepContext:
    """What objectives see at one control step."""

    n: int
    arms: dict[str, ArmKinematics]
    q: Array = field(default_factory=lambda: np.zeros(0))  # stacked joints of all arms
    # Obstacle normals active at this step, per arm: (normal, activation); used by the
    # end-effector position objective to slide around an obstacle instead of stalling on it.
    avoid: dict[str, list[tuple[Array, float]]] = field(default_factory=dict)
    min_distance: float = math.inf


@dataclass
class Task:
    """One objective's contribution at one step: ``J`` (m x n), ``ref`` (m,), activations (m,).

    ``J is None`` stands for the identity (a joint-space objective) and ``act is None`` for all
    ones (an equality objective): the solver then skips the corresponding products.
    Rows of an ``inequality`` task are oriented so that a positive rate moves away from the bound
    (their reference is the least rate allowed).
    """

    J: Array | None
    ref: Array
    act: Array | None
    inequality: bool = False


# ----------------------------------------------------------------------------------------------
# Objectives
# ----------------------------------------------------------------------------------------------


class Objective:
    """Base class: an objective has a name, a priority, and produces a :class:`Task` per step.

    ``evaluate`` returns None when every activation is zero (the level is then skipped).
    Goal objectives (equality objectives that define when an action is done) record their error
    ``(metres, radians)`` in ``last_error`` while evaluating, so the check costs nothing extra.
    """

    kind = "objective"
    is_goal = False

    def __init__(self, priority: int):
        self.priority = int(priority)

    def evaluate(self, ctx: StepContext) -> Task | None:  # pragma: no cover - abstract
        raise NotImplementedError

    #: goal objectives store ``(metres, radians)`` of their error at the last ``evaluate``
    last_error: tuple[float, float] = (0.0, 0.0)


class JointLimits(Objective):
    """Inequality ``q_min + margin <= q <= q_max - margin`` for every joint of the controlled arms.

    Active within ``width`` rad of the margin. The reference is ``K (bound - q)`` (row oriented
    away from the limit): in the transition zone the fastest approach allowed, zero at the bound,
    and a push back past it. Pushing back to the far edge of the zone instead
    (``x* = bound + width``) would make any goal that needs a joint inside the zone unreachable.
    """

    kind = "joint_limits"

    def __init__(
        self,
        priority: int,
        arms: Sequence[ArmModel],
        *,
        margin: float = 0.02,
        width: float = 0.1,
        gain: float = 2.0,
    ):
        super().__init__(priority)
        self.lo = np.concatenate([a.q_min for a in arms]) + margin
        self.hi = np.concatenate([a.q_max for a in arms]) - margin
        self.width, self.gain = width, gain
        self._lo_w, self._hi_w = self.lo + width, self.hi - width

    def evaluate(self, ctx: StepContext) -> Task | None:
        q = ctx.q
        if not ((q < self._lo_w).any() or (q > self._hi_w).any()):
            return None  # far from every limit: the whole objective is inactive
        a_lo = bell_below(q, self.lo, self.width)
        a_hi = bell_above(q, self.hi, self.width)
        act = np.maximum(a_lo, a_hi)
        rows = np.nonzero(act > 0.0)[0]
        if rows.size == 0:
            return None
        lower = a_lo[rows] >= a_hi[rows]
        # Row sign: +q_i for a lower bound, -q_i for an upper one (positive = away from it).
        ref = self.gain * np.where(lower, self.lo[rows] - q[rows], q[rows] - self.hi[rows])
        J = np.zeros((rows.size, ctx.n))
        J[np.arange(rows.size), rows] = np.where(lower, 1.0, -1.0)
        return Task(J, ref, act[rows], inequality=True)


class MinimumDistance(Objective):
    """Inequality ``distance(TCP, obstacle) >= d_min`` for every obstacle and every controlled arm.

    One row per (arm, obstacle) pair that is closer than ``d_min + width``: its Jacobian is the
    obstacle normal times the TCP linear Jacobian, its reference is ``K (d_min - d)`` (the fastest
    approach allowed in the transition zone, a push back inside ``d_min``; see
    :class:`JointLimits`).
    A human hand is a :class:`Sphere` of radius 0 with its own (larger) ``d_min``: build a second
    objective of this kind for it, usually at the same top priority.
    """

    kind = "min_distance"

    def __init__(
        self,
        priority: int,
        obstacles: Sequence[Obstacle],
        *,
        d_min: float = 0.05,
        width: float = 0.04,
        gain: float = 4.0,
        label: str = "obstacle",
    ):
        super().__init__(priority)
        self.obstacles = list(obstacles)
        self.d_min, self.width, self.gain, self.label = d_min, width, gain, label

    def evaluate(self, ctx: StepContext) -> Task | None:
        if not self.obstacles:
            return None
        rows_J, refs, acts = [], [], []
        for name, k in ctx.arms.items():
            for obs in self.obstacles:
                d, nrm = obs.distance(k.p)
                ctx.min_distance = min(ctx.min_distance, d)
                a = float(bell_below(d, self.d_min, self.width))
                if a <= 0.0:
                    continue
                row = np.zeros(ctx.n)
                row[k.cols] = nrm @ k.J[:3]
                rows_J.append(row)
                refs.append(self.gain * (self.d_min - d))
                acts.append(a)
                ctx.avoid.setdefault(name, []).append((nrm, a))
        if not acts:
            return None
        return Task(np.array(rows_J), np.array(refs), np.array(acts), inequality=True)


class EndEffectorPose(Objective):
    """Equality: TCP of ``arm`` to a goal position and/or orientation.

    Position reference ``K (goal - p)`` saturated at the maximum linear speed (0.4 m/s in the
    paper's experiments); orientation reference ``K log(R_goal R^T)`` (world-frame angular
    velocity) saturated at 0.8 rad/s. Built from the ``ee_position`` and ``ee_orientation`` specs
    (one objective with 6 rows when they share a priority, which saves a level per step).

    When a minimum-distance objective is active and the goal lies behind the obstacle, the
    component of the linear reference pointing into the obstacle is turned into the tangent plane
    (towards the goal, or upwards if the goal is straight behind): the higher-priority objective
    removes the normal component anyway, and without this the arm would stall on the saddle point
    in front of the obstacle instead of sliding around it.
    """

    kind = "ee_pose"
    is_goal = True

    def __init__(
        self,
        priority: int,
        arm: str,
        position: Array | None = None,
        rotation: Array | None = None,
        *,
        gain: float = 5.0,
        max_speed: float = 0.4,
        angular_gain: float | None = None,
        max_angular_speed: float = 0.8,
    ):
        super().__init__(priority)
        if position is None and rotation is None:
            raise ValueError("EndEffectorPose needs a position or a rotation goal")
        self.arm = arm
        self.position = None if position is None else np.asarray(position, dtype=float)
        self.rotation = None if rotation is None else np.asarray(rotation, dtype=float)
        self.gain, self.max_speed = gain, max_speed
        self.angular_gain = gain if angular_gain is None else angular_gain
        self.max_angular_speed = max_angular_speed
        self.last_error = (math.inf, math.inf)

    def evaluate(self, ctx: StepContext) -> Task | None:
        k = ctx.arms[self.arm]
        ref = np.empty(6)
        ep = eo = 0.0
        rows = 0
        if self.position is not None:
            e = self.position - k.p
            ep = math.sqrt(float(e @ e))
            v = self.gain * e
            if self.gain * ep > self.max_speed:
                v *= self.max_speed / (self.gain * ep)
            for nrm, a in ctx.avoid.get(self.arm, ()):
                v = _slide(v, nrm, a)
            ref[:3] = v
            rows = 3
        if self.rotation is not None:
            r = rotation_log(self.rotation @ k.R.T)
            eo = math.sqrt(float(r @ r))
            w = self.angular_gain * r
            if self.angular_gain * eo > self.max_angular_speed:
                w *= self.max_angular_speed / (self.angular_gain * eo)
            ref[rows : rows + 3] = w
            rows += 3
        self.last_error = (ep, eo)
        Jk = k.J if rows == 6 else (k.J[:3] if self.position is not None else k.J[3:])
        if ctx.n == 7:  # single arm: the arm's Jacobian is the task Jacobian
            J = Jk
        else:
            J = np.zeros((rows, ctx.n))
            J[:, k.cols] = Jk
        return Task(J, ref[:rows], None)


def _slide(v: Array, nrm: Array, a: float) -> Array:
    """Turn the part of ``v`` pointing into an obstacle (normal ``nrm``, activation ``a``) into
    the tangent plane, keeping its magnitude (see :class:`EndEffectorPose`)."""
    into = float(v @ nrm)
    if into >= 0.0:
        return v
    tangent = v - into * nrm
    tn = math.sqrt(float(tangent @ tangent))
    if tn < 0.2 * abs(into):  # goal (almost) straight behind the obstacle: go over it
        up = np.array([0.0, 0.0, 1.0]) - nrm[2] * nrm
        if up @ up < 1e-6:
            up = np.array([0.0, 1.0, 0.0]) - nrm[1] * nrm
        tangent = tangent + 0.2 * abs(into) * up / math.sqrt(float(up @ up))
        tn = math.sqrt(float(tangent @ tangent))
    return v - a * into * nrm + a * abs(into) * tangent / tn


class RelativePose(Objective):
    """Equality: both arms hold one rigid object, so the pose of the ``second`` TCP in the frame
    of the ``first`` stays what it was at the grasp (``r0``, ``R0``).

    Position error ``e = (p2 - p1) - R1 r0`` with rate ``v2 - v1 + [R1 r0]x w1``; orientation error
    ``log(R1 R0 R2^T)`` with rate ``w2 - w1``. Six rows over the 14 joints of both arms.
    """

    kind = "relative_pose"

    def __init__(
        self,
        priority: int,
        first: str,
        second: str,
        r0: Array,
        R0: Array,
        *,
        gain: float = 5.0,
    ):
        super().__init__(priority)
        self.first, self.second = first, second
        self.r0, self.R0, self.gain = np.asarray(r0, float), np.asarray(R0, float), gain

    def _errors(self, ctx: StepContext) -> tuple[Array, Array, Array]:
        a, b = ctx.arms[self.first], ctx.arms[self.second]
        r = a.R @ self.r0
        e_p = (b.p - a.p) - r
        e_o = rotation_log(a.R @ self.R0 @ b.R.T)
        return e_p, e_o, r

    def evaluate(self, ctx: StepContext) -> Task | None:
        a, b = ctx.arms[self.first], ctx.arms[self.second]
        e_p, e_o, r = self._errors(ctx)
        J = np.zeros((6, ctx.n))
        J[:3, a.cols] = -a.J[:3] + skew(r) @ a.J[3:]
        J[:3, b.cols] = b.J[:3]
        J[3:, a.cols] = -a.J[3:]
        J[3:, b.cols] = b.J[3:]
        self.last_error = (math.sqrt(float(e_p @ e_p)), math.sqrt(float(e_o @ e_o)))
        ref = np.concatenate([-self.gain * e_p, self.gain * e_o])
        return Task(J, ref, None)


class Posture(Objective):
    """Equality in joint space: ``q -> q_goal``. As a goal it drives an arm to rest; at the lowest
    priority it is the usual redundancy resolution (keep the elbow near a comfortable posture)."""

    kind = "posture"

    def __init__(
        self,
        priority: int,
        q_goal: Array,
        *,
        gain: float = 1.0,
        is_goal: bool = False,
        max_speed: float | None = None,
    ):
        super().__init__(priority)
        self.q_goal = np.asarray(q_goal, dtype=float)
        self.gain, self.is_goal, self.max_speed = gain, is_goal, max_speed
        self.last_error = (math.inf, math.inf)

    def evaluate(self, ctx: StepContext) -> Task | None:
        q = ctx.q
        ref = self.gain * (self.q_goal - q)
        if self.max_speed is not None:
            m = float(np.max(np.abs(ref)))
            if m > self.max_speed:
                ref *= self.max_speed / m
        if self.is_goal:
            self.last_error = (0.0, float(np.max(np.abs(self.q_goal - q))))
        return Task(None, ref, None)


# ----------------------------------------------------------------------------------------------
# Objectives as data
# ----------------------------------------------------------------------------------------------

OBJECTIVE_KINDS: tuple[str, ...] = (
    "joint_limits",
    "obstacles",
    "human",
    "relative_pose",
    "ee_position",
    "ee_orientation",
    "posture",
)


@dataclass(frozen=True)
class ObjectiveSpec:
    """One objective of an action definition: its kind, its priority (smaller = more important;
    equal priorities share a level) and optional parameters (gains, margins, minimum distances).

    Kinds: ``joint_limits`` (margin, width, gain), ``obstacles`` (d_min, width, gain), ``human``
    (d_min, width, gain), ``relative_pose`` (gain; two-arm actions only), ``ee_position`` (gain,
    max_speed), ``ee_orientation`` (gain, max_speed), ``posture`` (gain). Velocity limits are not
    a level: they are the saturation applied to the final joint velocity (always on).
    """

    kind: str
    priority: int
    params: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in OBJECTIVE_KINDS:
            raise UnknownNameError(
                f"unknown objective kind {self.kind!r}; known: {', '.join(OBJECTIVE_KINDS)}"
            )

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "priority": self.priority, "params": dict(self.params)}


# The default hierarchy of the paper: safety first (joint limits, obstacles, humans), then the
# kinematic constraint of a jointly held object, then the end-effector goal, then the posture.
DEFAULT_HIERARCHY: tuple[ObjectiveSpec, ...] = (
    ObjectiveSpec("joint_limits", 0),
    ObjectiveSpec("obstacles", 1, {"d_min": 0.05}),
    ObjectiveSpec("human", 1, {"d_min": 0.15, "width": 0.05}),
    ObjectiveSpec("relative_pose", 2),
    ObjectiveSpec("ee_position", 3),
    ObjectiveSpec("ee_orientation", 3),
    ObjectiveSpec("posture", 4, {"gain": 0.3}),
)


@dataclass(frozen=True)
class ArmGoal:
    """Goal of one arm for one control action: a TCP pose, or (``rest``) a joint posture."""

    position: Array | None = None
    rotation: Array | None = None
    posture: Array | None = None


def build_objectives(
    specs: Sequence[ObjectiveSpec],
    robot: DualArmRobot,
    arms: Sequence[str],
    goals: Mapping[str, ArmGoal],
    *,
    obstacles: Sequence[Obstacle] = (),
    human_hand: Sequence[float] | None = None,
    relative: tuple[Array, Array] | None = None,
) -> list[Objective]:
    """Instantiate a hierarchy from data for one control action.

    ``goals`` gives each arm's target; an arm whose goal is a ``posture`` gets a goal
    :class:`Posture` (at the priority of ``ee_position``) instead of pose objectives.
    ``relative`` is the ``(r0, R0)`` of a two-arm grasp (needed by ``relative_pose``).
    """
    models = [robot.arm(a) for a in arms]
    out: list[Objective] = []
    posture_goal = all(goals[a].posture is not None for a in arms)
    pose_specs: list[ObjectiveSpec] = []
    for spec in specs:
        p: dict[str, Any] = dict(spec.params)
        if spec.kind == "joint_limits":
            out.append(JointLimits(spec.priority, models, **p))
        elif spec.kind == "obstacles" and obstacles:
            out.append(MinimumDistance(spec.priority, obstacles, label="obstacle", **p))
        elif spec.kind == "human" and human_hand is not None:
            hand = Sphere(_three(human_hand, "human_hand"), 0.0, "human hand")
            out.append(MinimumDistance(spec.priority, [hand], label="human hand", **p))
        elif spec.kind == "relative_pose" and relative is not None and len(arms) == 2:
            out.append(RelativePose(spec.priority, arms[0], arms[1], *relative, **p))
        elif spec.kind == "ee_position" and posture_goal:
            q_goal = np.concatenate([np.asarray(goals[a].posture) for a in arms])
            out.append(Posture(spec.priority, q_goal, gain=2.0, is_goal=True, max_speed=0.6))
        elif spec.kind in ("ee_position", "ee_orientation") and not posture_goal:
            pose_specs.append(spec)
        elif spec.kind == "posture" and not posture_goal:
            q_goal = np.concatenate([robot.arm(a).q_rest for a in arms])
            out.append(Posture(spec.priority, q_goal, **p))
    # End-effector position and orientation: one 6-row objective per arm when they share a
    # priority, else one objective per part.
    by_priority: dict[int, dict[str, ObjectiveSpec]] = {}
    for spec in pose_specs:
        by_priority.setdefault(spec.priority, {})[spec.kind] = spec
    for prio, kinds in by_priority.items():
        params: dict[str, float] = {}
        if "ee_position" in kinds:
            params.update(kinds["ee_position"].params)
        if "ee_orientation" in kinds:
            o = dict(kinds["ee_orientation"].params)
            if "gain" in o:
                params["angular_gain"] = o.pop("gain")
            if "max_speed" in o:
                params["max_angular_speed"] = o.pop("max_speed")
            params.update(o)
        for a in arms:
            pos = goals[a].position if "ee_position" in kinds else None
            rot = goals[a].rotation if "ee_orientation" in kinds else None
            if pos is not None or rot is not None:
                out.append(EndEffectorPose(prio, a, pos, rot, **params))
    out.sort(key=lambda o: o.priority)
    return out


# ----------------------------------------------------------------------------------------------
# The solver
# ----------------------------------------------------------------------------------------------


_dposv: Any = None


def load_lapack() -> None:
    """Import LAPACK's ``dposv`` once (scipy's import takes a while: not inside a timed step)."""
    global _dposv
    if _dposv is None:
        try:
            from scipy.linalg.lapack import dposv
        except ImportError:  # pragma: no cover - scipy is part of the sim extra
            return
        _dposv = dposv


def _spd_solve(M: Array, B: Array) -> Array:
    """Solve ``M X = B`` for a symmetric positive definite ``M`` (Cholesky, LAPACK ``dposv``).

    ``numpy.linalg.solve`` spends most of its ~13 us on checks for a 7x7 system; the direct LAPACK
    call takes ~3 us, and the controller does two per level per step.
    """
    if _dposv is None:
        load_lapack()
        if _dposv is None:  # pragma: no cover - scipy is part of the sim extra
            return np.linalg.solve(M, B)
    _, x, info = _dposv(M, B)
    if info != 0:  # pragma: no cover - M is SPD by construction (lambda^2 > 0)
        return np.linalg.lstsq(M, B, rcond=None)[0]
    return x


def regularised_pinv(
    X: Array, act: Array | None, lam2: float, Q: Array | None = None, eta: float = 1.0
) -> Array:
    """``X^{#,A,Q} = (X^T A X + eta (I-Q)^T (I-Q) + lambda^2 I)^{-1} X^T A A`` (see module doc).

    ``act=None`` means ``A = I``; ``Q=None`` drops the control-direction term (``Q = I``).
    """
    n = X.shape[1]
    XtA = X.T if act is None else X.T * act
    M = XtA @ X
    rhs = XtA if act is None else XtA * act
    M.flat[:: n + 1] += lam2
    if Q is not None:
        IQ = np.eye(n) - Q
        M += eta * (IQ.T @ IQ)
    return _spd_solve(M, rhs)


class TaskPriorityController:
    """Joint velocities for the stacked joints of ``arms`` from a hierarchy of objectives."""

    def __init__(
        self,
        robot: DualArmRobot,
        arms: Sequence[str],
        objectives: Sequence[Objective],
        *,
        damping: float = 0.01,
        eta: float = 1.0,
        velocity_scale: float = 1.0,
        joint_speed_limit: float | None = None,
    ):
        load_lapack()
        self.robot = robot
        self.arms = [robot.arm(a) for a in arms]
        self.names = list(arms)
        self.n = 7 * len(self.arms)
        self.lam2 = damping * damping
        self.eta = eta
        levels: dict[int, list[Objective]] = {}
        for obj in objectives:
            levels.setdefault(obj.priority, []).append(obj)
        self.levels = [levels[p] for p in sorted(levels)]
        self.goals = [o for o in objectives if o.is_goal]
        v_max = np.concatenate([a.v_max for a in self.arms])
        if joint_speed_limit is not None:  # a slower robot than the model's datasheet
            v_max = np.minimum(v_max, joint_speed_limit)
        self.v_max = v_max * velocity_scale
        self._inv_v_max = 1.0 / self.v_max
        self.q_min = np.concatenate([a.q_min for a in self.arms])
        self.q_max = np.concatenate([a.q_max for a in self.arms])
        self._eye = np.eye(self.n)

    def context(self, q: Array) -> StepContext:
        """Kinematics of every controlled arm at the stacked configuration ``q``."""
        arms: dict[str, ArmKinematics] = {}
        for i, (name, model) in enumerate(zip(self.names, self.arms, strict=True)):
            cols = slice(7 * i, 7 * i + 7)
            qi = q[cols]
            p, R, J = model.kinematics(qi)
            arms[name] = ArmKinematics(model, cols, qi, p, R, J)
        return StepContext(self.n, arms, q)

    def solve(self, ctx: StepContext) -> Array:
        """Joint velocities ``rho`` (before saturation) for the current step.

        Inequality rows only ever limit motion *towards* their bound: when a first solution of
        the equality objectives alone already moves away from the bound faster than the row's
        reference, the row is switched off for this step (otherwise a zero reference inside the
        transition zone would also forbid moving away, and an arm starting near an obstacle
        could not leave it). This extra pass is only paid when some inequality is active.
        """
        levels: list[list[Task]] = []
        any_inequality = False
        for level in self.levels:
            tasks = [t for t in (o.evaluate(ctx) for o in level) if t is not None]
            if tasks:
                levels.append(tasks)
                any_inequality = any_inequality or any(t.inequality for t in tasks)
        if any_inequality:
            pre = self._recursion([[t for t in lv if not t.inequality] for lv in levels])
            for lv in levels:
                for t in lv:
                    if t.inequality and t.act is not None:
                        rate = pre if t.J is None else t.J @ pre
                        t.act = np.where(rate >= t.ref, 0.0, t.act)
        return self._recursion(levels)

    def _recursion(self, levels: list[list[Task]]) -> Array:
        """The task-priority recursion of the module docstring over non-empty levels."""
        rho: Array | None = None
        Q: Array | None = None  # None stands for the identity (nothing constrained yet)
        levels = [lv for lv in levels if lv]
        last = len(levels) - 1
        for i, tasks in enumerate(levels):
            if len(tasks) == 1:
                J, ref, act = tasks[0].J, tasks[0].ref, tasks[0].act
            else:
                J = np.vstack([self._eye if t.J is None else t.J for t in tasks])
                ref = np.concatenate([t.ref for t in tasks])
                act = (
                    None
                    if all(t.act is None for t in tasks)
                    else np.concatenate(
                        [np.ones(t.ref.shape[0]) if t.act is None else t.act for t in tasks]
                    )
                )
            if Q is None:  # first active level: Q_0 = I, rho_0 = 0, W = X X^# (no Q term)
                if J is None:
                    J = self._eye
                Xp = regularised_pinv(J, act, self.lam2)
                rho = Xp @ ((J @ Xp) @ ref)
                if i < last:
                    Q = self._eye - Xp @ J
                continue
            assert rho is not None
            if J is None and act is None and i == last:
                # Lowest-priority joint-space objective (the posture): with Q an orthogonal
                # projector the recursion reduces to rho += Q (ref - rho) / (1 + lambda^2)^2,
                # the classic null-space term of Liegeois; it saves two 7x7 (or 14x14)
                # factorisations per step and only touches the least important objective.
                rho = rho + (Q @ (ref - rho)) / (1.0 + self.lam2) ** 2
                continue
            if J is None:  # joint-space objective: X = Q, J rho = rho
                X, err = Q, ref - rho
            else:
                X, err = J @ Q, ref - J @ rho
            Xp_I = regularised_pinv(X, act, self.lam2)
            Xp_Q = regularised_pinv(X, act, self.lam2, Q, self.eta)
            rho = rho + Q @ (Xp_I @ ((X @ Xp_Q) @ err))
            if i < last:
                Q = Q - Q @ (Xp_I @ X)
        return np.zeros(self.n) if rho is None else rho

    def saturate(self, q: Array, qdot: Array, dt: float) -> Array:
        """Velocity limits (uniform scaling) and a joint-range guard for one Euler step."""
        ratio = float((np.abs(qdot) * self._inv_v_max).max())
        if ratio > 1.0:
            qdot = qdot * (1.0 / ratio)
        inv_dt = 1.0 / dt
        return np.minimum(np.maximum(qdot, (self.q_min - q) * inv_dt), (self.q_max - q) * inv_dt)

    def goal_error(self) -> tuple[float, float]:
        """Largest position (m) and angular/joint (rad) error over the goal objectives, as
        evaluated by the last :meth:`solve`."""
        ep, eo = 0.0, 0.0
        for g in self.goals:
            p, o = g.last_error
            ep, eo = max(ep, p), max(eo, o)
        return ep, eo
