"""The robot's head camera: PyBullet depth images of the simulated workspace (``sim`` extra).

One headless PyBullet client (``DIRECT``, software TinyRenderer: no display, no GPU) holds the
shipped dual-arm robot URDF, the table and a visual body per part; a frame moves the bodies to
the workspace's poses and the arms to their joint configuration, renders, and converts the
OpenGL depth buffer to metric depth along the optical axis. The arms are in the picture — they
hide what is behind them — but their own pixels are removed with the renderer's segmentation
mask (the "self filter" of real robots, which know their own body), so the scene pipeline never
mistakes a forearm for a part.

The camera sits on the robot's head, above and in front of the torso, looking down at the
table: every place a part can be (legs beside the tabletop, the middle pose, the operator's
hand) is in view, the arms at rest hide little.
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexhrc.perception.scene.sim_render import _pybullet
from flexhrc.perception.scene.synthetic import look_at
from flexhrc.perception.scene.types import CameraIntrinsics
from flexhrc.sensing.world import Part, SimulatedWorkspace

_NEAR, _FAR = 0.05, 5.0
COLOURS = {"box": (0.80, 0.62, 0.38, 1.0), "cylinder": (0.35, 0.55, 0.85, 1.0)}


@dataclass
class Frame:
    """One rendered frame: metric depth (0 = no return), and RGB when asked for."""

    depth: np.ndarray
    intrinsics: CameraIntrinsics
    extrinsics: np.ndarray  # camera-to-world
    rgb: np.ndarray | None = None
    robot_pixels: int = 0
    robot_mask: np.ndarray | None = None  # pixels of the robot's own body (self filter)

    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates ``(u, v)`` of world points ``(n, 3)`` (NaN behind the camera)."""
        T = self.extrinsics
        cam = (np.asarray(points, dtype=float) - T[:3, 3]) @ T[:3, :3]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(cam[:, 2] > 1e-6, cam[:, 2], np.nan)
            u = self.intrinsics.fx * cam[:, 0] / z + self.intrinsics.cx
            v = self.intrinsics.fy * cam[:, 1] / z + self.intrinsics.cy
        return np.column_stack([u, v])

    def near_robot(self, point: np.ndarray, radius_px: int = 4) -> bool:
        """Is the image of ``point`` within ``radius_px`` of the robot's own pixels?"""
        if self.robot_mask is None:
            return False
        u, v = self.project(np.asarray(point, dtype=float)[None])[0]
        if not (np.isfinite(u) and np.isfinite(v)):
            return False
        h, w = self.robot_mask.shape
        u0, u1 = max(0, int(u) - radius_px), min(w, int(u) + radius_px + 1)
        v0, v1 = max(0, int(v) - radius_px), min(h, int(v) + radius_px + 1)
        if u0 >= u1 or v0 >= v1:
            return False
        return bool(self.robot_mask[v0:v1, u0:u1].any())


