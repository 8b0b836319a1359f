"""The scene perception pipeline of FlexHRC+ (paper 000, section III) and identity tracking.

depth image → point cloud → support plane removed (RANSAC) → Euclidean clusters → primitive
shapes fitted by RANSAC (box, cylinder, sphere, cone) → PCA axis and extents → typed objects
(rules as data) → persistent identities across frames (:class:`Tracker`) → knowledge base
(:func:`~flexhrc.perception.scene.types.publish_objects`).

Point-cloud library: numpy + SciPy (``ndimage.label``, ``cKDTree``, sparse graphs,
``least_squares``) already ship with the ``perception`` extra and process a 100k-point frame in
~55 ms, well under the 150 ms budget (see ``flexhrc scene bench``); open3d would add ~1.1 GB for
the same operations, and generic RANSAC packages (e.g. pyransac3d) fit cylinders far more slowly
than the PCA-axis + circle RANSAC used here, so neither earns its install size.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from flexhrc.perception._deps import require
from flexhrc.perception.scene.classify import RuleSet
from flexhrc.perception.scene.cloud import depth_to_cloud
from flexhrc.perception.scene.primitives import fit_box, fit_cone, fit_cylinder, fit_sphere
from flexhrc.perception.scene.segmentation import grid_clusters, ransac_plane
from flexhrc.perception.scene.types import CameraIntrinsics, DetectedObject, PrimitiveFit


def _quaternion(R: np.ndarray) -> np.ndarray:
    """Rotation matrix → quaternion ``(x, y, z, w)``."""
    tr = np.trace(R)
    if tr > 0:
        s = 2 * np.sqrt(tr + 1)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, s / 4]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * np.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
        q = [0.0, 0.0, 0.0, (R[k, j] - R[j, k]) / s]
        q[i] = s / 4
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
    qa = np.asarray(q, dtype=float)
    return qa / np.linalg.norm(qa)


def _perpendicular(n: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to ``n`` (horizontal when ``n`` is the vertical)."""
    x = np.cross(n, [0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.cross(n, [1.0, 0.0, 0.0])
    return x / np.linalg.norm(x)


def _mad_sigma(residuals: np.ndarray) -> float:
    if len(residuals) == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(residuals - np.median(residuals))))


