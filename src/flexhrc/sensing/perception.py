"""The perception component: head camera -> scene pipeline -> anchoring in the knowledge base.

:class:`PerceptionComponent` is what the cell's perception does at every "update workspace" of
paper 000 (at the start and after every action that changes the world): render the simulated
workspace as the head camera sees it (:class:`~flexhrc.sensing.camera.HeadCamera`, the arms in
their current posture), run the scene pipeline (:class:`~flexhrc.perception.scene.
ScenePerception`: plane, clusters, primitives, types by rules), and anchor the percepts to the
knowledge base's symbols (:class:`~flexhrc.perception.scene.anchoring.Anchoring`). The
classification rules come from the parts themselves (one rule per type, its size with a
tolerance that lets a leg half hidden by an arm still count as a leg).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from flexhrc.knowledge import KnowledgeBase, ObjectRecord
from flexhrc.perception.scene import RuleSet, ScenePerception
from flexhrc.perception.scene.anchoring import Anchoring, AnchoringReport
from flexhrc.perception.scene.types import DetectedObject
from flexhrc.sensing.camera import Frame, HeadCamera
from flexhrc.sensing.world import SimulatedWorkspace


def rules_for(world: SimulatedWorkspace) -> RuleSet:
    """Classification rules for the workspace's part types (size +- a tolerance)."""
    seen: dict[str, dict[str, Any]] = {}
    for part in world.parts.values():
        if part.type in seen:
            continue
        size = list(part.extents)
        if part.shape == "cylinder":
            # an arm may hide part of a leg: lengths from half to 1.1 times its own count
            length = size[0]
            size[0], tol = 0.8 * length, [0.3 * length, 0.015, 0.015]
            primitive = "cylinder"
        else:
            tol = [max(0.15 * size[0], 0.03), max(0.15 * size[1], 0.03), 0.015]
            primitive = "box"
        seen[part.type] = {"type": part.type, "primitive": primitive, "size": size,
                           "tolerance": tol}  # fmt: skip
    return RuleSet.from_data(list(seen.values()), "<workspace rules>")


@dataclass
class PerceptionUpdate:
    """One update: the frame's detections, what anchoring did, and the time it took."""

    report: AnchoringReport
    detections: list[DetectedObject]
    render_s: float
    pipeline_s: float
    anchoring_s: float
    frame: Frame | None = None

    @property
    def total_s(self) -> float:
        return self.render_s + self.pipeline_s + self.anchoring_s

    def to_dict(self) -> dict[str, Any]:
        return {
            **self.report.to_dict(),
            "detections": len(self.detections),
            "ms": round(1000 * self.total_s, 2),
        }


@dataclass
class PerceptionStats:
    """Figures of a run (the ``perception`` key of a run's JSON)."""

    frames: int = 0
    anchored: set[str] = field(default_factory=set)
    new_objects: list[str] = field(default_factory=list)
    missing: list[str] = field(default_factory=list)
    moved: int = 0
    inconsistencies: int = 0
    cleared: int = 0
    repaired: int = 0
    times_s: list[float] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "frames": self.frames,
            "anchored": len(self.anchored),
            "symbols": sorted(self.anchored),
            "new_objects": list(self.new_objects),
            "missing": sorted(set(self.missing)),
            "moved": self.moved,
            "inconsistencies": self.inconsistencies,
            "cleared": self.cleared,
            "repaired": self.repaired,
            "update_ms_median": round(1000 * statistics.median(self.times_s), 2)
            if self.times_s
            else None,
            "compute_s": round(sum(self.times_s), 4),
        }


class PerceptionComponent:
    """Renders, perceives and anchors (see the module docstring)."""

    def __init__(
        self,
        world: SimulatedWorkspace,
        kb: KnowledgeBase,
        *,
        camera: HeadCamera | None = None,
        pipeline: ScenePerception | None = None,
        rules: RuleSet | None = None,
        robot_q: Callable[[], Mapping[str, Any] | None] | None = None,
        on_new: Callable[[ObjectRecord], None] | None = None,
        anchoring: Mapping[str, Any] | None = None,
        keep_frames: bool = False,
    ):
        self.world = world
        self.kb = kb
        self.rules = rules or rules_for(world)
        self.camera = camera or HeadCamera()
        self.pipeline = pipeline or ScenePerception(
            rules=self.rules, split_stacked=True, any_fit=True
        )
        self.anchoring = Anchoring(kb, self.rules.types, on_new=on_new, **dict(anchoring or {}))
        self.robot_q = robot_q or (lambda: None)
        self.stats = PerceptionStats()
        self.keep_frames = keep_frames
        self.last: PerceptionUpdate | None = None

    def update(self, now: float, *, rgb: bool = False) -> PerceptionUpdate:
        """One perception update at simulated time ``now``."""
        t0 = time.perf_counter()
        frame = self.camera.render(self.world, self.robot_q(), rgb=rgb)
        t1 = time.perf_counter()
        detections = self.pipeline.process_depth(frame.depth, frame.intrinsics, frame.extrinsics)
        t2 = time.perf_counter()
        report = self.anchoring.update(detections, now)
        t3 = time.perf_counter()
        upd = PerceptionUpdate(
            report, detections, t1 - t0, t2 - t1, t3 - t2, frame if (rgb or self.keep_frames) else None
        )
        s = self.stats
        s.frames += 1
        s.anchored.update(report.anchored)
        s.new_objects += report.new_objects
        s.missing += report.missing
        s.moved += len(report.moved)
        s.inconsistencies += len(report.inconsistencies)
        s.cleared += len(report.cleared)
        s.times_s.append(upd.total_s)
        self.last = upd
        return upd

    def close(self) -> None:
        self.camera.close()


def perceivable_types(world: SimulatedWorkspace) -> Iterable[str]:
    return sorted({p.type for p in world.parts.values()})


__all__ = ["PerceptionComponent", "PerceptionStats", "PerceptionUpdate", "rules_for"]
