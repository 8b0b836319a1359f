"""``flexhrc sim``: simulate one robot action with the kinematic task-priority controller.

Example::

    flexhrc sim transport --arm left --target 0.5 0.1 0.2 --json
    flexhrc sim approach --arm right --target 0.5 -0.1 0.05 --obstacle 0.5 -0.1 0.2 0.04
    flexhrc sim transport --arm both --from 0.5 0 0.1 --after approach --after grasp \
        --target 0.45 0.1 0.3 --view out.png

The robot starts at rest, or where ``--after ACTION`` (simulated first, at the same target)
leaves it. The simulator lives in the ``sim`` extra; it is imported only when the command runs.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from flexhrc.cli.common import add_json_flag, check_outputs, emit, float_range, needs
from flexhrc.errors import FlexhrcError

MIN_DT = 1e-3  # a finer step only costs time: the controller is converged at 1 ms
MAX_TIME_BUDGET = 600.0  # simulated seconds
MAX_STEPS = 200_000  # time budget / dt: bounds the time and memory of the trajectory


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "sim",
        help="simulate one robot action (kinematic task-priority controller)",
        description="Simulate one action of the dual-arm robot from rest (or after --after) and "
        "report success, reason, simulated duration, compute time and final error. Frame: origin "
        "at the centre of the robot base at table height, x forward, y left, z up (metres).",
    )
    p.add_argument(
        "action",
        metavar="ACTION",
        help="approach, grasp, transport, screw, ungrasp, rest, hand_over",
    )
    p.add_argument("--arm", default="left", help="left, right or both (default: left)")
    p.add_argument(
        "--target", nargs="+", metavar="X", help="target TCP position X Y Z in metres (world)"
    )
    p.add_argument(
        "--yaw",
        type=float_range(-2 * math.pi, 2 * math.pi),
        default=0.0,
        help="grasp yaw about the vertical (rad, within +-2 pi)",
    )
    p.add_argument(
        "--obstacle",
        nargs="+",
        action="append",
        default=[],
        metavar="V",
        help="obstacle 'X Y Z R' (sphere) or 'X Y Z HX HY HZ' (box); repeatable",
    )
    p.add_argument(
        "--human-hand", nargs="+", metavar="X", help="human hand position X Y Z (kept 15 cm away)"
    )
    p.add_argument(
        "--time-budget",
        type=float,
        default=10.0,
        help=f"simulated seconds before giving up (default 10, at most {MAX_TIME_BUDGET:g})",
    )
    p.add_argument(
        "--dt",
        type=float,
        default=0.02,
        help=f"control step in seconds (default 0.02; between {MIN_DT:g} and 0.1)",
    )
    p.add_argument(
        "--after",
        action="append",
        default=[],
        metavar="ACTION",
        help="simulate this action first (same arm, at --from or else --target) and start "
        "from its final state; repeatable, e.g. --after approach --after grasp",
    )
    p.add_argument(
        "--from",
        dest="from_",
        nargs="+",
        metavar="X",
        help="X Y Z target of the --after actions (e.g. where the object is picked)",
    )
    p.add_argument("--trajectory", action="store_true", help="include the trajectory in --json")
    p.add_argument(
        "--view",
        metavar="FILE",
        help="render the motion headless to FILE.png (last frame) or FILE.gif (animation), "
        "with a legend and labels",
    )
    add_json_flag(p)
    p.set_defaults(func=run)


def _floats(values: list[str] | None, what: str) -> list[float] | None:
    if values is None:
        return None
    try:
        return [float(v) for v in values]
    except ValueError:
        raise FlexhrcError(f"{what} must be numbers, got {' '.join(values)!r}") from None


def _pose(values: list[str] | None, option: str, yaw: float) -> Any:
    from flexhrc.action.simulator import Pose

    xyz = _floats(values, option)
    if xyz is None:
        return None
    if len(xyz) != 3:
        raise FlexhrcError(f"{option} must be 3 numbers X Y Z, got {len(xyz)}")
    return Pose.coerce({"position": xyz, "yaw": yaw}, option)


def run(args: argparse.Namespace) -> int:
    from flexhrc.action.api import simulate_action
    from flexhrc.action.control import parse_obstacle
    from flexhrc.action.simulator import Pose

    if not math.isfinite(args.time_budget) or not 0 < args.time_budget <= MAX_TIME_BUDGET:
        raise FlexhrcError(
            f"--time-budget must be positive and at most {MAX_TIME_BUDGET:g} s, "
            f"got {args.time_budget}"
        )
    if not math.isfinite(args.dt) or args.dt <= 0 or args.dt > 0.1:
        raise FlexhrcError(f"--dt must be in (0, 0.1] seconds, got {args.dt}")
    if args.dt < MIN_DT:
        raise FlexhrcError(f"--dt must be at least {MIN_DT:g} s, got {args.dt:g}")
    if args.time_budget / args.dt > MAX_STEPS:
        raise FlexhrcError(
            f"--time-budget {args.time_budget:g} s at --dt {args.dt:g} s is "
            f"{args.time_budget / args.dt:.0f} steps; at most {MAX_STEPS} (raise --dt)"
        )
    needs(args, "--from", args.from_ is not None, "--after", bool(args.after))
    needs(args, "--trajectory", args.trajectory, "--json", args.json)
    from flexhrc.action.view import VIEW_SUFFIXES

    check_outputs([("--view", args.view, VIEW_SUFFIXES)])
    target = _pose(args.target, "--target", args.yaw)
    obstacles = [
        parse_obstacle(_floats(o, "--obstacle"), f"--obstacle {i + 1}")
        for i, o in enumerate(args.obstacle)
    ]
    pick = _pose(args.from_, "--from", args.yaw)
    hand = None
    if args.human_hand is not None:
        hand = Pose.coerce(_floats(args.human_hand, "--human-hand"), "--human-hand").position
    data, out = simulate_action(
        args.action,
        args.arm,
        target,
        after=args.after,
        after_target=pick,
        obstacles=obstacles,
        human_hand=hand,
        dt=args.dt,
        time_budget_s=args.time_budget,
        trajectory=args.trajectory,
        view=args.view,
    )

    def text() -> str:
        lines = [
            f"{out.action} by {out.arm}: {'success' if out.success else 'FAILED'} — {out.reason}",
            f"  simulated duration {out.duration_s:.2f} s, compute {out.wall_s * 1e3:.1f} ms, "
            f"{out.steps} steps",
            f"  final error {out.final_error_m * 1e3:.3f} mm / {out.final_error_rad:.4f} rad, "
            f"energy {out.energy:.3f}"
            if math.isfinite(out.final_error_m)
            else "  not simulated: rejected before integrating",
        ]
        if data["min_distance_m"] is not None:
            lines.append(f"  closest distance to obstacles {out.min_distance_m:.3f} m")
        if args.view:
            lines.append(f"  view: {data['view']}")
        return "\n".join(lines)

    emit(args, data, text)
    return 0 if out.success else 1
