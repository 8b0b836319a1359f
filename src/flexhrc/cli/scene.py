"""``flexhrc scene`` — scene perception from depth images and point clouds.

flexhrc scene bench --scenes N --seed S --noise SIGMA_M [--json]
flexhrc scene generate -o FILE.npy [--seed S] [--noise SIGMA_M] [--depth]
flexhrc scene detect FILE.npy [--intrinsics fx,fy,cx,cy] [--rules RULES.yaml] [--json]
flexhrc scene frame -o FILE.png [--seed S] [--json]   # the head camera in the table assembly
"""

from __future__ import annotations

import argparse
import math

from flexhrc.cli.common import (
    add_json_flag,
    add_seed_option,
    check_outputs,
    emit,
    float_range,
    int_range,
    progress,
    seed_type,
)
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager.replay import plural

MAX_NOISE_M = 0.1  # beyond 10 cm of depth noise nothing on a table is recognisable


def _add_scene_options(p: argparse.ArgumentParser, scene: str, bound: str = "") -> None:
    p.add_argument("--seed", type=seed_type, default=0, help=f"seed of the {scene} (default 0)")
    p.add_argument(
        "--noise",
        type=float_range(0.0, MAX_NOISE_M),
        default=0.002,
        metavar="SIGMA_M",
        help=f"depth noise, standard deviation in metres (default 0.002{bound})",
    )


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "scene",
        help="scene perception: plane removal, clustering, RANSAC primitives, object types",
        description="Objects from depth images or point clouds (FlexHRC+ scene perception).",
    )
    sub = p.add_subparsers(dest="scene_command", metavar="ACTION")
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])

    b = sub.add_parser("bench", help="generate scenes, perceive them, score against the truth")
    b.add_argument(
        "--scenes",
        type=int_range(1, 100_000),
        default=50,
        help="number of scenes generated (default 50)",
    )
    _add_scene_options(b, "scenes", f", at most {MAX_NOISE_M:g}")
    b.add_argument(
        "--dropout",
        type=float_range(0.0, 1.0, hi_open=True),
        default=0.0,
        help="fraction of missing pixels, in [0, 1) (default 0)",
    )
    b.add_argument(
        "--width", type=int_range(16, 4096), default=400, help="depth image width (px, 400)"
    )
    b.add_argument(
        "--height", type=int_range(16, 4096), default=300, help="depth image height (px, 300)"
    )
    b.add_argument(
        "--renderer",
        choices=["raycast", "pybullet"],
        default="raycast",
        help="analytic ray casting (default) or pybullet's renderer (needs the sim extra)",
    )
    add_json_flag(b)
    b.set_defaults(func=_bench)

    g = sub.add_parser("generate", help="write a synthetic scene (point cloud or depth image)")
    g.add_argument("-o", "--output", required=True, metavar="FILE.npy", help="the file written")
    _add_scene_options(g, "scene")
    g.add_argument("--depth", action="store_true", help="write the depth image, not the cloud")
    add_json_flag(g)
    g.set_defaults(func=_generate)

    d = sub.add_parser("detect", help="detect and classify the objects of a cloud / depth image")
    d.add_argument("file", metavar="FILE.npy", help="(n, 3) point cloud or (H, W) depth image")
    d.add_argument("--intrinsics", metavar="fx,fy,cx,cy", help="needed for a depth image")
    d.add_argument("--rules", metavar="RULES.yaml", help="classification rules (default: table)")
    add_json_flag(d)
    d.set_defaults(func=_detect)

    f = sub.add_parser(
        "frame",
        help="the robot's head camera in the table assembly: one frame, its detections and "
        "the symbols they are anchored to, as a PNG (sim, perception and viz extras)",
    )
    f.add_argument(
        "-o", "--output", required=True, metavar="FILE.png", help="where to write the picture"
    )
    add_seed_option(f, "layout of the legs")
    add_json_flag(f)
    f.set_defaults(func=_frame)


