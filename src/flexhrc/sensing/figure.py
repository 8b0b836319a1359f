"""A picture of one perception update: the head camera's frame and what was detected in it.

Left: the RGB image the head camera renders (the arms as they are), each detection's outline —
its fitted box, projected — and the symbol it was anchored to. Right: the depth image after the
self filter (the robot's own pixels removed), the input of the scene pipeline. Uses matplotlib
(the ``viz`` extra).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.errors import FlexhrcError, OptionalDependencyError
from flexhrc.perception.scene.types import DetectedObject
from flexhrc.sensing.camera import Frame


def _corners(det: DetectedObject) -> np.ndarray:
    """The 8 corners of a detection's oriented box (world frame)."""
    x = np.asarray(det.axis, dtype=float)
    up = np.array([0.0, 0.0, 1.0])
    if abs(x @ up) > 0.9:  # standing upright: the box's long side is vertical
        x, up = up, np.array([1.0, 0.0, 0.0])
    y = np.cross(up, x)
    y /= np.linalg.norm(y) or 1.0
    z = np.cross(x, y)
    size = np.asarray(det.size, dtype=float)
    half = size / 2
    out = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            for sz in (-1, 1):
                out.append(det.position + sx * half[0] * x + sy * half[1] * y + sz * half[2] * z)
    return np.array(out)


EDGES = [(0, 1), (0, 2), (1, 3), (2, 3), (4, 5), (4, 6), (5, 7), (6, 7), (0, 4), (1, 5), (2, 6),
         (3, 7)]  # fmt: skip


def draw_update(
    frame: Frame,
    detections: list[DetectedObject],
    anchored: dict[str, str],
    path: str | Path,
    *,
    title: str | None = None,
) -> Path:
    """Write the picture of one update to ``path`` (PNG)."""
    if frame.rgb is None:
        raise FlexhrcError("the frame has no RGB image: render it with rgb=True")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - only without the extra
        raise OptionalDependencyError(
            "drawing the perception picture", "viz", "matplotlib"
        ) from exc
    out = Path(path)
    symbol_of = {pid: sym for sym, pid in anchored.items()}
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    ax = axes[0]
    ax.imshow(frame.rgb)
    colours = {"unknown": "tab:red"}
    for det in detections:
        uv = frame.project(_corners(det))
        colour = colours.get(det.type, "tab:green" if det.id in symbol_of else "tab:orange")
        for a, b in EDGES:
            ax.plot(uv[[a, b], 0], uv[[a, b], 1], color=colour, lw=1.2)
        label = symbol_of.get(det.id, "?")
        upright = abs(det.axis[2]) > 0.9
        # labels beside small outlines, in the middle of large ones
        spot = uv.mean(axis=0) if det.size[1] > 0.1 else uv[np.argmax(uv[:, 0])] + (4, 0)
        ax.text(
            spot[0], spot[1], f"{label}{' (upright)' if upright else ''}\n{det.type}",
            color="white", fontsize=7, ha="center" if det.size[1] > 0.1 else "left",
            va="center",
            bbox={"facecolor": colour, "alpha": 0.8, "pad": 1, "edgecolor": "none"},
        )  # fmt: skip
    ax.set_title("head camera: detections, anchored to symbols", fontsize=9)
    ax.set_axis_off()
    ax = axes[1]
    depth = np.where(frame.depth > 0, frame.depth, np.nan)
    im = ax.imshow(depth, cmap="viridis")
    fig.colorbar(im, ax=ax, fraction=0.035, label="depth [m]")
    ax.set_title("depth after the self filter (robot pixels removed)", fontsize=9)
    ax.set_axis_off()
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    from flexhrc.files import atomic_output

    with atomic_output(out) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return out


def picture_of_table(path: str | Path, *, seed: int = 0, screwed: int = 1) -> dict[str, Any]:
    """Render the table assembly part-way (``screwed`` legs already fixed upright, an arm
    reaching out), perceive it and draw the picture; returns the update's report."""
    from flexhrc.action.robots import PANDA_Q_REST
    from flexhrc.scenario.builtin.table import TableLayout
    from flexhrc.sensing.loop import forget_positions, lying_layout
    from flexhrc.sensing.perception import PerceptionComponent
    from flexhrc.sensing.world import SimulatedWorkspace

    truth = TableLayout(seed=seed, leg_positions=lying_layout(4, seed)).world()
    world, names = SimulatedWorkspace.from_knowledge(truth, types=("leg", "tabletop"))
    kb = forget_positions(truth, ("leg", "tabletop"))
    comp = PerceptionComponent(world, kb)
    try:
        comp.update(0.0)
        for k in range(1, screwed + 1):
            leg = names[f"leg{k}"]
            world.grasp("left", world.part(leg).position)
            world.attach("left", truth.position(f"bolt_{k}"), on=names["tabletop"])
            sym = min(
                (s for s in names if s.startswith("leg")),
                key=lambda s: np.hypot(
                    *(np.subtract(kb.position(s)[:2], truth.position(f"leg{k}")[:2]))
                ),
            )
            kb.move(sym, truth.position(f"bolt_{k}"))
            kb.set_fixed(sym)
        q = list(PANDA_Q_REST)
        q[0], q[1] = -0.35, 0.2  # the right arm reaches out over the table
        comp.robot_q = lambda: {"left": PANDA_Q_REST, "right": q}
        upd = comp.update(1.0, rgb=True)
        assert upd.frame is not None
        draw_update(
            upd.frame,
            upd.detections,
            upd.report.anchored,
            path,
            title=f"table assembly, seed {seed}: {len(upd.detections)} detections, "
            f"{len(upd.report.anchored)} anchored, {1000 * upd.total_s:.0f} ms",
        )
        return upd.to_dict()
    finally:
        comp.close()


__all__ = ["draw_update", "picture_of_table"]
