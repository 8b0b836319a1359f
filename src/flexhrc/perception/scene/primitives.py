"""RANSAC fits of primitive shapes to an object cluster, and PCA for its main axis.

FlexHRC+ (paper 000, III) models objects "using a set of primitive shapes characterised by
their geometrical characteristics" fitted by RANSAC, with PCA for complementary features. The
fits here work in the *support frame* (origin on the support plane, z along its normal), where
the table gives the objects' bottom even though the camera never sees it:

* **box** (a plane-faced object, e.g. a board): yaw from a 2-D PCA of the footprint, extents
  from robust percentiles, height from the top face above the support;
* **cylinder**: axis from PCA (the direction of largest spread), then a RANSAC circle in the
  plane perpendicular to the axis (3-point hypotheses, least-squares refinement) — far cheaper
  than a 2-point-and-normals cylinder RANSAC and robust for elongated parts such as legs;
* **sphere**: 4-point RANSAC of ``x²+y²+z² + Dx + Ey + Fz + G = 0``, least-squares refined;
* **cone** (upright): RANSAC of the apex height and slope of ``r(z)`` about a vertical axis
  through the footprint centre.

Each fit reports the fraction of points within ``tol`` of its surface; the pipeline keeps the
best-scoring primitive.
"""

from __future__ import annotations

import numpy as np

from flexhrc.perception._deps import require
from flexhrc.perception.scene.types import PrimitiveFit

_UP = np.array([0.0, 0.0, 1.0])


def pca(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mean, axes, variances)``; ``axes`` rows are the principal directions, largest first."""
    mean = points.mean(axis=0)
    cov = np.cov((points - mean).T)
    w, v = np.linalg.eigh(cov)
    order = np.argsort(w)[::-1]
    return mean, v[:, order].T, w[order]


def _robust_range(x: np.ndarray, q: float = 0.5) -> tuple[float, float]:
    lo, hi = np.percentile(x, [q, 100 - q])
    return float(lo), float(hi)


# ------------------------------------------------------------------------------------- box
def _min_area_direction(xy: np.ndarray) -> np.ndarray:
    """Long side of the minimum-area rectangle around ``xy`` (rotating calipers on the hull).

    PCA gives the same answer for elongated footprints but an arbitrary one for square ones
    (a cube), where the rectangle of the PCA axes is up to √2 too large.
    """
    spatial = require("scipy.spatial", "scene perception")
    try:
        hull = xy[spatial.ConvexHull(xy).vertices]
    except Exception:  # degenerate (collinear) footprint
        w, v = np.linalg.eigh(np.cov(xy.T))
        return v[:, int(np.argmax(w))]
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
    angles = np.unique(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), np.pi / 2))
    dirs = np.column_stack([np.cos(angles), np.sin(angles)])
    perp = np.column_stack([-dirs[:, 1], dirs[:, 0]])
    pa, pb = hull @ dirs.T, hull @ perp.T
    la, lb = np.ptp(pa, axis=0), np.ptp(pb, axis=0)
    k = int(np.argmin(la * lb))
    return dirs[k] if la[k] >= lb[k] else perp[k]


def fit_box(points: np.ndarray, tol: float) -> PrimitiveFit:
    """Oriented box resting on the support (``points`` in the support frame)."""
    xy = points[:, :2]
    c2 = xy.mean(axis=0)
    a = _min_area_direction(xy - c2)
    b = np.array([-a[1], a[0]])
    pa, pb = (xy - c2) @ a, (xy - c2) @ b
    (a0, a1), (b0, b1) = _robust_range(pa), _robust_range(pb)
    z = points[:, 2]
    top = np.percentile(z, 99)
    # The top face is where most points of a box seen from above lie: its median height is an
    # estimate unbiased by the sensor noise (a max would be biased up by ~2 sigma).
    top_pts = z[z > top - max(3 * tol, 0.3 * top)]
    h = float(np.median(top_pts)) if len(top_pts) else float(top)
    la, lb = a1 - a0, b1 - b0
    center = np.array([*(c2 + a * (a0 + a1) / 2 + b * (b0 + b1) / 2), h / 2])
    # Distance of each point to the box surface.
    local = np.column_stack([pa - (a0 + a1) / 2, pb - (b0 + b1) / 2, z - h / 2])
    half = np.array([la / 2, lb / 2, h / 2])
    q = np.abs(local) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    dist = outside + np.abs(inside)
    ratio = float(np.mean(dist < tol))
    axis3 = np.array([a[0], a[1], 0.0])
    size = np.sort(np.array([la, lb, h]))[::-1]
    return PrimitiveFit("box", center, axis3, size, ratio, {"height": h})


# -------------------------------------------------------------------------------- cylinder
def _circle_3pts(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circles through point triples ``p`` (k, 3, 2): centres (k, 2) and radii (k,)."""
    a, b, c = p[:, 0], p[:, 1], p[:, 2]
    d = 2 * (
        a[:, 0] * (b[:, 1] - c[:, 1])
        + b[:, 0] * (c[:, 1] - a[:, 1])
        + c[:, 0] * (a[:, 1] - b[:, 1])
    )
    d = np.where(np.abs(d) < 1e-12, np.nan, d)
    sa, sb, sc = (a**2).sum(1), (b**2).sum(1), (c**2).sum(1)
    ux = (sa * (b[:, 1] - c[:, 1]) + sb * (c[:, 1] - a[:, 1]) + sc * (a[:, 1] - b[:, 1])) / d
    uy = (sa * (c[:, 0] - b[:, 0]) + sb * (a[:, 0] - c[:, 0]) + sc * (b[:, 0] - a[:, 0])) / d
    centers = np.column_stack([ux, uy])
    return centers, np.linalg.norm(a - centers, axis=1)


