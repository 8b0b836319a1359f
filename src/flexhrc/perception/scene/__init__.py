"""Scene perception from depth images and point clouds (paper 000, section III).

depth → cloud (:mod:`.cloud`) → support plane removed by RANSAC and Euclidean clusters
(:mod:`.segmentation`) → RANSAC primitive fits and PCA (:mod:`.primitives`) → object types by
rules as data (:mod:`.classify`) → identities across frames and the knowledge-base hook
(:mod:`.pipeline`, :mod:`.types`) → percepts anchored to symbols (:mod:`.anchoring`).
:mod:`.synthetic` generates and renders test scenes and
:mod:`.bench` measures the whole chain. Only numpy is imported here; SciPy when needed.
"""

from __future__ import annotations

from flexhrc.perception.scene.anchoring import Anchoring, AnchoringReport
from flexhrc.perception.scene.classify import ClassificationRule, RuleSet
from flexhrc.perception.scene.cloud import depth_to_cloud
from flexhrc.perception.scene.pipeline import ScenePerception, Tracker
from flexhrc.perception.scene.synthetic import Scene, SceneObject, generate_scene, render_depth
from flexhrc.perception.scene.types import (
    CameraIntrinsics,
    DetectedObject,
    ObjectSink,
    PrimitiveFit,
    publish_objects,
)

__all__ = [
    "Anchoring",
    "AnchoringReport",
    "CameraIntrinsics",
    "ClassificationRule",
    "DetectedObject",
    "ObjectSink",
    "PrimitiveFit",
    "RuleSet",
    "Scene",
    "SceneObject",
    "ScenePerception",
    "Tracker",
    "depth_to_cloud",
    "generate_scene",
    "publish_objects",
    "render_depth",
]
