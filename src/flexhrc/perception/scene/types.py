"""Plain typed values of scene perception, and the hook to the knowledge base.

The perception pipeline outputs :class:`DetectedObject` values; :class:`ObjectSink` is the small
protocol the knowledge base implements to receive them (``update_object``), so this package does
not depend on the knowledge base and can be tested with a dict-backed fake.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics: focal lengths and principal point in pixels, image size."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        if self.fx <= 0 or self.fy <= 0:
            raise ValueError(f"focal lengths must be > 0, got fx={self.fx}, fy={self.fy}")
        if self.width < 1 or self.height < 1:
            raise ValueError(f"image size must be positive, got {self.width}x{self.height}")

    @classmethod
    def from_fov(cls, width: int, height: int, hfov_deg: float) -> CameraIntrinsics:
        f = width / 2 / np.tan(np.radians(hfov_deg) / 2)
        return cls(f, f, (width - 1) / 2, (height - 1) / 2, width, height)


@dataclass(frozen=True)
class PrimitiveFit:
    """A primitive shape fitted to a cluster (in the frame of the input cloud).

    ``kind`` is ``plane`` (a flat box), ``box``, ``cylinder``, ``sphere`` or ``cone``;
    ``size`` is sorted in decreasing order (cylinder: length, diameter, diameter; sphere: three
    diameters; box: its three edges; cone: height, base diameter, base diameter);
    ``axis`` the main axis (unit vector); ``inlier_ratio`` the fraction of the cluster's points
    within the fit tolerance of the surface.
    """

    kind: str
    center: np.ndarray
    axis: np.ndarray
    size: np.ndarray
    inlier_ratio: float
    params: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class DetectedObject:
    """An object perceived in the scene.

    ``position`` is the centre (m), ``axis`` the unit main axis (a leg's axis, a board's long
    side), ``orientation`` a quaternion ``(x, y, z, w)`` whose x-axis is ``axis`` and whose
    z-axis is the support plane normal, ``size`` the extents sorted in decreasing order (m).
    """

    id: str
    type: str
    position: np.ndarray
    orientation: np.ndarray
    axis: np.ndarray
    size: np.ndarray
    confidence: float
    primitive: str = "unknown"
    n_points: int = 0

    @property
    def pose(self) -> tuple[float, ...]:
        """``(x, y, z, qx, qy, qz, qw)``."""
        return tuple(float(v) for v in (*self.position, *self.orientation))

    def to_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "type": self.type,
            "position": [round(float(v), 4) for v in self.position],
            "orientation": [round(float(v), 4) for v in self.orientation],
            "axis": [round(float(v), 4) for v in self.axis],
            "size": [round(float(v), 4) for v in self.size],
            "confidence": round(float(self.confidence), 3),
            "primitive": self.primitive,
            "n_points": self.n_points,
        }


@runtime_checkable
class ObjectSink(Protocol):
    """What the knowledge base implements to receive perceived objects."""

    def update_object(
        self, obj_id: str, type: str, pose: tuple[float, ...], size: tuple[float, ...], **attrs: Any
    ) -> None: ...


def publish_objects(sink: ObjectSink, objects: list[DetectedObject]) -> int:
    """Send every object to ``sink`` (pose ``(x, y, z, qx, qy, qz, qw)``); returns the count."""
    for obj in objects:
        sink.update_object(
            obj.id,
            obj.type,
            obj.pose,
            tuple(float(s) for s in obj.size),
            confidence=float(obj.confidence),
            primitive=obj.primitive,
            axis=tuple(float(a) for a in obj.axis),
        )
    return len(objects)
