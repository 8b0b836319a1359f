"""Depth images of a synthetic scene rendered by pybullet (the ``sim`` extra), imported lazily.

The analytic ray caster of :mod:`.synthetic` is exact; this renders the *same* scene with
pybullet's software renderer (the engine of the simulated workspace) instead, so the perception
pipeline is also checked on a rasterised depth buffer: the table, boxes, cylinders and spheres
become pybullet shapes, the cone a triangle mesh, and the camera uses the scene's pinhole
intrinsics. The non-linear OpenGL depth buffer is converted to metric depth along the optical
axis. Each call uses its own ``DIRECT`` (headless) physics client.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from flexhrc.errors import OptionalDependencyError
from flexhrc.perception.scene.synthetic import Scene

_NEAR, _FAR = 0.05, 5.0


def _pybullet(feature: str = "rendering scenes with pybullet"):
    # pybullet prints its build time on stdout (from C) when imported: keep stdout clean for
    # ``--json`` by pointing file descriptor 1 at /dev/null meanwhile.
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            try:
                import pybullet
            except ImportError as exc:  # pragma: no cover - only without the extra
                raise OptionalDependencyError(feature, "sim", "pybullet") from exc
    finally:
        os.dup2(saved, 1)
        os.close(saved)
    return pybullet


def _cone_mesh(height: float, radius: float, n: int = 32) -> tuple[list, list]:
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    base = [[radius * np.cos(a), radius * np.sin(a), -height / 2] for a in ang]
    verts = [*base, [0.0, 0.0, height / 2], [0.0, 0.0, -height / 2]]
    apex, centre = n, n + 1
    idx: list[int] = []
    for i in range(n):
        j = (i + 1) % n
        idx += [i, j, apex, j, i, centre]
    return verts, idx


def render_depth_pybullet(
    scene: Scene, noise: float = 0.0, rng: np.random.Generator | None = None
) -> np.ndarray:
    """Depth image (m, 0 = no return) of ``scene`` rendered by pybullet's TinyRenderer."""
    p = _pybullet()
    rng = rng if rng is not None else np.random.default_rng(0)
    cid = p.connect(p.DIRECT)
    try:
        tx, ty = scene.table_half
        table = p.createVisualShape(p.GEOM_BOX, halfExtents=[tx, ty, 0.01], physicsClientId=cid)
        p.createMultiBody(0, -1, table, [0, 0, -0.01], physicsClientId=cid)
        for obj in scene.objects:
            yaw_q = p.getQuaternionFromEuler([0, 0, obj.yaw])
            orn = yaw_q
            if obj.primitive == "box":
                vis = p.createVisualShape(
                    p.GEOM_BOX, halfExtents=list(np.asarray(obj.dims) / 2), physicsClientId=cid
                )
            elif obj.primitive == "cylinder":
                vis = p.createVisualShape(
                    p.GEOM_CYLINDER, radius=obj.dims[1], length=obj.dims[0], physicsClientId=cid
                )
                # pybullet cylinders run along z: lay it down along x, then apply the yaw.
                lay = p.getQuaternionFromEuler([0, np.pi / 2, 0])
                orn = p.multiplyTransforms([0, 0, 0], yaw_q, [0, 0, 0], lay)[1]
            elif obj.primitive == "sphere":
                vis = p.createVisualShape(p.GEOM_SPHERE, radius=obj.dims[0], physicsClientId=cid)
            else:
                verts, idx = _cone_mesh(obj.dims[0], obj.dims[1])
                vis = p.createVisualShape(
                    p.GEOM_MESH, vertices=verts, indices=idx, physicsClientId=cid
                )
            p.createMultiBody(0, -1, vis, list(obj.center), orn, physicsClientId=cid)
        intr, T = scene.intrinsics, scene.extrinsics
        eye = T[:3, 3]
        forward, down = T[:3, 2], T[:3, 1]
        view = p.computeViewMatrix(list(eye), list(eye + forward), list(-down))
        vfov = float(np.degrees(2 * np.arctan(intr.height / 2 / intr.fy)))
        proj = p.computeProjectionMatrixFOV(vfov, intr.width / intr.height, _NEAR, _FAR)
        _, _, _, buf, _ = p.getCameraImage(
            intr.width, intr.height, view, proj, renderer=p.ER_TINY_RENDERER, physicsClientId=cid
        )
    finally:
        p.disconnect(cid)
    buf = np.asarray(buf, dtype=float).reshape(intr.height, intr.width)
    depth = _FAR * _NEAR / (_FAR - (_FAR - _NEAR) * buf)
    depth[buf >= 1.0 - 1e-7] = 0.0  # background: no return
    if noise > 0:
        depth = np.where(depth > 0, depth + rng.normal(0.0, noise, depth.shape), 0.0)
    return depth
