"""Synthetic tabletop scenes rendered to depth images by ray casting (numpy only).

A scene is a support table (z = 0) holding the parts of the table-assembly task — one tabletop
(one of two board sizes) and legs of two lengths lying on it — plus clutter (balls, blocks,
cones), placed at random without overlap. A pinhole depth camera looks at it obliquely from
above; every pixel's ray is intersected analytically with the table and every shape, so
self-occlusion and objects hiding parts of each other come out as in a real sensor. Sensor noise
is Gaussian on depth (``noise`` m) and ``dropout`` removes a fraction of pixels (no return).
The ground truth (type, primitive, centre, axis, size) comes with the scene.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexhrc.perception.scene.types import CameraIntrinsics

#: Object catalogue: type -> (primitive, dimensions). Box: (lx, ly, lz); cylinder (lying):
#: (length, radius); sphere: (radius,); cone (upright): (height, base radius).
CATALOGUE: dict[str, tuple[str, tuple[float, ...]]] = {
    "tabletop_large": ("box", (0.80, 0.50, 0.03)),
    "tabletop_small": ("box", (0.60, 0.40, 0.03)),
    "leg_long": ("cylinder", (0.45, 0.025)),
    "leg_short": ("cylinder", (0.30, 0.025)),
    "ball": ("sphere", (0.04,)),
    "block": ("box", (0.06, 0.06, 0.06)),
    "cone": ("cone", (0.10, 0.04)),
}
CLUTTER = ("ball", "block", "cone")


@dataclass(frozen=True)
class SceneObject:
    """Ground truth of one object: ``size`` sorted in decreasing order, as perception reports."""

    type: str
    primitive: str
    center: np.ndarray
    yaw: float
    dims: tuple[float, ...]

    @property
    def axis(self) -> np.ndarray:
        return np.array([np.cos(self.yaw), np.sin(self.yaw), 0.0])

    @property
    def size(self) -> np.ndarray:
        if self.primitive == "box":
            s = list(self.dims)
        elif self.primitive == "sphere":
            s = [2 * self.dims[0]] * 3
        else:  # cylinder: length and radius; cone: height and base radius
            s = [self.dims[0], 2 * self.dims[1], 2 * self.dims[1]]
        return np.sort(np.asarray(s, dtype=float))[::-1]

    def footprint(self) -> tuple[np.ndarray, float, np.ndarray]:
        """2-D oriented rectangle: centre, yaw, half extents."""
        if self.primitive == "box":
            half = np.array(self.dims[:2]) / 2
        elif self.primitive == "cylinder":
            half = np.array([self.dims[0] / 2, self.dims[1]])
        elif self.primitive == "sphere":
            half = np.array([self.dims[0], self.dims[0]])
        else:
            half = np.array([self.dims[1], self.dims[1]])
        return self.center[:2], self.yaw, half


@dataclass
class Scene:
    objects: list[SceneObject]
    intrinsics: CameraIntrinsics
    extrinsics: np.ndarray  # camera-to-world 4x4
    table_half: tuple[float, float] = (0.9, 0.7)
    meta: dict[str, float] = field(default_factory=dict)


def look_at(eye: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Camera-to-world transform of a camera at ``eye`` looking at ``target`` (z forward,
    x right, y down — the usual optical frame)."""
    z = target - eye
    z = z / np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, y, z])
    T[:3, 3] = eye
    return T


def _overlap(a: tuple, b: tuple, margin: float) -> bool:
    """Separating-axis test of two oriented rectangles grown by ``margin``."""
    (ca, ya, ha), (cb, yb, hb) = a, b
    ha, hb = ha + margin / 2, hb + margin / 2
    axes_a = np.array([[np.cos(ya), np.sin(ya)], [-np.sin(ya), np.cos(ya)]])
    axes_b = np.array([[np.cos(yb), np.sin(yb)], [-np.sin(yb), np.cos(yb)]])
    d = cb - ca
    for ax in (*axes_a, *axes_b):
        ra = np.sum(ha * np.abs(axes_a @ ax))
        rb = np.sum(hb * np.abs(axes_b @ ax))
        if abs(d @ ax) > ra + rb:
            return False
    return True


