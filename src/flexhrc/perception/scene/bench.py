"""Benchmark of scene perception on generated scenes (``flexhrc scene bench``).

For each scene: generate, render a noisy depth image, back-project it, run the pipeline, and
match detections to the ground truth (optimal assignment on centre distance, within
``match_radius``). Reported over all scenes: ``detection_rate`` (matched / ground-truth
objects), ``position_error_m`` (median centre error of matched objects), ``size_error_rel``
(median of ``|size - true| / |true|`` on the sorted size vectors), ``type_accuracy`` (correct
type among matched objects), ``false_positives``, ``frame_s`` (median wall time of the
perception of one frame: back-projection + pipeline, not the rendering) and ``frame_cpu_s``
(the same in process CPU time, less sensitive to other jobs on a shared machine).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from flexhrc.perception._deps import require
from flexhrc.perception.scene.cloud import depth_to_cloud
from flexhrc.perception.scene.pipeline import ScenePerception
from flexhrc.perception.scene.synthetic import generate_scene, render_depth


def match(truth_pos: np.ndarray, det_pos: np.ndarray, radius: float) -> list[tuple[int, int]]:
    """Optimal one-to-one matching of ground truth to detections within ``radius``."""
    if len(truth_pos) == 0 or len(det_pos) == 0:
        return []
    optimize = require("scipy.optimize", "scene benchmark")
    cost = np.linalg.norm(truth_pos[:, None] - det_pos[None], axis=2)
    r, c = optimize.linear_sum_assignment(np.where(cost > radius, 1e6, cost))
    return [(int(i), int(j)) for i, j in zip(r, c, strict=True) if cost[i, j] <= radius]


def run_bench(
    n_scenes: int = 50,
    seed: int = 0,
    noise: float = 0.002,
    width: int = 400,
    height: int = 300,
    dropout: float = 0.0,
    match_radius: float = 0.05,
    perception: ScenePerception | None = None,
    progress: Callable[[str], None] | None = None,
    renderer: str = "raycast",
) -> dict[str, Any]:
    if n_scenes < 1:
        raise ValueError(f"--scenes must be >= 1, got {n_scenes}")
    if noise < 0:
        raise ValueError(f"--noise must be >= 0, got {noise}")
    if renderer not in ("raycast", "pybullet"):
        raise ValueError(f"--renderer must be raycast or pybullet, got {renderer!r}")
    rng = np.random.default_rng(seed)
    perception = perception or ScenePerception(seed=seed)
    # The pipeline's matrices are small: BLAS threads only add overhead (and spin against other
    # jobs on a shared machine), so the benchmark runs single-threaded, as a robot would budget.
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl comes with scikit-learn
        limits = contextlib.nullcontext()
    else:
        limits = threadpool_limits(1)
    with limits:
        n_truth = n_matched = n_type_ok = n_false = 0
        pos_err: list[float] = []
        size_err: list[float] = []
        frame_s: list[float] = []
        frame_cpu: list[float] = []
        n_points: list[int] = []
        for i in range(n_scenes):
            scene = generate_scene(rng, width=width, height=height)
            if renderer == "pybullet":
                from flexhrc.perception.scene.sim_render import render_depth_pybullet

                depth = render_depth_pybullet(scene, noise=noise, rng=rng)
                if dropout > 0:
                    depth[rng.random(depth.shape) < dropout] = 0.0
            else:
                depth = render_depth(scene, noise=noise, dropout=dropout, rng=rng)
            t0, c0 = time.perf_counter(), time.process_time()
            cloud = depth_to_cloud(depth, scene.intrinsics, scene.extrinsics)
            objs = perception.process(cloud)
            frame_s.append(time.perf_counter() - t0)
            frame_cpu.append(time.process_time() - c0)
            n_points.append(len(cloud))
            truth = np.array([o.center for o in scene.objects])
            det = np.array([o.position for o in objs]) if objs else np.empty((0, 3))
            pairs = match(truth, det, match_radius)
            n_truth += len(scene.objects)
            n_matched += len(pairs)
            n_false += len(objs) - len(pairs)
            for ti, di in pairs:
                t, o = scene.objects[ti], objs[di]
                pos_err.append(float(np.linalg.norm(t.center - o.position)))
                size_err.append(float(np.linalg.norm(t.size - o.size) / np.linalg.norm(t.size)))
                n_type_ok += t.type == o.type
            if progress:
                progress(f"scene {i + 1}/{n_scenes}: {len(pairs)}/{len(scene.objects)} matched")
    return {
        "scenes": n_scenes,
        "seed": seed,
        "noise_m": noise,
        "objects": n_truth,
        "points_per_frame": int(np.median(n_points)),
        "detection_rate": round(n_matched / n_truth, 4) if n_truth else 0.0,
        "position_error_m": round(float(np.median(pos_err)), 5) if pos_err else None,
        "size_error_rel": round(float(np.median(size_err)), 4) if size_err else None,
        "type_accuracy": round(n_type_ok / n_matched, 4) if n_matched else 0.0,
        "false_positives": n_false,
        "frame_s": round(float(np.median(frame_s)), 4),
        "frame_cpu_s": round(float(np.median(frame_cpu)), 4),
        "renderer": renderer,
    }