def _bench(args: argparse.Namespace) -> int:
    from flexhrc.perception.scene.bench import run_bench

    try:
        res = run_bench(
            args.scenes,
            args.seed,
            args.noise,
            width=args.width,
            height=args.height,
            dropout=args.dropout,
            renderer=args.renderer,
            progress=progress,  # one line per scene, on stderr
        )
    except ValueError as exc:
        raise FlexhrcError(str(exc)) from None

    def text() -> str:
        return "\n".join(
            [
                f"{plural(int(res['scenes']), 'scene')} ({res['renderer']}), seed {res['seed']}, "
                f"noise {res['noise_m']} m, "
                f"{plural(int(res['objects']), 'object')}, {res['points_per_frame']} points/frame "
                "(median)",
                f"  detection_rate    {res['detection_rate']:.4f}",
                f"  position_error_m  {res['position_error_m']} (median)",
                f"  size_error_rel    {res['size_error_rel']} (median)",
                f"  type_accuracy     {res['type_accuracy']:.4f}",
                f"  false_positives   {res['false_positives']}",
                f"  frame_s           {res['frame_s']} (median; CPU {res['frame_cpu_s']})",
            ]
        )

    emit(args, res, text)
    return 0


def _generate(args: argparse.Namespace) -> int:
    from flexhrc.perception.scene.api import generate

    check_outputs([("-o", args.output, (".npy",))])
    data = generate(args.output, seed=args.seed, noise=args.noise, depth=args.depth)

    def text() -> str:
        head = f"wrote {args.output} {tuple(data['shape'])}; intrinsics "
        head += ",".join(f"{v:.2f}" for v in data["intrinsics"])
        rows = [f"  {o['type']:16s} at {o['position']} size {o['size']}" for o in data["objects"]]
        return "\n".join([head, *rows])

    emit(args, data, text)
    return 0


def _detect(args: argparse.Namespace) -> int:
    import numpy as np

    from flexhrc.perception.scene.api import detect

    intrinsics = None
    if args.intrinsics:
        try:
            fx, fy, cx, cy = (float(v) for v in args.intrinsics.split(","))
        except ValueError:
            raise FlexhrcError("--intrinsics: expected four numbers fx,fy,cx,cy") from None
        if not all(math.isfinite(v) for v in (fx, fy, cx, cy)):
            raise FlexhrcError(f"--intrinsics {args.intrinsics}: the numbers must be finite")
        if fx <= 0 or fy <= 0:
            raise FlexhrcError(
                f"--intrinsics {args.intrinsics}: focal lengths fx, fy must be > 0 (pixels)"
            )
        intrinsics = (fx, fy, cx, cy)
    data, objects = detect(args.file, intrinsics=intrinsics, rules=args.rules)

    def text() -> str:
        rows = [
            f"  {o.id:4s} {o.type:16s} {o.primitive:9s} at {np.round(o.position, 3).tolist()} "
            f"size {np.round(o.size, 3).tolist()} confidence {o.confidence:.2f}"
            for o in objects
        ]
        return "\n".join([plural(len(objects), "object"), *rows])

    emit(args, data, text)
    return 0


def _frame(args: argparse.Namespace) -> int:
    from flexhrc.files import check_output

    out = check_output(args.output, option="--output", suffixes=(".png",))
    try:
        from flexhrc.sensing.figure import picture_of_table
    except ImportError as exc:
        raise FlexhrcError(
            f"scene frame needs the sim and perception extras ({exc.name} is missing): "
            "pip install 'flexhrc[sim,perception,viz]'"
        ) from None
    report = picture_of_table(out, seed=args.seed)
    report["output"] = str(out)
    emit(
        args,
        report,
        lambda: (
            f"{report['detections']} detections, anchored: "
            + ", ".join(f"{s} <- {c}" for s, c in report["anchored"].items())
            + f" ({report['ms']} ms); picture: {out}"
        ),
    )
    return 0
