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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

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
            # the same for a board an arm reaches over: down to half its length and width
            a, b = size[0], size[1]
            size[0], size[1] = 0.8 * a, 0.8 * b
            tol = [0.3 * a, 0.3 * b, 0.015]
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
        detections = [self._complete(d, frame) for d in detections]
        t2 = time.perf_counter()
        report = self.anchoring.update(detections, now)
        t3 = time.perf_counter()
        upd = PerceptionUpdate(
            report,
            detections,
            t1 - t0,
            t2 - t1,
            t3 - t2,
            frame if (rgb or self.keep_frames) else None,
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

    def _complete(self, det: DetectedObject, frame: Frame) -> DetectedObject:
        """A lying cylinder seen shorter than the parts of its type are, with one end at the
        robot's own body: that end is hidden behind the arm, so the centre lies farther that
        way (the known length from the visible end), not at the middle of what is seen."""
        if det.primitive != "cylinder" or det.type == "unknown" or abs(det.axis[2]) > 0.5:
            return det
        known = [
            max(float(v) for v in o.size.values())
            for o in self.kb.objects.values()
            if o.size and self.kb.compatible(o.type, det.type)
        ]
        if not known:
            return det
        length, seen = max(known), float(det.size[0])
        if seen >= 0.9 * length:
            return det
        axis = np.asarray(det.axis, dtype=float)
        axis = axis / (np.linalg.norm(axis) or 1.0)
        ends = [det.position + axis * seen / 2, det.position - axis * seen / 2]
        hidden = [frame.near_robot(e) for e in ends]
        if hidden[0] == hidden[1]:
            return det  # both or neither: no better guess
        toward = axis if hidden[0] else -axis
        visible_end = ends[1] if hidden[0] else ends[0]
        centre = visible_end + toward * length / 2
        size = np.array([length, *det.size[1:]])
        return replace(det, position=centre, size=size)

    def close(self) -> None:
        self.camera.close()


__all__ = ["PerceptionComponent", "PerceptionStats", "PerceptionUpdate", "rules_for"]
