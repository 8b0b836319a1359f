"""Branch simulations that share their work (issue 23, item 3).

A decision tree simulates every grounding x every agent (paper 000, V-A; eq. 21); with the
kinematic simulator each branch's robot actions are integrated with the task-priority controller
(:mod:`flexhrc.action.control`). Much of that work repeats: the same arm, from the same joints,
towards the same target, in the same world, gives the same motion — in another branch, or in the
next decision while the other arm works elsewhere. Here:

* :class:`MotionRequest` — one controller action a branch needs integrated;
* :func:`motion_key` — what the outcome depends on: the moving arms' joints and grips, the
  action's definition, the target, the obstacles, the human hand, the simulator's settings. The
  other arm is not in it: a one-arm controller never reads it (no objective couples the arms
  unless both move, and then both are in the key);
* :func:`rebase` — a cached outcome for another request with the same key: the final state is the
  request's own, the moving arms where the motion left them;
* :func:`simulate_many` — the distinct motions of one round, integrated side by side (lockstep,
  vectorised over the lanes where :mod:`flexhrc.action.lockstep` supports the hierarchy, one by one
  with :meth:`KinematicSimulator.simulate` otherwise).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from flexhrc.action.simulator import ActionOutcome, KinematicSimulator, RobotState, _action_spec
from flexhrc.errors import FlexhrcError

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class MotionRequest:
    """One controller action of a simulated branch: ``arm`` (``left``, ``right``, ``both``)
    does ``action`` towards ``target`` from ``start`` among ``obstacles`` (spheres ``x y z r``)
    with the human hand at ``human_hand`` (or none)."""

    arm: str
    action: str
    target: Vec3 | None
    start: RobotState
    obstacles: Sequence[tuple[float, float, float, float]] = ()
    human_hand: Vec3 | None = None


def _moving(sim: KinematicSimulator, arm: str) -> tuple[str, ...]:
    return tuple(sim.robot.arm_names) if arm == "both" else (arm,)


def motion_key(sim: KinematicSimulator, request: MotionRequest) -> tuple[Any, ...] | None:
    """What the outcome of ``request`` depends on, hashable (None: not representable)."""
    try:
        arms = _moving(sim, request.arm)
        joints = tuple(
            (a, np.asarray(request.start.q[a], dtype=float).tobytes(),
             bool(request.start.holding.get(a, False)))
            for a in arms
        )  # fmt: skip
        spec = _spec(sim, request)
        target = None if request.target is None else tuple(float(v) for v in request.target)
        hand = None if request.human_hand is None else tuple(float(v) for v in request.human_hand)
        if spec is not None and not any(s.kind == "human" for s in spec.hierarchy):
            hand = None  # no human-hand objective: the hand changes nothing
        obstacles = tuple(tuple(float(v) for v in o) for o in request.obstacles)
        settings = (
            sim.dt, sim.time_budget_s, sim.pos_tol, sim.rot_tol, sim.posture_tol, sim.stall_s,
            sim.settle, sim.span_m, sim.joint_speed_limit,
        )  # fmt: skip
        key = (
            id(sim), settings, request.arm, request.action, _text(spec), target, joints,
            obstacles, hand,
        )  # fmt: skip
        hash(key)
        return key
    except (KeyError, TypeError, ValueError):  # pragma: no cover - odd input: not shared
        return None


_TEXTS: dict[int, tuple[Any, str]] = {}


def _text(spec: Any) -> str:
    """``repr(spec)`` (every field of the action's definition), made once per definition."""
    hit = _TEXTS.get(id(spec))
    if hit is None or hit[0] is not spec:
        hit = _TEXTS[id(spec)] = (spec, repr(spec))  # the spec kept alive: its id stays its own
    return hit[1]


def _spec(sim: KinematicSimulator, request: MotionRequest) -> Any:
    try:
        return _action_spec(request.action, sim.actions)
    except FlexhrcError:
        return None


def hand_reach(sim: KinematicSimulator, request: MotionRequest) -> float | None:
    """How near the human hand must come to the TCP for the action's human-hand objective to act
    (its ``d_min`` + transition ``width``, with a margin); None when the action's hierarchy has no
    such objective (then the hand changes nothing but the reported distance)."""
    spec = _spec(sim, request)
    if spec is None:
        return None
    hit = _REACH.get(id(spec))
    if hit is None or hit[0] is not spec:
        reach = None
        for s in spec.hierarchy:
            if s.kind == "human":
                d_min = float(s.params.get("d_min", 0.05))
                width = float(s.params.get("width", 0.04))
                reach = (d_min + width) * (1.0 + 1e-9) + 1e-12
                break
        hit = _REACH[id(spec)] = (spec, reach)
    return hit[1]


_REACH: dict[int, tuple[Any, float | None]] = {}


def far_key(key: tuple[Any, ...]) -> tuple[Any, ...]:
    """A :func:`motion_key` without the hand (its last item): the key of the motion where the
    hand stays beyond :func:`hand_reach` of the TCP all along (its objective never acts)."""
    return (*key[:-1], None)


def least_distance(path: np.ndarray, obstacles: Sequence[Sequence[float]]) -> float:
    """The least distance of the TCP ``path`` to the spheres ``x y z r`` (inf: none), as the
    scalar integrator measures it step by step (``Sphere.distance``: -r at a centre)."""
    best = math.inf
    for o in obstacles:
        c, r = np.asarray(o[:3], dtype=float), float(o[3]) if len(o) > 3 else 0.0
        d = path - c
        n = math.sqrt(float(np.min(np.einsum("ij,ij->i", d, d))))
        best = min(best, -r if n < 1e-12 else n - r)
    return best


def rebase(outcome: ActionOutcome, request: MotionRequest) -> ActionOutcome:
    """``outcome`` (of a request with the same :func:`motion_key`) for ``request``: its final
    state is the request's start with the moving arms (joints, grips) where the motion left them."""
    final = request.start.copy()
    for a in outcome.trajectory.arms:
        final.q[a] = outcome.final_state.q[a].copy()
        final.holding[a] = outcome.final_state.holding.get(a, False)
    return replace(outcome, final_state=final)


def simulate_many(
    sim: KinematicSimulator,
    requests: Sequence[MotionRequest],
    paths: list[np.ndarray | None] | None = None,
) -> list[ActionOutcome]:
    """The outcomes of ``requests`` (no trajectories recorded), integrated side by side where
    the lockstep integrator supports them (:mod:`flexhrc.action.lockstep`), else one by one.
    ``paths``, when given, receives each one's TCP path (a point per control step; None for
    those integrated one by one)."""
    from flexhrc.action import lockstep
    from flexhrc.action.simulator import _single_threaded

    out: list[ActionOutcome | None] = [None] * len(requests)
    tcp: list[np.ndarray | None] = [None] * len(requests)
    groups: dict[Any, list[lockstep.Lane]] = {}
    # a simulator that integrates its own way (a subclass) is asked one request at a time
    own = type(sim).simulate is not KinematicSimulator.simulate or (
        type(sim)._simulate is not KinematicSimulator._simulate
    )
    for i, r in enumerate(requests):
        lane = lockstep.prepare(sim, i, r) if lockstep_enabled and not own else None
        if lane is None:
            out[i] = sim.simulate(
                r.arm, r.action, r.target, start=r.start, obstacles=r.obstacles,
                human_hand=r.human_hand, record=False,
            )  # fmt: skip
        else:
            groups.setdefault(lane.signature, []).append(lane)
    with _single_threaded():
        for lanes in groups.values():
            for lane, (outcome, path) in zip(lanes, lockstep.run(sim, lanes), strict=True):
                out[lane.index] = outcome
                tcp[lane.index] = path
    if paths is not None:
        paths[:] = tcp
    return [o for o in out if o is not None]


#: False: every motion is integrated by the scalar code (to compare; the tests use it)
lockstep_enabled = True