class HeadCamera:
    """Depth camera on the robot's head (see the module docstring). Close it when done."""

    def __init__(
        self,
        *,
        width: int = 320,
        height: int = 240,
        hfov_deg: float = 50.0,
        eye: tuple[float, float, float] = (0.45, 0.0, 1.8),
        target: tuple[float, float, float] = (0.60, 0.0, 0.0),
        urdf: Any = None,
        noise_m: float = 0.0,
        seed: int = 0,
    ):
        from flexhrc.action.robots import DEFAULT_URDF

        if width < 16 or height < 16:
            raise ValueError(f"the image needs at least 16x16 pixels, got {width}x{height}")
        if not 5.0 <= hfov_deg <= 150.0:
            raise ValueError(f"hfov_deg must be in [5, 150], got {hfov_deg}")
        self.intrinsics = CameraIntrinsics.from_fov(width, height, hfov_deg)
        self.extrinsics = look_at(np.asarray(eye, float), np.asarray(target, float))
        self.noise_m = noise_m
        self._rng = np.random.default_rng(seed)
        self._p = _pybullet()
        p = self._p
        self._cid = p.connect(p.DIRECT)
        cid = self._cid
        self._robot = p.loadURDF(str(urdf or DEFAULT_URDF), useFixedBase=True, physicsClientId=cid)
        self._joints = {
            p.getJointInfo(self._robot, j, physicsClientId=cid)[1].decode(): j
            for j in range(p.getNumJoints(self._robot, physicsClientId=cid))
        }
        self._bodies: dict[str, tuple[int, Part]] = {}
        from flexhrc.action.robots import ARM_NAMES, PANDA_Q_REST

        self._rest = {arm: PANDA_Q_REST for arm in ARM_NAMES}  # the arms when none is given
        self._table: int | None = None
        T = self.extrinsics
        e, fwd, down = T[:3, 3], T[:3, 2], T[:3, 1]
        self._view = p.computeViewMatrix(list(e), list(e + fwd), list(-down))
        vfov = float(np.degrees(2 * np.arctan(height / 2 / self.intrinsics.fy)))
        self._proj = p.computeProjectionMatrixFOV(vfov, width / height, _NEAR, _FAR)

    # -- scene ------------------------------------------------------------------------------
    def _ensure_table(self, world: SimulatedWorkspace) -> None:
        if self._table is not None:
            return
        p, cid = self._p, self._cid
        x0, x1, y0, y1 = world.table
        vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=[(x1 - x0) / 2, (y1 - y0) / 2, 0.01],
            rgbaColor=[0.93, 0.93, 0.9, 1],
            physicsClientId=cid,
        )
        self._table = p.createMultiBody(
            0, -1, vis, [(x0 + x1) / 2, (y0 + y1) / 2, -0.01], physicsClientId=cid
        )

    def _body(self, part: Part) -> int:
        known = self._bodies.get(part.name)
        if known is not None and (known[1].shape, known[1].dims) == (part.shape, part.dims):
            return known[0]
        p, cid = self._p, self._cid
        rgba = list(COLOURS.get(part.shape, (0.6, 0.6, 0.6, 1.0)))
        if part.shape == "box":
            half = [d / 2 for d in part.dims]
            vis = p.createVisualShape(
                p.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=cid
            )
        else:
            vis = p.createVisualShape(
                p.GEOM_CYLINDER,
                radius=part.dims[1],
                length=part.dims[0],
                rgbaColor=rgba,
                physicsClientId=cid,
            )
        body = p.createMultiBody(0, -1, vis, [0, 0, -5], physicsClientId=cid)
        self._bodies[part.name] = (body, part)
        return body

    def _place(self, part: Part) -> None:
        p, cid = self._p, self._cid
        body = self._body(part)
        yaw = p.getQuaternionFromEuler([0, 0, part.yaw])
        orn = yaw
        if part.shape == "cylinder" and not part.upright:
            # pybullet cylinders run along z: lay it down along x, then turn it by the yaw
            lay = p.getQuaternionFromEuler([0, np.pi / 2, 0])
            orn = p.multiplyTransforms([0, 0, 0], yaw, [0, 0, 0], lay)[1]
        p.resetBasePositionAndOrientation(body, list(part.position), orn, physicsClientId=cid)
        self._bodies[part.name] = (body, part)

    def _pose_arms(self, q: Mapping[str, Any] | None) -> None:
        if not q:
            return
        p, cid = self._p, self._cid
        for arm, values in q.items():
            for i, v in enumerate(values):
                j = self._joints.get(f"{arm}_joint{i + 1}")
                if j is not None:
                    p.resetJointState(self._robot, j, float(v), physicsClientId=cid)

    # -- frames -----------------------------------------------------------------------------
    def render(
        self,
        world: SimulatedWorkspace,
        robot_q: Mapping[str, Any] | None = None,
        *,
        rgb: bool = False,
    ) -> Frame:
        """Depth (and optionally RGB) of ``world`` with the arms at ``robot_q`` (arm -> 7
        joint angles; rest posture if None)."""
        p, cid = self._p, self._cid
        self._ensure_table(world)
        for part in world.parts.values():
            self._place(part)
        self._pose_arms(robot_q if robot_q else self._rest)
        intr = self.intrinsics
        _, _, colour, buf, seg = p.getCameraImage(
            intr.width,
            intr.height,
            self._view,
            self._proj,
            renderer=p.ER_TINY_RENDERER,
            physicsClientId=cid,
        )
        buf = np.asarray(buf, dtype=float).reshape(intr.height, intr.width)
        depth = _FAR * _NEAR / (_FAR - (_FAR - _NEAR) * buf)
        depth[buf >= 1.0 - 1e-7] = 0.0
        body = np.asarray(seg, dtype=np.int64).reshape(intr.height, intr.width)
        body = np.where(body >= 0, body & ((1 << 24) - 1), -1)
        robot = body == self._robot
        depth[robot] = 0.0  # the self filter
        if self.noise_m > 0:
            depth = np.where(depth > 0, depth + self._rng.normal(0, self.noise_m, depth.shape), 0)
        image = None
        if rgb:
            image = np.asarray(colour, dtype=np.uint8).reshape(intr.height, intr.width, 4)[..., :3]
        return Frame(depth, intr, self.extrinsics, image, int(robot.sum()), robot)

    def close(self) -> None:
        if self._cid is not None:
            self._p.disconnect(physicsClientId=self._cid)
            self._cid = None

    def __enter__(self) -> HeadCamera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:  # pragma: no cover - best effort at interpreter exit
        with contextlib.suppress(Exception):
            self.close()


__all__ = ["Frame", "HeadCamera"]
