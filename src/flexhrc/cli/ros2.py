"""``flexhrc ros2``: the cell's manager and arms as ROS 2 nodes (the ``ros2`` extra).

Examples::

    flexhrc ros2 arm table_assembly --arm left --cell cell1
    flexhrc ros2 arm table_assembly --arm right --cell cell1 --realtime 2

rclpy is imported only when a command runs, so ``flexhrc --help`` works without the extra.
Environment: ``ROS_DOMAIN_ID`` (or ``--domain-id``) and, to keep discovery on this host,
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (see docs/ros2.md).
"""

from __future__ import annotations

import argparse
import math
import signal
import sys
from typing import Any

from flexhrc.errors import FlexhrcError


def _finite_nonneg(value: str) -> float:
    try:
        x = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {value!r}") from None
    if not math.isfinite(x) or x < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {value}")
    return x


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", metavar="SCENARIO", help="the scenario (built in: table_assembly)")
    p.add_argument(
        "--cell",
        default="cell",
        help="cell name: topics live under /flexhrc/<cell>/ (default: cell)",
    )
    p.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="ROS domain id 0..232 (default: $ROS_DOMAIN_ID, else 0)",
    )
    p.add_argument("--seed", type=int, default=0, help="scenario seed (default 0)")


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "ros2",
        help="the cell as ROS 2 nodes (manager, arms) with standard messages",
        description="Run parts of a cell as ROS 2 nodes. Protocol messages travel as JSON on "
        "std_msgs/String topics under /flexhrc/<cell>/; arms also publish sensor_msgs/JointState, "
        "geometry_msgs/PoseStamped and trajectory_msgs/JointTrajectory (docs/ros2.md).",
    )
    sub = p.add_subparsers(dest="ros2_command", metavar="NODE")
    p.set_defaults(func=lambda args: (p.print_help(sys.stderr), 2)[1])

    arm = sub.add_parser(
        "arm",
        help="a simulated (or real) robot arm node",
        description="A robot arm of the cell as a ROS 2 node: executes the manager's commands "
        "with the kinematic simulator (or on a real arm through JointTrajectory, --execute "
        "external), acknowledges them, and publishes its joint states and end-effector pose.",
    )
    _add_common(arm)
    arm.add_argument("--arm", required=True, help="which arm of the scenario (e.g. left)")
    arm.add_argument(
        "--realtime",
        type=_finite_nonneg,
        default=1.0,
        metavar="SPEED",
        help="play motions at SPEED x real time (default 1; 0: as fast as possible)",
    )
    arm.add_argument(
        "--rate", type=float, default=50.0, help="joint-state rate while moving, Hz (default 50)"
    )
    arm.add_argument(
        "--execute",
        choices=["sim", "external"],
        default="sim",
        help="sim: the kinematic simulator; external: a real arm via JointTrajectory",
    )
    arm.add_argument(
        "--trajectory-topic",
        help="(external) the controller's JointTrajectory topic, "
        "e.g. /joint_trajectory_controller/joint_trajectory",
    )
    arm.add_argument(
        "--joint-states-topic",
        help="(external) the real arm's JointState topic, e.g. /joint_states",
    )
    arm.add_argument(
        "--tolerance",
        type=float,
        default=0.01,
        help="(external) joint error in rad at which a motion is done (default 0.01)",
    )
    arm.set_defaults(func=cmd_arm)


def _transport(args: argparse.Namespace, node_name: str) -> Any:
    from flexhrc.ros2.transport import Ros2Transport, ros_topic

    ros_topic("flexhrc", args.cell)  # a cell name must be a valid ROS name part
    return Ros2Transport(
        prefix=f"flexhrc/{args.cell}", node_name=node_name, domain_id=args.domain_id
    )


class _Stop:
    """SIGTERM/SIGINT end the node's loop, so its token is withdrawn on the way out."""

    def __init__(self) -> None:
        self.requested = False
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, self._handle)

    def _handle(self, signum: int, frame: Any) -> None:
        self.requested = True

    def __call__(self) -> bool:
        return self.requested


def cmd_arm(args: argparse.Namespace) -> int:
    from flexhrc.ros2.arm import ArmNode
    from flexhrc.ros2.scenario import load_node_scenario
    from flexhrc.ros2.transport import ros_topic

    scenario = load_node_scenario(args.scenario, args.seed)
    ros_topic("", args.arm)
    if not (math.isfinite(args.rate) and 30 <= args.rate <= 1000):
        raise FlexhrcError(f"--rate must be between 30 and 1000 Hz, got {args.rate}")
    domain = scenario.domain()
    if args.arm not in domain.agents or domain.agents[args.arm].is_human:
        robots = [a.name for a in domain.agents.values() if not a.is_human]
        raise FlexhrcError(f"unknown arm {args.arm!r} (argument --arm); arms: {', '.join(robots)}")
    transport = _transport(args, f"flexhrc_{args.cell}_arm_{args.arm}")
    stop = _Stop()
    try:
        node = ArmNode(
            transport,
            args.arm,
            scenario.knowledge(),
            domain,
            realtime=args.realtime,
            rate_hz=args.rate,
            execute=args.execute,
            trajectory_topic=args.trajectory_topic,
            joint_states_topic=args.joint_states_topic,
            tolerance_rad=args.tolerance,
        )
        print(
            f"arm {args.arm} of cell {args.cell} on ROS domain {transport.domain_id}: "
            f"commands on {transport.ros_name('cmd/' + args.arm)}",
            file=sys.stderr,
            flush=True,
        )
        node.run(until=stop)
        node.close()
    finally:
        transport.close()
    return 0
