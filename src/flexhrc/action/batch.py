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

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from flexhrc.action.simulator import ActionOutcome, KinematicSimulator, RobotState

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
        spec = sim.actions.get(request.action)
        target = None if request.target is None else tuple(float(v) for v in request.target)
        hand = None if request.human_hand is None else tuple(float(v) for v in request.human_hand)
        obstacles = tuple(tuple(float(v) for v in o) for o in request.obstacles)
        key = (id(sim), request.arm, request.action, repr(spec), target, joints, obstacles, hand)
        hash(key)
        return key
    except (KeyError, TypeError, ValueError):  # pragma: no cover - odd input: not shared
        return None


def rebase(outcome: ActionOutcome, request: MotionRequest) -> ActionOutcome:
    """``outcome`` (of a request with the same :func:`motion_key`) for ``request``: its final
    state is the request's start with the moving arms (joints, grips) where the motion left them."""
    final = request.start.copy()
    for a in outcome.trajectory.arms:
        final.q[a] = outcome.final_state.q[a].copy()
        final.holding[a] = outcome.final_state.holding.get(a, False)
    return replace(outcome, final_state=final)


def simulate_many(
    sim: KinematicSimulator, requests: Sequence[MotionRequest]
) -> list[ActionOutcome]:
    """The outcomes of ``requests`` (no trajectories recorded), integrated side by side where
    the lockstep integrator supports them (:mod:`flexhrc.action.lockstep`), else one by one."""
    from flexhrc.action import lockstep
    from flexhrc.action.simulator import _single_threaded

    out: list[ActionOutcome | None] = [None] * len(requests)
    groups: dict[Any, list[lockstep.Lane]] = {}
    for i, r in enumerate(requests):
        lane = lockstep.prepare(sim, i, r) if lockstep_enabled else None
        if lane is None:
            out[i] = sim.simulate(
                r.arm, r.action, r.target, start=r.start, obstacles=r.obstacles,
                human_hand=r.human_hand, record=False,
            )  # fmt: skip
        else:
            groups.setdefault(lane.signature, []).append(lane)
    with _single_threaded():
        for lanes in groups.values():
            for lane, outcome in zip(lanes, lockstep.run(sim, lanes), strict=True):
                out[lane.index] = outcome
    return [o for o in out if o is not None]


#: False: every motion is integrated by the scalar code (to compare; the tests use it)
lockstep_enabled = True