def _round_lsq(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Algebraic (Kåsa) least-squares circle (points ``(n, 2)``) or sphere (``(n, 3)``)."""
    A = np.column_stack([2 * p, np.ones(len(p))])
    b = (p**2).sum(1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:-1]
    return c, float(np.sqrt(max(sol[-1] + c @ c, 0.0)))


def fit_cylinder(
    points: np.ndarray,
    tol: float,
    iterations: int = 80,
    rng: np.random.Generator | None = None,
    axis: np.ndarray | None = None,
    grounded: bool = False,
) -> PrimitiveFit:
    """Cylinder with the PCA main axis (or the given ``axis``, e.g. the support normal for a
    part standing upright, whose points are mostly its cap); RANSAC circle in the
    perpendicular plane. ``grounded``: the cylinder reaches down to the plane through the
    origin normal to ``axis`` (the support in the support frame), as a box fit assumes: a
    part standing upright is seen from above by its cap and little of its side."""
    rng = rng if rng is not None else np.random.default_rng(0)
    mean, axes, _ = pca(points)
    if axis is None:
        axis = axes[0]
        e1, e2 = axes[1], axes[2]
    else:
        axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
        e1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
    rel = points - mean
    s = rel @ axis
    p2 = np.column_stack([rel @ e1, rel @ e2])
    spread = float(np.ptp(p2, axis=0).max()) if len(p2) else 0.0
    idx = rng.integers(0, len(p2), size=(iterations, 3))
    centers, radii = _circle_3pts(p2[idx])
    ok = np.isfinite(radii) & (radii < 0.75 * max(spread, 1e-6)) & (radii > 1e-3)
    if not ok.any():
        return PrimitiveFit("cylinder", mean, axis, np.array([np.ptp(s), 0.0, 0.0]), 0.0)
    centers, radii = centers[ok], radii[ok]
    d = np.linalg.norm(p2[None, :, :] - centers[:, None, :], axis=2)
    scores = (np.abs(d - radii[:, None]) < tol).sum(axis=1)
    best = int(np.argmax(scores))
    inl = np.abs(d[best] - radii[best]) < tol
    c, r = _round_lsq(p2[inl]) if inl.sum() >= 3 else (centers[best], float(radii[best]))
    dist = np.abs(np.linalg.norm(p2 - c, axis=1) - r)
    s0, s1 = _robust_range(s)
    if grounded:
        s0 = min(s0, -float(mean @ axis))
    ratio = float(np.mean(dist < tol))
    center = mean + c[0] * e1 + c[1] * e2 + axis * (s0 + s1) / 2
    size = np.array([s1 - s0, 2 * r, 2 * r])
    if axis[0] < 0 or (axis[0] == 0 and axis[1] < 0):
        axis = -axis  # a canonical sign, so the axis of a tracked object does not flip
    return PrimitiveFit("cylinder", center, axis, np.sort(size)[::-1], ratio, {"radius": r})


# ---------------------------------------------------------------------------------- sphere
def fit_sphere(
    points: np.ndarray, tol: float, iterations: int = 60, rng: np.random.Generator | None = None
) -> PrimitiveFit:
    rng = rng if rng is not None else np.random.default_rng(0)
    extent = float(np.ptp(points, axis=0).max())
    idx = rng.integers(0, len(points), size=(iterations, 4))
    A = np.concatenate([2 * points[idx], np.ones((iterations, 4, 1))], axis=2)
    b = (points[idx] ** 2).sum(2)
    good = np.abs(np.linalg.det(A)) > 1e-12
    best_c, best_r, best_score = points.mean(0), 0.0, -1
    if good.any():
        sol = np.linalg.solve(A[good], b[good][:, :, None])[:, :, 0]
        cs = sol[:, :3]
        rs = np.sqrt(np.maximum(sol[:, 3] + (cs**2).sum(1), 0.0))
        ok = (rs > 1e-3) & (rs < extent)
        if ok.any():
            cs, rs = cs[ok], rs[ok]
            d = np.linalg.norm(points[None] - cs[:, None], axis=2)
            scores = (np.abs(d - rs[:, None]) < tol).sum(1)
            k = int(np.argmax(scores))
            best_c, best_r, best_score = cs[k], float(rs[k]), int(scores[k])
    if best_score > 3:
        inl = np.abs(np.linalg.norm(points - best_c, axis=1) - best_r) < tol
        best_c, best_r = _round_lsq(points[inl])
    dist = np.abs(np.linalg.norm(points - best_c, axis=1) - best_r)
    ratio = float(np.mean(dist < tol)) if best_r > 0 else 0.0
    return PrimitiveFit(
        "sphere", best_c, _UP.copy(), np.full(3, 2 * best_r), ratio, {"radius": best_r}
    )


# ------------------------------------------------------------------------------------ cone
def fit_cone(
    points: np.ndarray, tol: float, iterations: int = 100, rng: np.random.Generator | None = None
) -> PrimitiveFit:
    """Upright cone (apex up) on the support: ``r(z) = R (1 - z / H)`` about a vertical axis.

    The axis starts through the highest points (the apex), RANSAC over pairs of points fixes
    the line ``r = R - k z``, and a robust least-squares fit refines axis, ``R`` and ``k``.
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    xy = points[:, :2]
    z = points[:, 2]
    # The apex is the top of the cluster and lies on the axis, whichever side is visible.
    c = xy[z >= np.percentile(z, 95)].mean(axis=0)
    no_cone = PrimitiveFit("cone", np.array([*c, 0.0]), _UP.copy(), np.zeros(3), 0.0)
    r = np.linalg.norm(xy - c, axis=1)
    pair = rng.integers(0, len(z), size=(iterations, 2))
    dz = z[pair[:, 0]] - z[pair[:, 1]]
    okp = np.abs(dz) > 1e-3
    if not okp.any():
        return no_cone
    k = -(r[pair[okp, 0]] - r[pair[okp, 1]]) / dz[okp]  # r = R - k z
    R = r[pair[okp, 0]] + k * z[pair[okp, 0]]
    # A cone stands on the support with its apex at the top of the cluster, and its base fits
    # inside the footprint: this rejects the huge flat "cones" that explain a board.
    zmax = float(np.percentile(z, 99))
    r_max = 1.2 * float(np.percentile(r, 99))
    H_all = R / np.where(k > 0, k, np.inf)
    valid = (k > 0.05) & (R > 0.005) & (r_max > R) & (np.abs(H_all - zmax) < 0.25 * zmax + tol)
    if not valid.any():
        return no_cone
    k, R = k[valid], R[valid]
    # Perpendicular distance to the cone surface ≈ |r - (R - k z)| cos(atan k).
    res = np.abs(r[None] - (R[:, None] - k[:, None] * z[None])) / np.sqrt(1 + k[:, None] ** 2)
    scores = (res < tol).sum(1)
    b = int(np.argmax(scores))
    if scores[b] < 0.5 * len(points):  # not a cone: skip the (comparatively costly) refinement
        return no_cone
    # Refine axis position, base radius and slope together (robust least squares): the
    # footprint circle is biased when only one side of the cone is visible.
    optimize = require("scipy.optimize", "cone fitting")

    def residual(p: np.ndarray) -> np.ndarray:
        rr = np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1])
        return (rr - (p[2] - p[3] * z)) / np.sqrt(1 + p[3] ** 2)

    sol = optimize.least_squares(
        residual, [c[0], c[1], R[b], k[b]], loss="soft_l1", f_scale=tol, max_nfev=50
    ).x
    c, Rb, kb = sol[:2], float(sol[2]), float(sol[3])
    if not (kb > 0.05 and 0.005 < Rb < r_max):
        return PrimitiveFit("cone", np.array([*c, 0.0]), _UP.copy(), np.zeros(3), 0.0)
    H = Rb / kb
    ratio = float(np.mean(np.abs(residual(sol)) < tol))
    size = np.sort(np.array([H, 2 * Rb, 2 * Rb]))[::-1]
    return PrimitiveFit(
        "cone", np.array([*c, H / 2]), _UP.copy(), size, ratio, {"radius": Rb, "height": H}
    )
