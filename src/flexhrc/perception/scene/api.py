"""What ``flexhrc scene generate | detect`` do, callable from Python (``scene bench`` is
:func:`flexhrc.perception.scene.bench.run_bench`).

Each function returns the document the command prints with ``--json``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.perception.scene.pipeline import ScenePerception
from flexhrc.perception.scene.types import CameraIntrinsics, DetectedObject


def generate(
    output: str | Path, *, seed: int = 0, noise: float = 0.002, depth: bool = False
) -> dict[str, Any]:
    """Write a synthetic table scene to ``output`` (.npy): its point cloud in the world frame,
    or with ``depth`` its depth image, with ``noise`` metres of depth noise. The report: the
    file, the array's shape, the camera and the true objects."""
    from flexhrc.files import atomic_output
    from flexhrc.perception.scene.cloud import depth_to_cloud
    from flexhrc.perception.scene.synthetic import generate_scene, render_depth

    rng = np.random.default_rng(seed)
    scene = generate_scene(rng)
    image = render_depth(scene, noise=noise, rng=rng)
    out = image if depth else depth_to_cloud(image, scene.intrinsics, scene.extrinsics)
    with atomic_output(output) as tmp, open(tmp, "wb") as fh:
        np.save(fh, out)
    i = scene.intrinsics
    return {
        "file": str(output),
        "shape": list(out.shape),
        "intrinsics": [i.fx, i.fy, i.cx, i.cy],
        "camera_to_world": scene.extrinsics.round(6).tolist(),
        "objects": [
            {
                "type": o.type,
                "position": o.center.round(4).tolist(),
                "size": o.size.round(4).tolist(),
            }
            for o in scene.objects
        ],
    }


def detect(
    file: str | Path,
    *,
    intrinsics: tuple[float, float, float, float] | None = None,
    rules: str | Path | None = None,
) -> tuple[dict[str, Any], list[DetectedObject]]:
    """The objects of ``file`` (.npy): an ``(n, 3)`` point cloud, or an ``(H, W)`` depth image
    taken with ``intrinsics`` (fx, fy, cx, cy; the cloud is then in the camera frame),
    classified by ``rules`` (a rules file; default: the table's). The report and the objects."""
    from flexhrc.perception._io import load_npy
    from flexhrc.perception.scene.classify import RuleSet

    path = Path(file)
    arr = load_npy(path)
    perception = ScenePerception(rules=RuleSet.load(rules) if rules else RuleSet.default())
    if not np.issubdtype(arr.dtype, np.number) or arr.dtype.kind == "c":
        raise FormatError(f"expected real numbers, got an array of {arr.dtype}", path)
    if arr.ndim == 2 and arr.size and not np.isfinite(arr).any():
        raise FormatError("no finite value: every point or pixel is NaN or infinite", path)
    if arr.ndim == 2 and arr.shape[1] == 3:
        if intrinsics is not None:
            raise FlexhrcError(f"--intrinsics goes with a depth image; {path} is a point cloud")
        objects = perception.process(arr)
    elif arr.ndim == 2:
        if intrinsics is None:
            raise FlexhrcError(f"{path}: a depth image needs --intrinsics fx,fy,cx,cy")
        intr = CameraIntrinsics(*intrinsics, arr.shape[1], arr.shape[0])
        # Without extrinsics the cloud is in the camera frame: "up" is towards the camera (-z).
        perception.up = (0.0, 0.0, -1.0)
        objects = perception.process_depth(arr, intr)
    else:
        raise FormatError(
            f"expected an (n, 3) cloud or an (H, W) depth image, got {arr.shape}", path
        )
    return {"file": str(path), "objects": [o.to_dict() for o in objects]}, objects