def generate_scene(
    rng: np.random.Generator,
    n_legs: int = 4,
    n_clutter: tuple[int, int] = (1, 3),
    workspace: tuple[float, float] = (0.65, 0.42),
    margin: float = 0.05,
    width: int = 400,
    height: int = 300,
    hfov_deg: float = 60.0,
) -> Scene:
    """A random scene: one tabletop, ``n_legs`` legs of random lengths, some clutter."""
    types = [str(rng.choice(["tabletop_large", "tabletop_small"]))]
    types += [str(rng.choice(["leg_long", "leg_short"])) for _ in range(n_legs)]
    types += [
        str(rng.choice(CLUTTER)) for _ in range(int(rng.integers(n_clutter[0], n_clutter[1] + 1)))
    ]
    placed: list[SceneObject] = []
    for t in types:
        prim, dims = CATALOGUE[t]
        for _ in range(500):
            yaw = float(rng.uniform(-np.pi, np.pi))
            xy = rng.uniform([-workspace[0], -workspace[1]], [workspace[0], workspace[1]])
            if prim == "box":
                z = dims[2] / 2
            elif prim == "cylinder":
                z = dims[1]
            elif prim == "sphere":
                z = dims[0]
            else:
                z = dims[0] / 2
            obj = SceneObject(t, prim, np.array([xy[0], xy[1], z]), yaw, dims)
            fp = obj.footprint()
            # The whole footprint must lie inside the workspace, and clear of the others.
            rot = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
            signs = np.array([[1, 1], [1, -1], [-1, 1], [-1, -1]])
            corners = fp[0] + (signs * fp[2]) @ rot.T
            if np.any(np.abs(corners) > np.array(workspace) + 0.1):
                continue
            if all(not _overlap(fp, o.footprint(), margin) for o in placed):
                placed.append(obj)
                break
    eye = np.array([0.0, -0.75, 1.25])
    extr = look_at(eye, np.array([0.0, 0.0, 0.0]))
    intr = CameraIntrinsics.from_fov(width, height, hfov_deg)
    return Scene(placed, intr, extr)