@dataclass
class ScenePerception:
    """Configuration and entry points of the pipeline (all lengths in metres).

    ``up`` orients the support-plane normal (the side the objects are on); ``noise`` is the
    depth noise σ (m) — by default it is estimated on the support plane each frame, and the
    plane threshold, the height above the plane and the fit tolerance grow with it (they never
    go below the configured values); ``seed`` makes the RANSAC steps deterministic.

    ``split_stacked``: a cluster of no known type is tried as parts standing on a board (legs
    screwed upright into a tabletop touch it, so they cluster with it): the points above the
    board's top face — the most common height of the cluster — are clustered again on their
    own, the rest is the board; the pieces replace the cluster when one of them has a type.
    ``any_fit``: when the best-fitting primitive matches no rule, the next best that does is
    taken, if it explains at least half as many points (an upright leg seen from above is mostly
    its round cap, which a sphere fits best).
    """

    rules: RuleSet = field(default_factory=RuleSet.default)
    plane_threshold: float = 0.01
    min_height: float = 0.008
    cluster_radius: float = 0.02
    min_cluster_points: int = 40
    fit_tol: float = 0.005
    max_fit_points: int = 500
    primitives: tuple[str, ...] = ("box", "cylinder", "sphere", "cone")
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    noise: float | None = None
    seed: int = 0
    split_stacked: bool = False
    any_fit: bool = False

    def __post_init__(self) -> None:
        for name in ("plane_threshold", "cluster_radius", "fit_tol"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        unknown = set(self.primitives) - {"box", "cylinder", "sphere", "cone"}
        if unknown:
            raise ValueError(f"unknown primitives {sorted(unknown)}")

    # ------------------------------------------------------------------------ entry points
    def process_depth(
        self,
        depth: np.ndarray,
        intrinsics: CameraIntrinsics,
        extrinsics: np.ndarray | None = None,
    ) -> list[DetectedObject]:
        """Objects in a depth image (world frame when ``extrinsics`` is given)."""
        return self.process(depth_to_cloud(depth, intrinsics, extrinsics))

    def process(self, points: np.ndarray) -> list[DetectedObject]:
        """Objects in a point cloud ``(n, 3)``; ids are per frame (``c0``, ``c1``...)."""
        points = np.asarray(points, dtype=float)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f"expected an (n, 3) point cloud, got {points.shape}")
        points = points[np.isfinite(points).all(axis=1)]
        if len(points) < 100:
            return []
        rng = np.random.default_rng(self.seed)
        n, d, inliers = ransac_plane(points, self.plane_threshold, rng=rng)
        # Sensor noise, from the spread of the support plane (robust MAD). With noisier data
        # every threshold widens with it, so the plane's noise does not become "objects".
        sigma = self.noise if self.noise is not None else _mad_sigma(points[inliers] @ n + d)
        if 3.5 * sigma > self.plane_threshold:
            n, d, inliers = ransac_plane(points, 3.5 * sigma, rng=rng)
        min_height = max(self.min_height, 4.0 * sigma)
        fit_tol = max(self.fit_tol, 2.5 * sigma)
        up = np.asarray(self.up, dtype=float)
        if n @ up < 0:
            n, d = -n, -d
        height = points @ n + d
        objects_pts = points[height > min_height]
        # Support frame: z along the plane normal, origin on the plane below the centroid.
        ex = _perpendicular(n)
        ey = np.cross(n, ex)
        R = np.column_stack([ex, ey, n])
        origin = -d * n
        local = (objects_pts - origin) @ R
        groups = grid_clusters(local, self.cluster_radius / 2)
        out: list[DetectedObject] = []

        def detect(idx: np.ndarray, name: str) -> DetectedObject:
            pts = local[idx]
            if len(pts) > self.max_fit_points:
                pts = pts[rng.choice(len(pts), self.max_fit_points, replace=False)]
            fits = self.fit_primitives(pts, rng, fit_tol)
            fit = fits[0]
            obj_type, err = self.rules.classify(fit.kind, fit.size)
            if obj_type == "unknown" and self.any_fit:
                if "cylinder" in self.primitives:  # standing upright: the normal is its axis
                    up_axis = np.array([0.0, 0.0, 1.0])
                    fits.append(fit_cylinder(pts, fit_tol, rng=rng, axis=up_axis, grounded=True))
                for other in fits[1:]:
                    t, e = self.rules.classify(other.kind, other.size)
                    if t != "unknown" and other.inlier_ratio >= 0.5 * fit.inlier_ratio:
                        fit, obj_type, err = other, t, e
                        break
            conf = fit.inlier_ratio * (1.0 - 0.5 * min(err, 1.0)) if np.isfinite(err) else 0.0
            axis = R @ fit.axis
            return DetectedObject(
                id=name,
                type=obj_type,
                position=origin + R @ fit.center,
                orientation=self._orientation(axis, n),
                axis=axis,
                size=fit.size,
                confidence=float(conf),
                primitive=fit.kind,
                n_points=len(idx),
            )

        for k, idx in enumerate(groups):
            if len(idx) < self.min_cluster_points:
                continue
            det = detect(idx, f"c{k}")
            if det.type == "unknown" and self.split_stacked:
                pieces = [
                    detect(part, f"c{k}.{j}")
                    for j, part in enumerate(self._stacked(local, idx, fit_tol))
                ]
                if any(p.type != "unknown" for p in pieces):
                    out.extend(pieces)
                    continue
            out.append(det)
        return out

    def _stacked(self, local: np.ndarray, idx: np.ndarray, tol: float) -> list[np.ndarray]:
        """Split a cluster into the board (up to its top face) and what stands on it."""
        z = local[idx, 2]
        bins = np.arange(z.min(), z.max() + 0.01, 0.005)
        if len(bins) < 3:
            return []
        counts, edges = np.histogram(z, bins=bins)
        top = edges[int(np.argmax(counts)) + 1]
        upper = z > top + max(2 * tol, 0.01)
        if upper.sum() < self.min_cluster_points or (~upper).sum() < self.min_cluster_points:
            return []
        up_idx = idx[upper]
        pieces = [
            up_idx[g]
            for g in grid_clusters(local[up_idx], self.cluster_radius / 2)
            if len(g) >= self.min_cluster_points
        ]
        return [idx[~upper], *pieces]

    # ---------------------------------------------------------------------------- helpers
    def fit_primitives(
        self, pts: np.ndarray, rng: np.random.Generator, tol: float | None = None
    ) -> list[PrimitiveFit]:
        """Every primitive fitted to a cluster in the support frame, best (highest inlier
        ratio) first.

        A box explains any compact cluster a little, so a curved primitive wins ties: it is
        preferred when its inlier ratio is within 0.05 of the box's.
        """
        fits: list[PrimitiveFit] = []
        tol = self.fit_tol if tol is None else tol
        if "box" in self.primitives:
            fits.append(fit_box(pts, tol))
        if "cylinder" in self.primitives:
            fits.append(fit_cylinder(pts, tol, rng=rng))
        if "sphere" in self.primitives:
            fits.append(fit_sphere(pts, tol, rng=rng))
        if "cone" in self.primitives:
            fits.append(fit_cone(pts, tol, rng=rng))
        bonus = {"box": 0.0, "cylinder": 0.05, "sphere": 0.05, "cone": 0.05}
        return sorted(fits, key=lambda f: -(f.inlier_ratio + bonus[f.kind]))

    @staticmethod
    def _orientation(axis: np.ndarray, normal: np.ndarray) -> np.ndarray:
        x = axis - (axis @ normal) * normal
        # a vertical axis (sphere, cone) gives no x: any horizontal one
        x = _perpendicular(normal) if np.linalg.norm(x) < 1e-6 else x / np.linalg.norm(x)
        z = normal / np.linalg.norm(normal)
        y = np.cross(z, x)
        return _quaternion(np.column_stack([x, y, z]))


