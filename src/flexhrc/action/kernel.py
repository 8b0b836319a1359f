"""The lockstep lane's control loop, compiled (issue 23, item 3): a fast kinematic decision.

:mod:`flexhrc.action.lockstep` steps the lanes of a decision together with stacked numpy arrays;
a step of 8 lanes still costs ~80 us, nearly all of it numpy's per-call overhead on 7x7
matrices (~50 calls a step). Here one lane's whole loop — forward kinematics of the arm's chain,
the objectives, the regularised task-priority recursion (paper 000, section III; Simetti &
Casalino 2016, the recursion in :mod:`flexhrc.action.control`'s docstring), the stop rules, the
saturation and the Euler step — is one function compiled by numba, so a step costs a few
microseconds and lanes need not wait for each other.

It is the scalar controller's arithmetic, statement by statement
(:meth:`TaskPriorityController.solve <flexhrc.action.control.TaskPriorityController.solve>`,
:func:`~flexhrc.action.control.regularised_pinv`, the objectives' ``evaluate`` and
:meth:`KinematicSimulator._simulate <flexhrc.action.simulator.KinematicSimulator._simulate>`'s
loop), so its outcomes are the scalar integrator's up to floating-point rounding: the forward
kinematics is pinocchio's composition ``oMi = oMparent * placement * R_axis(q)``, the 7x7 systems
are solved by a Cholesky factorisation (LAPACK's ``dposv`` in the scalar code), only the order
of a few sums differs. Inactive rows are left out exactly as the scalar code leaves them out.

numba is optional (the ``sim`` extra installs it). Without it, or for a chain that is not a
serial chain of revolute joints about their x, y or z axes, :func:`available` is False and the
numpy lockstep runs. The function is compiled once per machine (numba's on-disk cache beside
this file, or ``NUMBA_CACHE_DIR``): the first use in a fresh install takes a few seconds, a
later process loads it in a fraction of a second; :func:`warm_up` does it ahead of a timed
decision.
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

Array = np.ndarray

#: objective kinds, as the kernel reads them
JOINT_LIMITS, MIN_DISTANCE, EE_POSE, POSTURE = 0, 1, 2, 3

#: how a lane ended (the stop rules of KinematicSimulator._simulate)
REACHED, STALLED, TIMED_OUT = 0, 1, 2

try:  # pragma: no branch - numba is part of the sim extra
    if os.environ.get("FLEXHRC_JIT", "1") == "0":
        raise ImportError("switched off by FLEXHRC_JIT=0")
    from numba import njit

    _NUMBA = True
except ImportError:  # pragma: no cover - without the sim extra's numba
    _NUMBA = False

    def njit(*args: Any, **kwargs: Any) -> Any:  # type: ignore[no-redef]
        def wrap(f: Any) -> Any:
            return f

        return wrap


#: False: the numpy lockstep integrates every lane (to compare; the tests and the benchmark use it)
enabled = True


def available() -> bool:
    """Whether lanes can be integrated by the compiled loop here (numba imported)."""
    return _NUMBA and enabled


# ----------------------------------------------------------------------------------------------
# small linear algebra, written out (n <= 14: loops beat any call)
# ----------------------------------------------------------------------------------------------


@njit(cache=True, fastmath=False)
def _matmul(A: Array, B: Array) -> Array:  # pragma: no cover - compiled
    m, k = A.shape
    n = B.shape[1]
    C = np.zeros((m, n))
    for i in range(m):
        for p in range(k):
            a = A[i, p]
            if a != 0.0:
                for j in range(n):
                    C[i, j] += a * B[p, j]
    return C


@njit(cache=True)
def _matvec(A: Array, x: Array) -> Array:  # pragma: no cover - compiled
    m, k = A.shape
    y = np.zeros(m)
    for i in range(m):
        s = 0.0
        for p in range(k):
            s += A[i, p] * x[p]
        y[i] = s
    return y


@njit(cache=True)
def _spd_solve(M: Array, B: Array) -> Array:  # pragma: no cover - compiled
    """``M X = B`` for a symmetric positive definite ``M`` (Cholesky, as LAPACK's dposv)."""
    n = M.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = M[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = M[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    m = B.shape[1]
    X = np.empty((n, m))
    y = np.empty(n)
    for c in range(m):
        for i in range(n):
            s = B[i, c]
            for k in range(i):
                s -= L[i, k] * y[k]
            y[i] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = y[i]
            for k in range(i + 1, n):
                s -= L[k, i] * X[k, c]
            X[i, c] = s / L[i, i]
    return X


@njit(cache=True)
def _pinv(
    X: Array, act: Array, has_act: bool, lam2: float, Q: Array, has_q: bool, eta: float
) -> Array:  # pragma: no cover - compiled
    """:func:`~flexhrc.action.control.regularised_pinv`: ``(X^T A X + eta (I-Q)^T (I-Q) +
    lambda^2 I)^{-1} X^T A A``."""
    m, n = X.shape
    XtA = np.empty((n, m))
    for r in range(m):
        a = act[r] if has_act else 1.0
        for k in range(n):
            XtA[k, r] = X[r, k] * a
    M = _matmul(XtA, X)
    for k in range(n):
        M[k, k] += lam2
    if has_q:
        IQ = -Q.copy()
        for k in range(n):
            IQ[k, k] += 1.0
        M += eta * _matmul(IQ.T.copy(), IQ)
    if has_act:
        rhs = np.empty((n, m))
        for k in range(n):
            for r in range(m):
                rhs[k, r] = XtA[k, r] * act[r]
    else:
        rhs = XtA
    return _spd_solve(M, rhs)


# ----------------------------------------------------------------------------------------------
# kinematics of a serial chain of revolute joints (pinocchio's forward pass)
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _kinematics(
    q: Array, jR: Array, jp: Array, jax: Array, fR: Array, fp: Array, J: Array
) -> tuple[Array, Array]:  # pragma: no cover - compiled
    """The TCP's position and rotation, and its 6 x n Jacobian in the world-aligned frame at
    the TCP (pinocchio's LOCAL_WORLD_ALIGNED) written into ``J``."""
    n = q.shape[0]
    R = np.eye(3)
    p = np.zeros(3)
    zs = np.empty((n, 3))
    ps = np.empty((n, 3))
    Rq = np.eye(3)
    for j in range(n):
        c, s = math.cos(q[j]), math.sin(q[j])
        a = jax[j]
        Rq[:, :] = 0.0
        if a == 0:
            Rq[0, 0] = 1.0
            Rq[1, 1], Rq[1, 2], Rq[2, 1], Rq[2, 2] = c, -s, s, c
        elif a == 1:
            Rq[1, 1] = 1.0
            Rq[0, 0], Rq[0, 2], Rq[2, 0], Rq[2, 2] = c, s, -s, c
        else:
            Rq[2, 2] = 1.0
            Rq[0, 0], Rq[0, 1], Rq[1, 0], Rq[1, 1] = c, -s, s, c
        L = _matmul(jR[j], Rq)
        p = p + _matvec(R, jp[j])
        R = _matmul(R, L)
        for k in range(3):
            zs[j, k] = R[k, a]
            ps[j, k] = p[k]
    pf = p + _matvec(R, fp)
    Rf = _matmul(R, fR)
    for j in range(n):
        dx, dy, dz = pf[0] - ps[j, 0], pf[1] - ps[j, 1], pf[2] - ps[j, 2]
        zx, zy, zz = zs[j, 0], zs[j, 1], zs[j, 2]
        J[0, j] = zy * dz - zz * dy
        J[1, j] = zz * dx - zx * dz
        J[2, j] = zx * dy - zy * dx
        J[3, j], J[4, j], J[5, j] = zx, zy, zz
    return pf, Rf


@njit(cache=True)
def _rotation_log(R: Array) -> Array:  # pragma: no cover - compiled
    """:func:`~flexhrc.action.control.rotation_log`."""
    cos = min(1.0, max(-1.0, (R[0, 0] + R[1, 1] + R[2, 2] - 1.0) * 0.5))
    angle = math.acos(cos)
    wx, wy, wz = R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]
    out = np.empty(3)
    if angle < 1e-9:
        out[0], out[1], out[2] = 0.5 * wx, 0.5 * wy, 0.5 * wz
        return out
    if math.pi - angle < 1e-6:  # near pi: the axis from the symmetric part (R + I) / 2
        i = 0
        best = -math.inf
        for k in range(3):
            b = 0.5 * (R[k, k] + 1.0)
            if b > best:
                best, i = b, k
        scale = math.sqrt(max(0.5 * (R[i, i] + 1.0), 1e-12))
        for k in range(3):
            out[k] = 0.5 * (R[k, i] + (1.0 if k == i else 0.0)) / scale
        if wx * out[0] + wy * out[1] + wz * out[2] < 0:
            out = -out
        return angle * out
    f = angle / (2.0 * math.sin(angle))
    out[0], out[1], out[2] = f * wx, f * wy, f * wz
    return out


@njit(cache=True)
def _slide(v: Array, nrm: Array, a: float) -> Array:  # pragma: no cover - compiled
    """:func:`~flexhrc.action.control._slide`."""
    into = v[0] * nrm[0] + v[1] * nrm[1] + v[2] * nrm[2]
    if into >= 0.0:
        return v
    tangent = v - into * nrm
    tn = math.sqrt(tangent[0] ** 2 + tangent[1] ** 2 + tangent[2] ** 2)
    if tn < 0.2 * abs(into):
        up = np.array([0.0, 0.0, 1.0]) - nrm[2] * nrm
        if up[0] ** 2 + up[1] ** 2 + up[2] ** 2 < 1e-6:
            up = np.array([0.0, 1.0, 0.0]) - nrm[1] * nrm
        tangent = tangent + 0.2 * abs(into) * up / math.sqrt(up[0] ** 2 + up[1] ** 2 + up[2] ** 2)
        tn = math.sqrt(tangent[0] ** 2 + tangent[1] ** 2 + tangent[2] ** 2)
    return v - a * into * nrm + a * abs(into) * tangent / tn


@njit(cache=True)
def _bell(s: float) -> float:  # pragma: no cover - compiled
    s = min(1.0, max(0.0, s))
    return 0.5 * (1.0 + math.cos(math.pi * s))


# ----------------------------------------------------------------------------------------------
# the task-priority recursion over the tasks of one step
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _recursion(
    n: int,
    level_of: Array,
    n_levels: int,
    rows: Array,
    tJ: Array,
    tref: Array,
    tact: Array,
    j_none: Array,
    act_none: Array,
    ineq: Array,
    with_ineq: bool,
    lam2: float,
    eta: float,
) -> Array:  # pragma: no cover - compiled
    """``TaskPriorityController._recursion`` over the tasks present (``rows > 0``), leaving
    the inequality tasks out when ``with_ineq`` is False (the solver's first pass)."""
    n_obj = rows.shape[0]
    # the non-empty levels, in order
    present = np.zeros(n_levels, dtype=np.bool_)
    for o in range(n_obj):
        if rows[o] > 0 and (with_ineq or not ineq[o]):
            present[level_of[o]] = True
    last = -1
    count = 0
    for lv in range(n_levels):
        if present[lv]:
            last = count
            count += 1
    rho = np.zeros(n)
    Q = np.eye(n)
    first = True
    i = -1
    eye = np.eye(n)
    for lv in range(n_levels):
        if not present[lv]:
            continue
        i += 1
        k = 0
        m = 0
        only = -1
        for o in range(n_obj):
            if level_of[o] == lv and rows[o] > 0 and (with_ineq or not ineq[o]):
                k += 1
                only = o
                m += n if j_none[o] else rows[o]
        J = np.empty((m, n))
        ref = np.empty(m)
        act = np.ones(m)
        single_j_none = False
        has_act = False
        if k == 1:
            single_j_none = j_none[only]
            has_act = not act_none[only]
        r0 = 0
        for o in range(n_obj):
            if level_of[o] == lv and rows[o] > 0 and (with_ineq or not ineq[o]):
                if j_none[o]:
                    J[r0 : r0 + n, :] = eye
                    ref[r0 : r0 + n] = tref[o, :n]
                    r0 += n
                else:
                    mo = rows[o]
                    J[r0 : r0 + mo, :] = tJ[o, :mo, :]
                    ref[r0 : r0 + mo] = tref[o, :mo]
                    if not act_none[o]:
                        act[r0 : r0 + mo] = tact[o, :mo]
                        has_act = True
                    r0 += mo
        if first:
            Xp = _pinv(J, act, has_act, lam2, Q, False, eta)
            rho = _matvec(Xp, _matvec(_matmul(J, Xp), ref))
            if i < last:
                Q = eye - _matmul(Xp, J)
            first = False
            continue
        if single_j_none and not has_act and i == last:
            # the posture at the lowest level: Liegeois' null-space term (see control.py)
            rho = rho + _matvec(Q, ref - rho) / (1.0 + lam2) ** 2
            continue
        if single_j_none:
            X = Q.copy()
            err = ref - rho
        else:
            X = _matmul(J, Q)
            err = ref - _matvec(J, rho)
        Xp_I = _pinv(X, act, has_act, lam2, Q, False, eta)
        Xp_Q = _pinv(X, act, has_act, lam2, Q, True, eta)
        rho = rho + _matvec(Q, _matvec(Xp_I, _matvec(_matmul(X, Xp_Q), err)))
        if i < last:
            Q = Q - _matmul(Q, _matmul(Xp_I, X))
    return rho


# ----------------------------------------------------------------------------------------------
# one lane, start to stop
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _integrate(
    q0: Array,
    jR: Array,
    jp: Array,
    jax: Array,
    fR: Array,
    fp: Array,
    inv_v_max: Array,
    q_min: Array,
    q_max: Array,
    kind: Array,
    level_of: Array,
    n_levels: int,
    par: Array,
    vec_a: Array,
    vec_b: Array,
    goal_R: Array,
    sph_c: Array,
    sph_r: Array,
    sph_obj: Array,
    lam2: float,
    eta: float,
    dt: float,
    max_steps: int,
    pos_tol: float,
    tol_rot: float,
    stall_s: float,
    path: Array,
) -> tuple[int, int, float, float, float, float, Array]:  # pragma: no cover - compiled
    """Integrate one controller action from ``q0`` until a stop rule ends it.

    Objectives ``o`` (in evaluation order: by level, then as listed) have a ``kind``, a level
    and parameters: ``par[o]`` (joint limits: width, gain; minimum distance: d_min, width,
    gain; end-effector pose: gain, max speed, angular gain, max angular speed; posture: gain,
    is goal, max speed or NaN), ``vec_a[o]``/``vec_b[o]`` (joint limits: lower and upper bound;
    posture: the goal; end-effector pose: the goal position in ``vec_a[o, :3]``) and
    ``goal_R[o]``; the spheres ``sph_*`` belong to the minimum-distance objective ``sph_obj``.

    Returns how it ended (REACHED, STALLED, TIMED_OUT), the steps, the goal errors (m, rad),
    the energy, the least obstacle distance and the final joints; ``path[k]`` gets the TCP at
    step k.
    """
    n = q0.shape[0]
    n_obj = kind.shape[0]
    n_sph = sph_c.shape[0]
    maxrows = max(n, max(6, n_sph))
    tJ = np.zeros((n_obj, maxrows, n))
    tref = np.zeros((n_obj, maxrows))
    tact = np.zeros((n_obj, maxrows))
    rows = np.zeros(n_obj, dtype=np.int64)
    j_none = np.zeros(n_obj, dtype=np.bool_)
    act_none = np.zeros(n_obj, dtype=np.bool_)
    ineq = np.zeros(n_obj, dtype=np.bool_)
    av_n = np.zeros((max(n_sph, 1), 3))
    av_a = np.zeros(max(n_sph, 1))
    J = np.zeros((6, n))
    q = q0.copy()
    energy = 0.0
    min_dist = math.inf
    best = math.inf
    best_t = 0.0
    step = 0
    t = 0.0
    inv_dt = 1.0 / dt
    while True:
        p, R = _kinematics(q, jR, jp, jax, fR, fp, J)
        path[step, :] = p
        # the objectives (TaskPriorityController.solve's evaluate pass)
        e0 = 0.0
        e1 = 0.0
        n_av = 0
        step_min = math.inf
        for o in range(n_obj):
            k = kind[o]
            rows[o] = 0
            if k == JOINT_LIMITS:
                ineq[o] = True
                width, gain = par[o, 0], par[o, 1]
                near = False
                for c in range(n):
                    if q[c] < vec_a[o, c] + width or q[c] > vec_b[o, c] - width:
                        near = True
                if not near:
                    continue
                m = 0
                for c in range(n):
                    a_lo = _bell((q[c] - vec_a[o, c]) / width)
                    a_hi = _bell((vec_b[o, c] - q[c]) / width)
                    a = max(a_lo, a_hi)
                    if a > 0.0:
                        tJ[o, m, :] = 0.0
                        if a_lo >= a_hi:
                            tJ[o, m, c] = 1.0
                            tref[o, m] = gain * (vec_a[o, c] - q[c])
                        else:
                            tJ[o, m, c] = -1.0
                            tref[o, m] = gain * (q[c] - vec_b[o, c])
                        tact[o, m] = a
                        m += 1
                rows[o] = m
            elif k == MIN_DISTANCE:
                ineq[o] = True
                d_min, width, gain = par[o, 0], par[o, 1], par[o, 2]
                m = 0
                for si in range(n_sph):
                    if sph_obj[si] != o:
                        continue
                    dx = p[0] - sph_c[si, 0]
                    dy = p[1] - sph_c[si, 1]
                    dz = p[2] - sph_c[si, 2]
                    nn = math.sqrt(dx * dx + dy * dy + dz * dz)
                    nrm = np.empty(3)
                    if nn < 1e-12:
                        d = -sph_r[si]
                        nrm[0], nrm[1], nrm[2] = 0.0, 0.0, 1.0
                    else:
                        d = nn - sph_r[si]
                        nrm[0], nrm[1], nrm[2] = dx / nn, dy / nn, dz / nn
                    step_min = min(step_min, d)
                    a = _bell((d - d_min) / width)
                    if a <= 0.0:
                        continue
                    for c in range(n):
                        tJ[o, m, c] = nrm[0] * J[0, c] + nrm[1] * J[1, c] + nrm[2] * J[2, c]
                    tref[o, m] = gain * (d_min - d)
                    tact[o, m] = a
                    av_n[n_av, :] = nrm
                    av_a[n_av] = a
                    n_av += 1
                    m += 1
                rows[o] = m
            elif k == EE_POSE:
                gain, vmax, again, wmax = par[o, 0], par[o, 1], par[o, 2], par[o, 3]
                e = vec_a[o, :3] - p
                ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
                v = gain * e
                if gain * ep > vmax:
                    v *= vmax / (gain * ep)
                for si in range(n_av):
                    v = _slide(v, av_n[si], av_a[si])
                lg = _rotation_log(_matmul(goal_R[o], R.T.copy()))
                eo = math.sqrt(lg[0] * lg[0] + lg[1] * lg[1] + lg[2] * lg[2])
                w = again * lg
                if again * eo > wmax:
                    w *= wmax / (again * eo)
                tJ[o, :6, :] = J
                tref[o, :3] = v
                tref[o, 3:6] = w
                rows[o] = 6
                act_none[o] = True
                e0 = max(e0, ep)
                e1 = max(e1, eo)
            else:  # posture
                gain, is_goal, vmax = par[o, 0], par[o, 1], par[o, 2]
                top = 0.0
                for c in range(n):
                    tref[o, c] = gain * (vec_a[o, c] - q[c])
                    top = max(top, abs(tref[o, c]))
                if not math.isnan(vmax) and top > vmax:
                    for c in range(n):
                        tref[o, c] *= vmax / top
                if is_goal > 0.0:
                    err = 0.0
                    for c in range(n):
                        err = max(err, abs(vec_a[o, c] - q[c]))
                    e0 = max(e0, 0.0)
                    e1 = max(e1, err)
                rows[o] = n
                j_none[o] = True
                act_none[o] = True
        min_dist = min(min_dist, step_min)
        # the stop rules, in KinematicSimulator._simulate's order
        if e0 <= pos_tol and e1 <= tol_rot:
            return REACHED, step, e0, e1, energy, min_dist, q
        progress = e0 + 0.1 * e1
        if progress < best * 0.995 - 1e-6:
            best, best_t = progress, t
        elif t - best_t >= stall_s:
            return STALLED, step, e0, e1, energy, min_dist, q
        if step >= max_steps:
            return TIMED_OUT, step, e0, e1, energy, min_dist, q
        # TaskPriorityController.solve: the inequality rows a first solution already respects
        # are switched off for this step
        any_ineq = False
        for o in range(n_obj):
            if ineq[o] and rows[o] > 0:
                any_ineq = True
        if any_ineq:
            pre = _recursion(
                n,
                level_of,
                n_levels,
                rows,
                tJ,
                tref,
                tact,
                j_none,
                act_none,
                ineq,
                False,
                lam2,
                eta,
            )
            for o in range(n_obj):
                if ineq[o] and rows[o] > 0:
                    for ri in range(rows[o]):
                        rate = 0.0
                        for c in range(n):
                            rate += tJ[o, ri, c] * pre[c]
                        if rate >= tref[o, ri]:
                            tact[o, ri] = 0.0
        qdot = _recursion(
            n, level_of, n_levels, rows, tJ, tref, tact, j_none, act_none, ineq, True, lam2, eta
        )
        # TaskPriorityController.saturate, then the Euler step
        ratio = 0.0
        for c in range(n):
            ratio = max(ratio, abs(qdot[c]) * inv_v_max[c])
        if ratio > 1.0:
            qdot = qdot * (1.0 / ratio)
        for c in range(n):
            qdot[c] = min(max(qdot[c], (q_min[c] - q[c]) * inv_dt), (q_max[c] - q[c]) * inv_dt)
        q = q + qdot * dt
        sq = 0.0
        for c in range(n):
            sq += qdot[c] * qdot[c]
        energy += 0.5 * sq * dt
        step += 1
        t = step * dt


#: the compiled loop (typed loosely: numba's dispatcher checks the arguments at the call)
integrate: Any = _integrate

# ----------------------------------------------------------------------------------------------
# from the Python objects to the kernel's arrays
# ----------------------------------------------------------------------------------------------

_CHAINS: dict[int, tuple[Any, tuple[Array, ...] | None]] = {}


def chain_of(arm: Any) -> tuple[Array, ...] | None:
    """The arm's chain as the kernel reads it — joint placements, axes (0, 1, 2 for x, y, z)
    and the TCP frame's placement — or None when it is not a serial chain of revolute joints
    about a principal axis (the numpy lockstep then runs)."""
    key = id(arm)
    hit = _CHAINS.get(key)
    if hit is not None and hit[0] is arm:
        return hit[1]
    model = arm.model
    axes = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}
    n = int(model.nq)
    out: tuple[Array, ...] | None = None
    ok = int(model.njoints) == n + 1 and int(model.nv) == n
    jax = np.zeros(n, dtype=np.int64)
    for j in range(1, n + 1) if ok else ():
        name = model.joints[j].shortname()
        if name not in axes or int(model.parents[j]) != j - 1 or model.joints[j].idx_q != j - 1:
            ok = False
            break
        jax[j - 1] = axes[name]
    frame = model.frames[arm.tcp_frame]
    if ok and int(frame.parentJoint) == n:
        jR = np.stack([np.array(model.jointPlacements[j].rotation) for j in range(1, n + 1)])
        jp = np.stack([np.array(model.jointPlacements[j].translation) for j in range(1, n + 1)])
        out = (
            np.ascontiguousarray(jR, dtype=float),
            np.ascontiguousarray(jp, dtype=float),
            jax,
            np.ascontiguousarray(frame.placement.rotation, dtype=float),
            np.ascontiguousarray(frame.placement.translation, dtype=float),
        )
    _CHAINS[key] = (arm, out)
    return out


def objectives_of(ctrl: Any) -> tuple[Any, ...] | None:
    """The kernel's arrays for the hierarchy of ``ctrl`` (one arm, the objectives that
    :func:`flexhrc.action.lockstep._signature` accepts), or None."""
    from flexhrc.action.control import (
        EndEffectorPose,
        JointLimits,
        MinimumDistance,
        Posture,
        Sphere,
    )

    n = ctrl.n
    objs = [(li, o) for li, level in enumerate(ctrl.levels) for o in level]
    n_obj = len(objs)
    kind = np.zeros(n_obj, dtype=np.int64)
    level_of = np.zeros(n_obj, dtype=np.int64)
    par = np.full((n_obj, 4), math.nan)
    vec_a = np.zeros((n_obj, n))
    vec_b = np.zeros((n_obj, n))
    goal_R = np.zeros((n_obj, 3, 3))
    sph_c: list[Any] = []
    sph_r: list[float] = []
    sph_obj: list[int] = []
    for i, (li, o) in enumerate(objs):
        level_of[i] = li
        if isinstance(o, JointLimits):
            kind[i] = JOINT_LIMITS
            par[i, :2] = (o.width, o.gain)
            vec_a[i], vec_b[i] = o.lo, o.hi
        elif isinstance(o, MinimumDistance):
            kind[i] = MIN_DISTANCE
            par[i, :3] = (o.d_min, o.width, o.gain)
            for s in o.obstacles:
                if not isinstance(s, Sphere):
                    return None
                sph_c.append(tuple(float(v) for v in s.center))
                sph_r.append(float(s.radius))
                sph_obj.append(i)
        elif isinstance(o, EndEffectorPose):
            if o.position is None or o.rotation is None or n != 7:
                return None
            kind[i] = EE_POSE
            par[i] = (o.gain, o.max_speed, o.angular_gain, o.max_angular_speed)
            vec_a[i, :3] = o.position
            goal_R[i] = o.rotation
        elif isinstance(o, Posture):
            kind[i] = POSTURE
            par[i, :3] = (o.gain, 1.0 if o.is_goal else 0.0, math.nan if o.max_speed is None
                          else o.max_speed)  # fmt: skip
            vec_a[i] = o.q_goal
        else:
            return None
    return (
        kind, level_of, len(ctrl.levels), par, vec_a, vec_b, goal_R,
        np.array(sph_c, dtype=float).reshape(len(sph_c), 3), np.array(sph_r, dtype=float),
        np.array(sph_obj, dtype=np.int64),
    )  # fmt: skip


def warm_up() -> float:
    """Compile (or load from numba's cache) the kernel now, not inside a timed decision;
    the seconds it took (0.0 without numba)."""
    if not available():
        return 0.0
    import time

    t0 = time.perf_counter()
    n = 7
    eye = np.eye(3)
    integrate(
        np.zeros(n), np.stack([eye] * n), np.zeros((n, 3)), np.full(n, 2, dtype=np.int64), eye,
        np.zeros(3), np.ones(n), -np.ones(n), np.ones(n),
        np.array([POSTURE], dtype=np.int64), np.zeros(1, dtype=np.int64), 1,
        np.array([[1.0, 1.0, math.nan, math.nan]]), np.zeros((1, n)), np.zeros((1, n)),
        np.zeros((1, 3, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=np.int64),
        1e-4, 1.0, 0.04, 1, 1e-3, 1e-2, 1.0, np.empty((2, 3)),
    )  # fmt: skip
    return time.perf_counter() - t0
