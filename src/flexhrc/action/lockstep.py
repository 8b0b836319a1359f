"""Lockstep integration: many one-arm controller actions stepped together (issue 23, item 3).

:meth:`KinematicSimulator.simulate <flexhrc.action.simulator.KinematicSimulator.simulate>`
integrates one action at ~30-45 us a control step, most of it numpy's per-call overhead on 7x7
matrices. The branches of a decision integrate many such actions at once (one per branch per
round, :mod:`flexhrc.action.batch`); here they run as the lanes of one batch: every control step
evaluates the objectives and solves the task-priority recursion (paper 000, section III; the
regularised inverse of :mod:`flexhrc.action.control`) for all lanes with stacked ``(B, 7, 7)``
arrays, so the overhead is paid once per step instead of once per lane. Only the forward
kinematics (pinocchio) runs lane by lane. Where numba is installed, each lane runs instead in the
compiled loop of :mod:`flexhrc.action.kernel` (the same arithmetic, ~2x faster again); this
numpy loop is the fallback.

The result is the scalar integrator's, lane by lane, up to floating-point rounding:

* every objective is evaluated as in :mod:`flexhrc.action.control`, with all of its rows; a row
  the scalar controller leaves out (an inequality inactive in that lane) is kept with activation
  0, which contributes exactly nothing: its column of ``X^T A`` is zero, so the regularised
  inverse, ``rho`` and the projector ``Q`` come out as if it were absent; a level that is inactive
  in every lane is skipped, as the scalar controller skips it;
* the stop rules (goal reached, settled, stalled, timed out), the saturation and the Euler step
  are the scalar ones; a lane that stops leaves the batch; failures are diagnosed by the scalar
  code (:meth:`KinematicSimulator._diagnose`) so their reasons read the same.

Supported: one arm (``left`` or ``right``), a goal of kind above/target/retreat/rest/screw,
spherical obstacles, hierarchies made of joint limits, minimum distances, the end-effector pose
(position and orientation at one priority) and the posture, no events, no recorded trajectory —
everything a branch simulation asks for on the table. Anything else (two arms, ``hold``, boxes,
...) is :func:`prepare`'d as None and integrated by the scalar code.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexhrc.action.control import (
    EndEffectorPose,
    JointLimits,
    MinimumDistance,
    Posture,
    Sphere,
    TaskPriorityController,
    _slide,
    build_objectives,
    parse_obstacle,
    rotation_log,
)
from flexhrc.action.robots import _import_pinocchio
from flexhrc.action.simulator import (
    ActionOutcome,
    KinematicSimulator,
    Pose,
    RobotState,
    _action_spec,
)

Array = np.ndarray


@dataclass
class Lane:
    """One controller action ready to integrate (what :meth:`KinematicSimulator._simulate`
    sets up before its loop)."""

    index: int
    spec: Any
    arm: str
    state: RobotState
    q: Array
    goals: Any
    ctrl: TaskPriorityController
    duration: float
    tol_rot: float
    signature: tuple[Any, ...]
    t_wall: float


def prepare(sim: KinematicSimulator, index: int, request: Any) -> Lane | None:
    """``request`` (:class:`~flexhrc.action.batch.MotionRequest`) as a lane, or None when the
    lockstep integrator does not support it (or it ends before its first step: an unreachable
    goal) — the scalar integrator then runs it and says why."""
    t_wall = time.perf_counter()
    if request.arm not in sim.robot.arm_names:
        return None
    spec = _action_spec(request.action, sim.actions)
    if spec.goal not in ("above", "target", "retreat", "rest", "screw"):
        return None
    obs = [parse_obstacle(o, f"obstacle {i + 1}") for i, o in enumerate(request.obstacles)]
    if not all(isinstance(o, Sphere) for o in obs):
        return None
    hand = request.human_hand
    if hand is not None:
        hand = tuple(Pose.coerce(hand, "human_hand").position)
    arms = [request.arm]
    if request.arm not in request.start.q:
        return None
    target = request.target
    if target is None and spec.default_target is not None:
        target = spec.default_target
    if target is None and spec.needs_target:
        return None
    pose = Pose.coerce(target) if target is not None else None
    state = request.start.copy()
    q = np.concatenate([state.q[a] for a in arms]).astype(float)
    goals, relative = sim._goals(spec, arms, q, pose)
    for a in arms:  # the geometric rejection: the scalar code answers it at once
        g = goals[a].position
        model = sim.robot.arm(a)
        if g is not None and model.wrist_distance(g) > model.reach_m:
            return None
    duration = 0.0
    if spec.gripper == "open":
        duration += spec.gripper_time_s
        for a in arms:
            state.holding[a] = False
    objectives = build_objectives(
        spec.hierarchy, sim.robot, arms, goals, obstacles=obs, human_hand=hand, relative=relative
    )
    ctrl = TaskPriorityController(
        sim.robot, arms, objectives,
        velocity_scale=spec.speed_scale, joint_speed_limit=sim.joint_speed_limit,
    )  # fmt: skip
    signature = _signature(ctrl)
    if signature is None:
        return None
    tol_rot = sim.posture_tol if spec.goal == "rest" else sim.rot_tol
    return Lane(
        index, spec, request.arm, state, q, goals, ctrl, duration, tol_rot,
        (signature, tol_rot), t_wall,
    )  # fmt: skip


def _signature(ctrl: TaskPriorityController) -> tuple[Any, ...] | None:
    """What lanes must share to be stepped together: the levels, each objective's kind and
    scalar parameters (per-lane values — limits, goals, obstacle centres — may differ)."""
    levels = []
    for level in ctrl.levels:
        items: list[tuple[Any, ...]] = []
        for o in level:
            if isinstance(o, JointLimits):
                items.append(("jl", o.width, o.gain))
            elif isinstance(o, MinimumDistance):
                radii = tuple(float(getattr(s, "radius", 0.0)) for s in o.obstacles)
                items.append(("md", o.label, o.d_min, o.width, o.gain, len(o.obstacles), radii))
            elif isinstance(o, EndEffectorPose):
                if o.position is None or o.rotation is None:
                    return None
                items.append(("ee", o.gain, o.max_speed, o.angular_gain, o.max_angular_speed))
            elif isinstance(o, Posture):
                items.append(("po", o.gain, o.is_goal, o.max_speed))
            else:
                return None
        levels.append(tuple(items))
    return (ctrl.n, ctrl.lam2, ctrl.eta, tuple(levels))


def run(sim: KinematicSimulator, lanes: Sequence[Lane]) -> list[tuple[ActionOutcome, Array]]:
    """Integrate ``lanes`` (one signature) together; their outcomes, in order, each with the
    path of its TCP (one point per control step, the last step's included: where the scalar
    integrator measures distances)."""
    compiled = _compiled(sim, lanes)
    if compiled is not None:
        return compiled
    batch = _Batch(sim, list(lanes))
    outcomes = batch.run()
    return list(zip(outcomes, batch.paths, strict=True))


def _compiled(sim: KinematicSimulator, lanes: Sequence[Lane]) -> list[Any] | None:
    """The lanes integrated one by one by the compiled loop (:mod:`flexhrc.action.kernel`),
    or None where it does not apply (no numba, another chain or objective)."""
    from flexhrc.action import kernel

    if not kernel.available():
        return None
    work = []
    for lane in lanes:
        chain = kernel.chain_of(lane.ctrl.arms[0])
        objectives = kernel.objectives_of(lane.ctrl) if chain is not None else None
        if chain is None or objectives is None:
            return None
        work.append((lane, chain, objectives))
    dt = sim.dt
    max_steps = math.ceil(sim.time_budget_s / dt - 1e-9)
    out = []
    for lane, chain, objectives in work:
        c = lane.ctrl
        path = np.empty((max_steps + 1, 3))
        # every argument of the one compiled signature (an int where a float is expected, or
        # a strided array, would compile another specialisation: seconds, once)
        how, step, e0, e1, energy, min_dist, q = kernel.integrate(
            _f64(lane.q), *chain, _f64(c._inv_v_max), _f64(c.q_min), _f64(c.q_max), *objectives,
            float(c.lam2), float(c.eta), float(dt), int(max_steps), float(sim.pos_tol),
            float(lane.tol_rot), float(sim.stall_s), path,
        )  # fmt: skip
        outcome = _finish(
            sim, lane, ("reached", "stalled", "timed out")[how], step * dt, step, (e0, e1),
            q, min_dist, energy,
        )  # fmt: skip
        out.append((outcome, path[: step + 1].copy()))
    return out


def _f64(a: Array) -> Array:
    return np.ascontiguousarray(a, dtype=np.float64)


def _finish(
    sim: KinematicSimulator, lane: Lane, how: str, t: float, step: int,
    err: tuple[float, float], q: Array, min_dist: float, energy: float,
) -> ActionOutcome:  # fmt: skip
    """The outcome of a lane stopped by rule ``how`` (KinematicSimulator._simulate's end)."""
    success = False
    if how == "reached":
        success, reason = True, "goal reached"
    elif how == "stalled":
        if err[0] <= sim.settle * sim.pos_tol and err[1] <= sim.settle * lane.tol_rot:
            success = True
            reason = f"goal reached (settled {err[0] * 1e3:.2f} mm / {err[1]:.4f} rad away)"
        else:
            ctx = lane.ctrl.context(q)
            cause = sim._diagnose([lane.arm], lane.goals, lane.ctrl, ctx) or "no progress"
            reason = (
                f"stalled for {sim.stall_s:g} s at {err[0]:.4f} m / {err[1]:.4f} rad from "
                f"the goal ({cause})"
            )
    else:
        ctx = lane.ctrl.context(q)
        cause = sim._diagnose([lane.arm], lane.goals, lane.ctrl, ctx)
        reason = (
            f"timed out: time budget of {sim.time_budget_s:g} s spent, still "
            f"{err[0]:.4f} m / {err[1]:.4f} rad from the goal" + (f" ({cause})" if cause else "")
        )
    duration = lane.duration + t
    state = lane.state
    if success and lane.spec.gripper == "close":
        duration += lane.spec.gripper_time_s
        state.holding[lane.arm] = True
    return sim._outcome(
        lane.spec, lane.arm, [lane.arm], state, success, reason, duration, q, min_dist,
        energy, err, None, lane.t_wall, step,
    )  # fmt: skip


class _Batch:
    """The lanes of one signature, stepped together."""

    def __init__(self, sim: KinematicSimulator, lanes: list[Lane]):
        self.sim = sim
        self.lanes = lanes
        first = lanes[0].ctrl
        self.n = n = first.n
        self.lam2, self.eta = first.lam2, first.eta
        self.eye = np.eye(n)
        self.lam2_eye = self.lam2 * self.eye
        B = len(lanes)
        self.q = np.stack([lane.q for lane in lanes])
        self.models = [lane.ctrl.arms[0] for lane in lanes]
        c = [lane.ctrl for lane in lanes]
        self.inv_v_max = np.stack([x._inv_v_max for x in c])
        # the farthest a joint can move in one step, with a margin
        self.max_step = float(np.max(1.0 / self.inv_v_max)) * sim.dt * 1.01 + 1e-9
        self.q_min = np.stack([x.q_min for x in c])
        self.q_max = np.stack([x.q_max for x in c])
        # the objectives, level by level: (kind, scalar params, per-lane arrays)
        self.levels: list[list[dict[str, Any]]] = []
        for li, level in enumerate(first.levels):
            items = []
            for oi, o in enumerate(level):
                objs: list[Any] = [lane.ctrl.levels[li][oi] for lane in lanes]
                item: dict[str, Any] = {"obj": o}
                if isinstance(o, JointLimits):
                    item["kind"] = "jl"
                    item["lo"] = np.stack([x.lo for x in objs])
                    item["hi"] = np.stack([x.hi for x in objs])
                    item["lo_w"] = np.stack([x._lo_w for x in objs])
                    item["hi_w"] = np.stack([x._hi_w for x in objs])
                    item["skip"] = 0
                elif isinstance(o, MinimumDistance):
                    item["kind"] = "md"
                    item["c"] = np.array(
                        [[s.center for s in x.obstacles] for x in objs], dtype=float
                    ).reshape(B, len(o.obstacles), 3)
                    item["r"] = r = np.array(
                        [float(getattr(s, "radius", 0.0)) for s in o.obstacles], dtype=float
                    )
                    # the least squared distance of each lane's TCP to each obstacle's centre
                    # so far (min_distance_m at the end: sqrt is monotone), and the squared
                    # distance beyond which a row is inactive (with a margin: a row of
                    # activation 0 kept in changes nothing)
                    item["minsq"] = np.full((B, len(o.obstacles)), math.inf)
                    item["far2"] = ((o.d_min + o.width + r) ** 2) * (1.0 + 1e-9)
                elif isinstance(o, EndEffectorPose):
                    item["kind"] = "ee"
                    item["p"] = np.stack([x.position for x in objs])
                    item["R"] = np.stack([x.rotation for x in objs])
                else:
                    assert isinstance(o, Posture)
                    item["kind"] = "po"
                    item["g"] = np.stack([x.q_goal for x in objs])
                items.append(item)
            self.levels.append(items)
        self.energy = np.zeros(B)
        self.best = [math.inf] * B
        self.best_t = [0.0] * B
        self.tol_rot = lanes[0].tol_rot
        self.alive = list(range(B))  # lane positions still integrating
        self.alive_idx = np.arange(B)
        max_steps = math.ceil(sim.time_budget_s / sim.dt - 1e-9)
        self.path = np.empty((max_steps + 1, B, 3))  # each lane's TCP, step by step
        self.paths: list[Array] = [np.empty((0, 3))] * B
        self.out: list[ActionOutcome | None] = [None] * B

    # -- per-lane arrays leave together -------------------------------------------------
    def _keep(self, keep: Array) -> None:
        for name in ("q", "inv_v_max", "q_min", "q_max", "energy"):
            setattr(self, name, getattr(self, name)[keep])
        idx = np.nonzero(keep)[0]
        self.best = [self.best[i] for i in idx]
        self.best_t = [self.best_t[i] for i in idx]
        self.models = [self.models[i] for i in idx]
        self.alive = [self.alive[i] for i in idx]
        self.alive_idx = self.alive_idx[keep]
        for items in self.levels:
            for item in items:
                for key in ("lo", "hi", "lo_w", "hi_w", "c", "p", "R", "g", "minsq"):
                    if key in item:
                        item[key] = item[key][keep]

    # -- the loop (KinematicSimulator._simulate's, for every lane at once) --------------
    def run(self) -> list[ActionOutcome]:
        sim = self.sim
        dt = sim.dt
        max_steps = math.ceil(sim.time_budget_s / dt - 1e-9)
        step = 0
        t = 0.0
        pin = _import_pinocchio()
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        pos_tol, tol_rot, stall_s = sim.pos_tol, self.tol_rot, sim.stall_s
        inv_dt = 1.0 / dt
        H = np.empty((len(self.alive), 4, 4))  # each lane's TCP pose (homogeneous)
        Jm = np.empty((len(self.alive), 6, 7))
        frame = pin.computeFrameJacobian
        place = pin.updateFramePlacement
        while self.alive:
            q = self.q
            for i, model in enumerate(self.models):
                # ArmModel.kinematics in two calls (the TCP's Jacobian with the forward pass,
                # then its placement), written straight into the stacked arrays
                m, d, tcp = model.model, model.data, model.tcp_frame
                Jm[i] = frame(m, d, q[i], tcp, lwa)
                H[i] = place(m, d, tcp).homogeneous
            P = H[:, :3, 3]
            Rm = H[:, :3, :3]
            self.path[step, self.alive_idx] = P
            levels, (e0, e1) = self._evaluate(P, Rm, Jm)
            rho = self._solve(levels)[:, :, 0]
            # stop rules, in the scalar order (floats: a handful of lanes)
            done: list[int] = []
            best, best_t = self.best, self.best_t
            for i, (a, b) in enumerate(zip(e0.tolist(), e1.tolist(), strict=True)):
                if a <= pos_tol and b <= tol_rot:
                    done.append(i)
                    self._finish(i, "reached", t, step, (a, b))
                    continue
                progress = a + 0.1 * b
                if progress < best[i] * 0.995 - 1e-6:
                    best[i], best_t[i] = progress, t
                elif t - best_t[i] >= stall_s:
                    done.append(i)
                    self._finish(i, "stalled", t, step, (a, b))
                    continue
                if step >= max_steps:
                    done.append(i)
                    self._finish(i, "timed out", t, step, (a, b))
            if done:
                keep = np.ones(len(self.alive), dtype=bool)
                keep[done] = False
                self._keep(keep)
                rho = rho[keep]
                if not self.alive:
                    break
                H, Jm = H[keep], Jm[keep]
            # TaskPriorityController.saturate: a lane too fast is scaled down (x 1.0 is exact
            # for the others); the joint-range guard only when a step would leave a range
            qdot = rho
            ratio = _max(np.abs(qdot) * self.inv_v_max, axis=1)
            if _max(ratio, axis=None) > 1.0:
                qdot = qdot * (1.0 / np.maximum(ratio, 1.0))[:, None]
            q = self.q
            q_next = q + qdot * dt
            if _any(q_next < self.q_min) or _any(q_next > self.q_max):
                qdot = np.minimum(
                    np.maximum(qdot, (self.q_min - q) * inv_dt), (self.q_max - q) * inv_dt
                )
                q_next = q + qdot * dt
            self.q = q_next
            self.energy = self.energy + 0.5 * _dot(qdot, qdot) * dt
            step += 1
            t = step * dt
        return [o for o in self.out if o is not None]

    def _finish(self, i: int, how: str, t: float, step: int, err: tuple[float, float]) -> None:
        min_dist = math.inf
        for items in self.levels:
            for item in items:
                if item["kind"] == "md":
                    for sq, r in zip(item["minsq"][i].tolist(), item["r"].tolist(), strict=True):
                        # Sphere.distance: -r at the centre itself
                        d = -r if math.sqrt(sq) < 1e-12 else math.sqrt(sq) - r
                        min_dist = min(min_dist, d)
        lane = self.lanes[self.alive[i]]
        self.paths[self.alive[i]] = self.path[: step + 1, self.alive[i]].copy()
        self.out[self.alive[i]] = _finish(
            self.sim, lane, how, t, step, err, self.q[i].copy(), min_dist, float(self.energy[i])
        )

    # -- objectives -------------------------------------------------------------------
    def _evaluate(
        self, P: Array, Rm: Array, Jm: Array
    ) -> tuple[list[list[tuple[Any, ...]]], tuple[Array, Array]]:
        """Every objective's task for every lane: ``(J | None, ref (B, m, 1), act | None,
        inequality)`` per present objective, per level, and the goal errors; the obstacle normals
        active in a lane turn its end-effector reference (the slide of EndEffectorPose)."""
        q = self.q
        B = q.shape[0]
        avoid: list[list[Any]] = [[] for _ in range(B)]
        # the goal errors (TaskPriorityController.goal_error: the largest over the goal
        # objectives, from 0; errors are norms, so the first one is its own maximum with 0)
        e0: Array | None = None
        e1: Array | None = None
        out: list[list[tuple[Any, ...]]] = []
        for items in self.levels:
            tasks: list[tuple[Any, ...]] = []
            for item in items:
                kind = item["kind"]
                o = item["obj"]
                if kind == "jl":
                    if item["skip"] > 0:  # no joint can have reached its zone yet (below)
                        item["skip"] -= 1
                        continue
                    if not (_any(q < item["lo_w"]) or _any(q > item["hi_w"])):
                        # a joint moves at most v_max dt a step (saturation; the range guard
                        # only slows it): the zones stay out of reach for a few steps
                        margin = min(
                            _min(q - item["lo_w"], axis=None), _min(item["hi_w"] - q, axis=None)
                        )
                        item["skip"] = int(margin / self.max_step) - 1
                        continue
                    lo, hi = item["lo"], item["hi"]
                    s_lo = np.clip((q - lo) / o.width, 0.0, 1.0)
                    a_lo = 0.5 * (1.0 + np.cos(np.pi * s_lo))
                    s_hi = np.clip((hi - q) / o.width, 0.0, 1.0)
                    a_hi = 0.5 * (1.0 + np.cos(np.pi * s_hi))
                    act = np.maximum(a_lo, a_hi)
                    lower = a_lo >= a_hi
                    ref = o.gain * np.where(lower, lo - q, q - hi)
                    J = np.zeros((B, self.n, self.n))
                    J[:, np.arange(self.n), np.arange(self.n)] = np.where(lower, 1.0, -1.0)
                    tasks.append((J, ref[:, :, None], act, True))
                elif kind == "md":
                    D = P[:, None, :] - item["c"]  # (B, K, 3)
                    sq = _dot(D, D)
                    np.minimum(item["minsq"], sq, out=item["minsq"])
                    if not _any(sq < item["far2"]):
                        continue  # every lane beyond the transition zone: inactive
                    nn = np.sqrt(sq)
                    d = nn - item["r"]
                    if _min(nn, axis=None) < 1e-12:  # at a centre: Sphere.distance's convention
                        tiny = nn < 1e-12
                        d = np.where(tiny, -item["r"], d)
                        nrm = D / np.where(tiny, 1.0, nn)[:, :, None]
                        nrm[tiny] = (0.0, 0.0, 1.0)
                    else:
                        nrm = D / nn[:, :, None]
                    s = np.clip((d - o.d_min) / o.width, 0.0, 1.0)
                    act = 0.5 * (1.0 + np.cos(np.pi * s))
                    if not _any(act > 0.0):
                        continue
                    for b, k in zip(*np.nonzero(act > 0.0), strict=True):
                        avoid[b].append((nrm[b, k], float(act[b, k])))
                    J = nrm @ Jm[:, :3, :]  # (B, K, 7)
                    ref = o.gain * (o.d_min - d)
                    tasks.append((J, ref[:, :, None], act, True))
                elif kind == "ee":
                    e = item["p"] - P
                    ep = np.sqrt(_dot(e, e))
                    v = o.gain * e
                    gep = o.gain * ep
                    if _max(gep, axis=None) > o.max_speed:  # x 1.0 for the slower lanes
                        v *= np.divide(o.max_speed, gep, out=np.ones(B), where=gep > o.max_speed)[
                            :, None
                        ]
                    if any(avoid):
                        for b, entries in enumerate(avoid):
                            for nrm_b, a in entries:
                                v[b] = _slide(v[b], nrm_b, a)
                    r = _rotation_logs(item["R"] @ Rm.transpose(0, 2, 1), B)
                    eo = np.sqrt(_dot(r, r))
                    w = o.angular_gain * r
                    geo = o.angular_gain * eo
                    top = o.max_angular_speed
                    if _max(geo, axis=None) > top:
                        w *= np.divide(top, geo, out=np.ones(B), where=geo > top)[:, None]
                    e0 = ep if e0 is None else np.maximum(e0, ep)
                    e1 = eo if e1 is None else np.maximum(e1, eo)
                    tasks.append((Jm, np.concatenate([v, w], axis=1)[:, :, None], None, False))
                else:  # posture
                    diff = item["g"] - q
                    ref = o.gain * diff
                    if o.max_speed is not None:
                        m = _max(np.abs(ref), axis=1)
                        fast = m > o.max_speed
                        if _any(fast, axis=None):
                            ref[fast] *= (o.max_speed / m[fast])[:, None]
                    if o.is_goal:
                        err = _max(np.abs(diff), axis=1)
                        e1 = err if e1 is None else np.maximum(e1, err)
                    tasks.append((None, ref[:, :, None], None, False))
            out.append(tasks)
        zero = np.zeros(B)
        return out, (zero if e0 is None else e0, zero if e1 is None else e1)

    # -- the task-priority recursion (TaskPriorityController.solve, batched) -----------
    def _solve(self, levels: list[list[tuple[Any, ...]]]) -> Array:
        active = [lv for lv in levels if lv]
        if len(active) == 2 and len(active[0]) == 1 and len(active[1]) == 1:
            (J, ref, act, inequality), (J2, ref2, act2, _) = active[0][0], active[1][0]
            if J is not None and act is None and not inequality and J2 is None and act2 is None:
                # the usual step: the end-effector pose, then the posture (no inequality
                # near its bound) -- the recursion below for these two levels, inline
                Xt = J.transpose(0, 2, 1)
                M = Xt @ J
                M += self.lam2_eye
                Xp = _batched_solve(M, Xt)
                rho = Xp @ ((J @ Xp) @ ref)
                Q = self.eye - Xp @ J
                return rho + (Q @ (ref2 - rho)) / (1.0 + self.lam2) ** 2
        if any(t[3] for lv in levels for t in lv):
            pre = self._recursion([[t for t in lv if not t[3]] for lv in levels])
            for lv in levels:
                for j, t in enumerate(lv):
                    if t[3] and t[2] is not None:
                        J, ref, act = t[0], t[1], t[2]
                        rate = pre if J is None else J @ pre
                        lv[j] = (J, ref, np.where((rate >= ref)[:, :, 0], 0.0, act), True)
        return self._recursion(levels)

    def _recursion(self, levels: list[list[tuple[Any, ...]]]) -> Array:
        n, lam2 = self.n, self.lam2
        B = self.q.shape[0]
        rho: Array | None = None
        Q: Array | None = None
        levels = [lv for lv in levels if lv]
        last = len(levels) - 1
        eye = self.eye
        for i, tasks in enumerate(levels):
            if len(tasks) == 1:
                J, ref, act = tasks[0][0], tasks[0][1], tasks[0][2]
            else:
                J = np.concatenate(
                    [np.broadcast_to(eye, (B, n, n)) if t[0] is None else t[0] for t in tasks],
                    axis=1,
                )
                ref = np.concatenate([t[1] for t in tasks], axis=1)
                act = (
                    None
                    if all(t[2] is None for t in tasks)
                    else np.concatenate(
                        [np.ones(t[1].shape) if t[2] is None else t[2] for t in tasks], axis=1
                    )
                )
            if Q is None:
                if J is None:
                    J = np.broadcast_to(eye, (B, n, n))
                Xp = self._pinv(J, act)
                rho = Xp @ ((J @ Xp) @ ref)
                if i < last:
                    Q = eye - Xp @ J
                continue
            assert rho is not None
            if J is None and act is None and i == last:
                rho = rho + (Q @ (ref - rho)) / (1.0 + lam2) ** 2
                continue
            if J is None:
                X, err = Q, ref - rho
            else:
                X, err = J @ Q, ref - J @ rho
            Xp_I = self._pinv(X, act)
            Xp_Q = self._pinv(X, act, Q)
            rho = rho + Q @ (Xp_I @ ((X @ Xp_Q) @ err))
            if i < last:
                Q = Q - Q @ (Xp_I @ X)
        return np.zeros((B, n, 1)) if rho is None else rho

    def _pinv(self, X: Array, act: Array | None, Q: Array | None = None) -> Array:
        """``regularised_pinv`` for every lane."""
        Xt = X.transpose(0, 2, 1)
        if act is None:
            XtA = Xt
            M = XtA @ X
            rhs = XtA
        else:
            XtA = Xt * act[:, None, :]
            M = XtA @ X
            rhs = XtA * act[:, None, :]
        M = M + self.lam2_eye
        if Q is not None:
            IQ = self.eye - Q
            M = M + self.eta * (IQ.transpose(0, 2, 1) @ IQ)
        return _batched_solve(M, rhs)


#: full and row reductions without ndarray's method wrappers
_max = np.maximum.reduce
_min = np.minimum.reduce


def _any(a: Array, axis: Any = None) -> bool:
    return bool(np.logical_or.reduce(a, axis=axis))


def _einsum_dot(a: Array, b: Array) -> Array:
    return np.einsum("...i,...i->...", a, b)


#: row-wise dot products over the last axis (numpy >= 2: vecdot, as ``@`` sums them)
_dot: Any = getattr(np, "vecdot", _einsum_dot)


def _batched_solve(M: Array, rhs: Array) -> Array:
    """``M[b] X[b] = rhs[b]`` for every lane (LAPACK through numpy's gufunc, without the checks
    of ``numpy.linalg.solve``: M is symmetric positive definite by construction)."""
    if _GUFUNC_SOLVE is not None:
        return _GUFUNC_SOLVE(M, rhs, signature="dd->d")
    return np.linalg.solve(M, rhs)


try:  # numpy's own batched solver, behind numpy.linalg.solve
    from numpy.linalg import _umath_linalg

    _GUFUNC_SOLVE: Any = _umath_linalg.solve
except (ImportError, AttributeError):  # pragma: no cover - another numpy layout
    _GUFUNC_SOLVE = None


#: R[2,1], R[0,2], R[1,0] and R[1,2], R[2,0], R[0,1] of a flattened 3x3 matrix
_W_PLUS = np.array([7, 2, 3])
_W_MINUS = np.array([5, 6, 1])


def _rotation_logs(R: Array, B: int) -> Array:
    """:func:`~flexhrc.action.control.rotation_log` of every ``R[b]``."""
    cos = (np.einsum("bii->b", R) - 1.0) * 0.5
    cos = np.minimum(1.0, np.maximum(-1.0, cos))
    angle = np.arccos(cos)
    f = R.reshape(B, 9)
    w = f[:, _W_PLUS] - f[:, _W_MINUS]
    if math.pi - _max(angle, axis=None) < 1e-6:  # a lane near a half turn: the scalar code's branch
        return np.array([rotation_log(R[b]) for b in range(B)])
    if _min(angle, axis=None) >= 1e-9:  # the usual case
        return (angle / (2.0 * np.sin(angle)))[:, None] * w
    small = angle < 1e-9  # no rotation left: rotation_log's first-order branch
    k = np.where(small, 0.5, angle / (2.0 * np.where(small, 1.0, np.sin(angle))))
    return k[:, None] * w
