"""Support-plane removal (RANSAC) and Euclidean clustering.

The support plane (the table the objects lie on) is the largest plane of the cloud: RANSAC
hypotheses (3 random points) are scored on a random subset of the points for speed, the best is
refined by least squares (SVD) on all its inliers. Objects are then the connected components of
the remaining points under a distance threshold (Euclidean clustering, as in FlexHRC+):
:func:`euclidean_clusters` with SciPy's k-d tree and sparse connected components, or the much
faster :func:`grid_clusters` (26-connected occupancy-grid cells, ``scipy.ndimage.label``) that
the pipeline uses.
"""

from __future__ import annotations

import numpy as np

from flexhrc.perception._deps import require


def fit_plane_lsq(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane ``n·x + d = 0`` (unit ``n``) through ``points``."""
    c = points.mean(axis=0)
    w, v = np.linalg.eigh(np.cov((points - c).T))  # 3x3 scatter: cheaper than an SVD of n x 3
    n = v[:, int(np.argmin(w))]
    return n, -float(n @ c)


def ransac_plane(
    points: np.ndarray,
    threshold: float = 0.01,
    iterations: int = 100,
    sample_size: int = 2000,
    rng: np.random.Generator | None = None,
) -> tuple[np.ndarray, float, np.ndarray]:
    """The dominant plane: ``(normal, d, inlier mask)`` with ``normal·x + d = 0``."""
    if len(points) < 3:
        raise ValueError(f"a plane needs at least 3 points, got {len(points)}")
    rng = rng if rng is not None else np.random.default_rng(0)
    sub = points[rng.choice(len(points), min(sample_size, len(points)), replace=False)]
    triples = rng.integers(0, len(sub), size=(iterations, 3))
    p0, p1, p2 = sub[triples[:, 0]], sub[triples[:, 1]], sub[triples[:, 2]]
    normals = np.cross(p1 - p0, p2 - p0)
    norms = np.linalg.norm(normals, axis=1)
    ok = norms > 1e-9
    normals = normals[ok] / norms[ok, None]
    ds = -np.einsum("ij,ij->i", normals, p0[ok])
    scores = (np.abs(sub @ normals.T + ds) < threshold).sum(axis=0)
    best = int(np.argmax(scores))
    n, d = normals[best], ds[best]
    inliers = np.abs(points @ n + d) < threshold
    n, d = fit_plane_lsq(points[inliers])
    inliers = np.abs(points @ n + d) < threshold
    return n, d, inliers


def grid_clusters(
    points: np.ndarray, cell: float, min_points: int = 1, max_cells: int = 20_000_000
) -> list[np.ndarray]:
    """Fast Euclidean clustering on an occupancy grid: points in 26-connected cells of size
    ``cell`` are one cluster. Points closer than ``cell`` always join; points farther than
    ``2√3 cell`` never do — the same objects as a k-d tree clustering whenever the gaps
    between objects exceed that. Falls back to :func:`euclidean_clusters` (radius ``2 cell``)
    when the grid would be too large (far outliers)."""
    if len(points) == 0:
        return []
    ndimage = require("scipy.ndimage", "scene perception")
    keys = np.floor(points / cell).astype(np.int64)
    keys -= keys.min(axis=0)
    dims = keys.max(axis=0) + 1
    if int(np.prod(dims)) > max_cells:
        return euclidean_clusters(points, 2 * cell, min_points)
    grid = np.zeros(tuple(dims), dtype=bool)
    grid[keys[:, 0], keys[:, 1], keys[:, 2]] = True
    labels, _ = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
    return _clusters(labels[keys[:, 0], keys[:, 1], keys[:, 2]] - 1, min_points)


def euclidean_clusters(points: np.ndarray, radius: float, min_points: int = 1) -> list[np.ndarray]:
    """Connected components of ``points`` linked by distance < ``radius`` (index arrays,
    largest first); components with fewer than ``min_points`` points are dropped."""
    if len(points) == 0:
        return []
    spatial = require("scipy.spatial", "scene perception")
    csgraph = require("scipy.sparse.csgraph", "scene perception")
    sparse = require("scipy.sparse", "scene perception")
    pairs = spatial.cKDTree(points).query_pairs(radius, output_type="ndarray")
    n = len(points)
    graph = sparse.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = csgraph.connected_components(graph, directed=False)
    return _clusters(labels, min_points)


def _clusters(labels: np.ndarray, min_points: int) -> list[np.ndarray]:
    """Point indices per label (labels 0..k-1), largest first, without those below
    ``min_points``."""
    order = np.argsort(labels, kind="stable")
    counts = np.bincount(labels)
    clusters = [c for c in np.split(order, np.cumsum(counts)[:-1]) if len(c) >= min_points]
    return sorted(clusters, key=len, reverse=True)
