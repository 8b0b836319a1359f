"""Headless view: replay a simulated trajectory in a PyBullet scene and save a PNG or a GIF.

PyBullet's ``DIRECT`` mode with its software ``TinyRenderer`` needs no display and no GPU, so this
works on a server or in CI. The scene is the shipped robot URDF (primitive shapes only), a table
top at z = 0, the obstacles (red), the human hand (skin colour), the goal (green) and the path of
each TCP (small dots). A PNG shows the last configuration; a GIF shows up to ``max_frames``
evenly spaced configurations. Only used on request (``flexhrc sim ... --view out.png``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.action.control import Box, Sphere, parse_obstacle
from flexhrc.action.robots import DEFAULT_URDF
from flexhrc.action.simulator import Trajectory
from flexhrc.errors import FlexhrcError, OptionalDependencyError


def _import_pybullet() -> Any:
    try:
        import pybullet
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise OptionalDependencyError("the trajectory view", "sim", "pybullet") from exc
    return pybullet


def _import_pil() -> Any:
    try:
        from PIL import Image
    except ImportError as exc:  # pragma: no cover - pillow comes with matplotlib
        raise OptionalDependencyError("saving images", "viz", "pillow") from exc
    return Image


def _visual(p: Any, cid: int, kind: str, size: Any, pos: Sequence[float], rgba: Sequence[float]):
    if kind == "sphere":
        shape = p.createVisualShape(p.GEOM_SPHERE, radius=float(size), rgbaColor=rgba,
                                    physicsClientId=cid)  # fmt: skip
    else:
        shape = p.createVisualShape(p.GEOM_BOX, halfExtents=list(size), rgbaColor=rgba,
                                    physicsClientId=cid)  # fmt: skip
    return p.createMultiBody(baseMass=0, baseVisualShapeIndex=shape,
                             basePosition=list(pos), physicsClientId=cid)  # fmt: skip


def render(
    trajectory: Trajectory,
    path: str | Path,
    *,
    obstacles: Iterable[Any] = (),
    human_hand: Sequence[float] | None = None,
    goal: Sequence[float] | None = None,
    urdf: str | Path = DEFAULT_URDF,
    width: int = 640,
    height: int = 480,
    max_frames: int = 40,
    rest: dict[str, np.ndarray] | None = None,
) -> Path:
    """Render ``trajectory`` to ``path`` (``.png``: last frame; ``.gif``: animation)."""
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in (".png", ".gif"):
        raise FlexhrcError(f"--view: {out}: the view is saved as .png or .gif")
    if len(trajectory) == 0:
        raise FlexhrcError("nothing to view: the trajectory is empty")
    p = _import_pybullet()
    Image = _import_pil()
    cid = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(urdf), useFixedBase=True, physicsClientId=cid)
        joints = {}
        for j in range(p.getNumJoints(robot, physicsClientId=cid)):
            info = p.getJointInfo(robot, j, physicsClientId=cid)
            joints[info[1].decode()] = j
        _visual(p, cid, "box", (0.45, 0.6, 0.01), (0.45, 0.0, -0.011), (0.62, 0.45, 0.3, 1))
        for obs in (parse_obstacle(o) for o in obstacles):
            if isinstance(obs, Sphere):
                _visual(p, cid, "sphere", max(obs.radius, 0.01), obs.center, (0.85, 0.15, 0.1, 1))
            elif isinstance(obs, Box):
                _visual(p, cid, "box", obs.half_extents, obs.center, (0.85, 0.15, 0.1, 1))
        if human_hand is not None:
            _visual(p, cid, "sphere", 0.04, human_hand, (0.95, 0.75, 0.6, 1))
        if goal is not None:
            _visual(p, cid, "sphere", 0.012, goal, (0.1, 0.8, 0.2, 1))
        for arm in trajectory.arms:
            pts = trajectory.tcp[arm]
            idx = np.unique(np.linspace(0, len(pts) - 1, min(len(pts), 30)).astype(int))
            for i in idx:
                if np.all(np.isfinite(pts[i])):
                    _visual(p, cid, "sphere", 0.006, pts[i], (0.2, 0.4, 0.9, 1))

        def pose(k: int) -> None:
            for arm_name, q_rest in (rest or {}).items():
                for i in range(7):
                    j = joints.get(f"{arm_name}_joint{i + 1}")
                    if j is not None:
                        p.resetJointState(robot, j, float(q_rest[i]), physicsClientId=cid)
            for arm_name in trajectory.arms:
                q = trajectory.arm_q(arm_name)[k]
                if not np.all(np.isfinite(q)):  # arm idle before its first action
                    continue
                for i in range(7):
                    p.resetJointState(robot, joints[f"{arm_name}_joint{i + 1}"], float(q[i]),
                                      physicsClientId=cid)  # fmt: skip

        view = p.computeViewMatrix(cameraEyePosition=[1.75, 1.0, 1.25],
                                   cameraTargetPosition=[0.3, 0.0, 0.3],
                                   cameraUpVector=[0, 0, 1], physicsClientId=cid)  # fmt: skip
        proj = p.computeProjectionMatrixFOV(fov=45, aspect=width / height, nearVal=0.05,
                                            farVal=5.0, physicsClientId=cid)  # fmt: skip

        def snap() -> Any:
            img = p.getCameraImage(width, height, view, proj, renderer=p.ER_TINY_RENDERER,
                                   physicsClientId=cid)  # fmt: skip
            rgba = np.reshape(np.asarray(img[2], dtype=np.uint8), (height, width, 4))
            return Image.fromarray(rgba[:, :, :3])

        out.parent.mkdir(parents=True, exist_ok=True)
        if suffix == ".png":
            pose(len(trajectory) - 1)
            snap().save(out)
        else:
            ks = np.unique(np.linspace(0, len(trajectory) - 1, max_frames).astype(int))
            frames = []
            for k in ks:
                pose(int(k))
                frames.append(snap())
            frames[0].save(out, save_all=True, append_images=frames[1:], duration=100, loop=0)
    finally:
        p.disconnect(physicsClientId=cid)
    return out