@dataclass(eq=False)
class Tracker:
    """Persistent identities across frames: optimal assignment of detections to tracks.

    The cost of pairing a detection with a track is their distance, plus ``type_penalty`` when
    the types differ; pairs farther than ``max_distance`` are never made. Unmatched detections
    open new tracks (``<prefix>_<n>``); a track unseen for more than ``max_missed`` frames ends.
    """

    max_distance: float = 0.05
    max_missed: int = 3
    type_penalty: float = 0.03
    prefix: str = "obj"
    _tracks: dict[str, tuple[DetectedObject, int]] = field(
        default_factory=dict, init=False, repr=False
    )
    _next: int = field(default=1, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.max_distance <= 0:
            raise ValueError(f"max_distance must be > 0, got {self.max_distance}")

    @property
    def tracks(self) -> dict[str, DetectedObject]:
        return {k: v[0] for k, v in self._tracks.items()}

    def update(self, detections: list[DetectedObject]) -> list[DetectedObject]:
        """Give each detection its persistent id; returns the detections re-labelled."""
        ids = list(self._tracks)
        assigned: dict[int, str] = {}
        if ids and detections:
            optimize = require("scipy.optimize", "object tracking")
            prev = np.array([self._tracks[i][0].position for i in ids])
            cur = np.array([d.position for d in detections])
            cost = np.linalg.norm(cur[:, None] - prev[None], axis=2)
            types_differ = np.array(
                [[d.type != self._tracks[i][0].type for i in ids] for d in detections]
            )
            cost = cost + self.type_penalty * types_differ
            big = 1e6
            cost = np.where(cost > self.max_distance, big, cost)
            rows, cols = optimize.linear_sum_assignment(cost)
            for r, c in zip(rows, cols, strict=True):
                if cost[r, c] < big:
                    assigned[int(r)] = ids[int(c)]
        out: list[DetectedObject] = []
        seen = set()
        for k, det in enumerate(detections):
            tid = assigned.get(k)
            if tid is None:
                tid = f"{self.prefix}_{self._next}"
                self._next += 1
            obj = replace(det, id=tid)
            self._tracks[tid] = (obj, 0)
            seen.add(tid)
            out.append(obj)
        for tid in list(self._tracks):
            if tid not in seen:
                obj, missed = self._tracks[tid]
                if missed + 1 > self.max_missed:
                    del self._tracks[tid]
                else:
                    self._tracks[tid] = (obj, missed + 1)
        return out
