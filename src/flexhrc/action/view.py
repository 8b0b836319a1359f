"""Headless view: replay a simulated trajectory in a PyBullet scene and save a PNG or a GIF.

PyBullet's ``DIRECT`` mode with its software ``TinyRenderer`` needs no display and no GPU, so this
works on a server or in CI. The scene is the shipped robot URDF (primitive shapes only), a table
top at z = 0, the obstacles (red), the human hand (skin colour), the goal (green) and the path of
each TCP (small dots). Every frame carries a legend of these colours, a label beside each
obstacle, the goal and the hand, and a title (the action and its outcome), so a picture is
readable without this docstring. A PNG shows the last configuration; a GIF shows up to
``max_frames`` evenly spaced configurations. Only used on request
(``flexhrc sim ... --view out.png``); the caller checks the output path first and writes it
atomically (:mod:`flexhrc.files`), so no folder is created here.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.action.control import Sphere, parse_obstacle
from flexhrc.action.robots import DEFAULT_URDF
from flexhrc.action.simulator import Trajectory
from flexhrc.errors import FlexhrcError, OptionalDependencyError
from flexhrc.perception.scene.sim_render import _pybullet

VIEW_SUFFIXES = (".png", ".gif")
OBSTACLE_RGBA = (0.85, 0.15, 0.1, 1)
HAND_RGBA = (0.95, 0.75, 0.6, 1)
GOAL_RGBA = (0.1, 0.8, 0.2, 1)
PATH_RGBA = (0.2, 0.4, 0.9, 1)


def _project(view: Sequence[float], proj: Sequence[float], xyz: Sequence[float], w: int, h: int):
    """Pixel (column, row) of world point ``xyz`` in a PyBullet camera (column-major 4x4s)."""
    v = np.asarray(view, dtype=float).reshape(4, 4).T
    pr = np.asarray(proj, dtype=float).reshape(4, 4).T
    clip = pr @ v @ np.array([*map(float, xyz), 1.0])
    if clip[3] <= 1e-9:
        return None
    ndc = clip[:3] / clip[3]
    return (int((ndc[0] + 1) / 2 * w), int((1 - ndc[1]) / 2 * h))


def _rgb(rgba: Sequence[float]) -> tuple[int, int, int]:
    return (int(rgba[0] * 255), int(rgba[1] * 255), int(rgba[2] * 255))


def _annotate(
    image: Any,
    title: str | None,
    legend: list[tuple[str, Sequence[float]]],
    labels: list[tuple[str, tuple[int, int] | None]],
) -> Any:
    """Title, colour legend and labels drawn onto a frame (PIL's built-in font)."""
    from PIL import ImageDraw

    draw = ImageDraw.Draw(image)
    y = 6
    if title:
        draw.text((8, y), title, fill=(0, 0, 0))
        y += 16
    for name, rgba in legend:
        draw.rectangle((8, y + 2, 18, y + 12), fill=_rgb(rgba), outline=(0, 0, 0))
        draw.text((24, y), name, fill=(0, 0, 0))
        y += 15
    for text, at in labels:
        if at is None or not (0 <= at[0] < image.width and 0 <= at[1] < image.height):
            continue
        x, yy = at[0] + 10, at[1] - 16
        draw.line((at[0], at[1], x, yy + 6), fill=(0, 0, 0))
        draw.text((x + 2, yy), text, fill=(0, 0, 0))
    return image


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
    title: str | None = None,
) -> Path:
    """Render ``trajectory`` to ``path`` (``.png``: last frame; ``.gif``: animation)."""
    out = Path(path)
    suffix = out.suffix.lower()
    if suffix not in VIEW_SUFFIXES:
        raise FlexhrcError(f"--view: {out}: the view is saved as .png or .gif")
    if len(trajectory) == 0:
        raise FlexhrcError("nothing to view: the trajectory is empty")
    p = _pybullet("the trajectory view")  # stdout stays clean for --json
    Image = _import_pil()
    cid = p.connect(p.DIRECT)
    try:
        robot = p.loadURDF(str(urdf), useFixedBase=True, physicsClientId=cid)
        joints = {}
        for j in range(p.getNumJoints(robot, physicsClientId=cid)):
            info = p.getJointInfo(robot, j, physicsClientId=cid)
            joints[info[1].decode()] = j
        _visual(p, cid, "box", (0.45, 0.6, 0.01), (0.45, 0.0, -0.011), (0.62, 0.45, 0.3, 1))
        marks: list[tuple[str, Sequence[float]]] = []  # (label, world point)
        parsed = [parse_obstacle(o) for o in obstacles]
        for n, obs in enumerate(parsed, 1):
            if isinstance(obs, Sphere):
                _visual(p, cid, "sphere", max(obs.radius, 0.01), obs.center, OBSTACLE_RGBA)
            else:
                _visual(p, cid, "box", obs.half_extents, obs.center, OBSTACLE_RGBA)
            marks.append(("obstacle" if len(parsed) == 1 else f"obstacle {n}", obs.center))
        if human_hand is not None:
            _visual(p, cid, "sphere", 0.04, human_hand, HAND_RGBA)
            marks.append(("human hand", human_hand))
        if goal is not None:
            _visual(p, cid, "sphere", 0.012, goal, GOAL_RGBA)
            marks.append(("goal", goal))
        for arm in trajectory.arms:
            pts = trajectory.tcp[arm]
            idx = np.unique(np.linspace(0, len(pts) - 1, min(len(pts), 30)).astype(int))
            for i in idx:
                if np.all(np.isfinite(pts[i])):
                    _visual(p, cid, "sphere", 0.006, pts[i], PATH_RGBA)
        legend: list[tuple[str, Sequence[float]]] = [("TCP path", PATH_RGBA)]
        if parsed:
            legend.append(("obstacle", OBSTACLE_RGBA))
        if goal is not None:
            legend.append(("goal", GOAL_RGBA))
        if human_hand is not None:
            legend.append(("human hand (kept 15 cm away)", HAND_RGBA))

        def pose(k: int) -> None:
            moving = [(a, trajectory.arm_q(a)[k]) for a in trajectory.arms]
            for arm_name, q in [*(rest or {}).items(), *moving]:
                if not np.all(np.isfinite(q)):  # arm idle before its first action: at rest
                    continue
                for i in range(7):
                    j = joints.get(f"{arm_name}_joint{i + 1}")
                    if j is not None:
                        p.resetJointState(robot, j, float(q[i]), physicsClientId=cid)

        view = p.computeViewMatrix(cameraEyePosition=[1.75, 1.0, 1.25],
                                   cameraTargetPosition=[0.3, 0.0, 0.3],
                                   cameraUpVector=[0, 0, 1], physicsClientId=cid)  # fmt: skip
        proj = p.computeProjectionMatrixFOV(fov=45, aspect=width / height, nearVal=0.05,
                                            farVal=5.0, physicsClientId=cid)  # fmt: skip

        labels = [(name, _project(view, proj, xyz, width, height)) for name, xyz in marks]

        def snap() -> Any:
            img = p.getCameraImage(width, height, view, proj, renderer=p.ER_TINY_RENDERER,
                                   physicsClientId=cid)  # fmt: skip
            rgba = np.reshape(np.asarray(img[2], dtype=np.uint8), (height, width, 4))
            return _annotate(Image.fromarray(rgba[:, :, :3]), title, legend, labels)

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