# ------------------------------------------------------------------------------ ray casting
def _rays(intr: CameraIntrinsics, extr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v, u = np.mgrid[0 : intr.height, 0 : intr.width]
    d_cam = np.stack(
        [(u.ravel() - intr.cx) / intr.fx, (v.ravel() - intr.cy) / intr.fy, np.ones(u.size)],
        axis=1,
    )
    return extr[:3, 3], d_cam @ extr[:3, :3].T  # origin, directions with unit depth


def _to_local(o: np.ndarray, d: np.ndarray, center: np.ndarray, yaw: float):
    c, s = np.cos(yaw), np.sin(yaw)
    Rt = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # world -> local
    return Rt @ (o - center), d @ Rt.T


def _hit_box(o, d, half):
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / np.where(np.abs(d) < 1e-12, 1e-12, d)
        t1, t2 = (-half - o) * inv, (half - o) * inv
    tmin = np.minimum(t1, t2).max(axis=1)
    tmax = np.maximum(t1, t2).min(axis=1)
    return np.where((tmax >= tmin) & (tmin > 0), tmin, np.inf)


def _hit_cylinder_x(o, d, half_len, r):
    """Cylinder along local x, centred at the origin."""
    A = d[:, 1] ** 2 + d[:, 2] ** 2
    B = 2 * (o[1] * d[:, 1] + o[2] * d[:, 2])
    C = o[1] ** 2 + o[2] ** 2 - r * r
    disc = B * B - 4 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (-B - np.sqrt(disc)) / (2 * A)
    x = o[0] + t * d[:, 0]
    side = np.where((disc >= 0) & (t > 0) & (np.abs(x) <= half_len), t, np.inf)
    best = side
    for sgn in (-1.0, 1.0):
        with np.errstate(divide="ignore", invalid="ignore"):
            tc = (sgn * half_len - o[0]) / d[:, 0]
        yy, zz = o[1] + tc * d[:, 1], o[2] + tc * d[:, 2]
        cap = np.where((tc > 0) & (yy**2 + zz**2 <= r * r), tc, np.inf)
        best = np.minimum(best, cap)
    return best


def _hit_sphere(o, d, r):
    A = (d**2).sum(1)
    B = 2 * d @ o
    C = o @ o - r * r
    disc = B * B - 4 * A * C
    with np.errstate(invalid="ignore"):
        t = (-B - np.sqrt(disc)) / (2 * A)
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def _hit_cone(o, d, h, r):
    """Upright cone, base centred at the origin (z = 0), apex at (0, 0, h)."""
    k2 = (r / h) ** 2
    hz = h - o[2]
    A = d[:, 0] ** 2 + d[:, 1] ** 2 - k2 * d[:, 2] ** 2
    B = 2 * (o[0] * d[:, 0] + o[1] * d[:, 1] + k2 * hz * d[:, 2])
    C = o[0] ** 2 + o[1] ** 2 - k2 * hz**2
    disc = B * B - 4 * A * C
    best = np.full(len(d), np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        sq = np.sqrt(disc)
        for t in ((-B - sq) / (2 * A), (-B + sq) / (2 * A)):
            z = o[2] + t * d[:, 2]
            ok = (disc >= 0) & (t > 0) & (z >= 0) & (z <= h)
            best = np.minimum(best, np.where(ok, t, np.inf))
    return best


def render_depth(
    scene: Scene, noise: float = 0.0, dropout: float = 0.0, rng: np.random.Generator | None = None
) -> np.ndarray:
    """Depth image (m, 0 = no return) of ``scene`` seen by its camera."""
    rng = rng if rng is not None else np.random.default_rng(0)
    intr = scene.intrinsics
    o, d = _rays(intr, scene.extrinsics)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_table = np.where(d[:, 2] < 0, -o[2] / d[:, 2], np.inf)
    hit = o + t_table[:, None] * np.where(np.isfinite(t_table)[:, None], d, 0)
    tx, ty = scene.table_half
    t_best = np.where((np.abs(hit[:, 0]) <= tx) & (np.abs(hit[:, 1]) <= ty), t_table, np.inf)
    for obj in scene.objects:
        # Only rays that pass near the object (bounding sphere) need the exact test.
        rad = float(np.linalg.norm(obj.size)) / 2 + 0.01
        rel = obj.center - o
        tc = d @ rel / (d**2).sum(1)
        near = np.linalg.norm(o + tc[:, None] * d - obj.center, axis=1) < rad
        if not near.any():
            continue
        dn = d[near]
        if obj.primitive == "sphere":
            t = _hit_sphere(o - obj.center, dn, obj.dims[0])
        else:
            lo, ld = _to_local(o, dn, obj.center, obj.yaw)
            if obj.primitive == "box":
                t = _hit_box(lo, ld, np.asarray(obj.dims) / 2)
            elif obj.primitive == "cylinder":
                t = _hit_cylinder_x(lo, ld, obj.dims[0] / 2, obj.dims[1])
            else:
                lo = lo + np.array([0.0, 0.0, obj.dims[0] / 2])  # centre -> base
                t = _hit_cone(lo, ld, obj.dims[0], obj.dims[1])
        t_best[near] = np.minimum(t_best[near], t)
    depth = np.where(np.isfinite(t_best), t_best, 0.0)
    if noise > 0:
        depth = np.where(depth > 0, depth + rng.normal(0.0, noise, depth.shape), 0.0)
    if dropout > 0:
        depth[rng.random(depth.shape) < dropout] = 0.0
    return depth.reshape(intr.height, intr.width)
