"""Depth image → point cloud and rigid transforms (numpy only)."""

from __future__ import annotations

import numpy as np

from flexhrc.perception.scene.types import CameraIntrinsics


def depth_to_cloud(
    depth: np.ndarray,
    intrinsics: CameraIntrinsics,
    extrinsics: np.ndarray | None = None,
    max_depth: float = np.inf,
) -> np.ndarray:
    """Back-project a depth image (m, z along the optical axis; 0/NaN = no return).

    Pinhole model: ``x = (u - cx) z / fx``, ``y = (v - cy) z / fy``. With ``extrinsics`` (4×4
    camera-to-world transform) the points are returned in the world frame.
    """
    depth = np.asarray(depth, dtype=float)
    if depth.shape != (intrinsics.height, intrinsics.width):
        raise ValueError(
            f"depth image is {depth.shape[1]}x{depth.shape[0]} but the intrinsics say "
            f"{intrinsics.width}x{intrinsics.height}"
        )
    valid = np.isfinite(depth) & (depth > 0) & (depth < max_depth)
    v, u = np.nonzero(valid)
    z = depth[v, u]
    pts = np.column_stack(
        [(u - intrinsics.cx) * z / intrinsics.fx, (v - intrinsics.cy) * z / intrinsics.fy, z]
    )
    return transform(pts, extrinsics) if extrinsics is not None else pts


def transform(points: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Apply a 4×4 homogeneous transform to ``(n, 3)`` points."""
    T = np.asarray(T, dtype=float)
    if T.shape != (4, 4):
        raise ValueError(f"expected a 4x4 transform, got {T.shape}")
    return points @ T[:3, :3].T + T[:3, 3]
