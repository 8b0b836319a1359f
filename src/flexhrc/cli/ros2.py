"""``flexhrc ros2 cell|arm|human``: a cell's nodes on ROS 2 (the ``ros2`` extra).

Examples (one shell each; ``export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``)::

    flexhrc ros2 cell table_assembly --realtime 1
    flexhrc ros2 arm table_assembly --arm left
    flexhrc ros2 arm table_assembly --arm right

``flexhrc ros2 cell`` is ``flexhrc cell ... --agents external`` with the ROS 2 transport: the same
manager loop (:class:`flexhrc.cell.Cell`), the same event store and resume. Each command only
translates its arguments into a config of :mod:`flexhrc.ros2.serve` (the options are its fields),
calls :func:`~flexhrc.ros2.serve.serve_ros2_cell` (``_arm``, ``_human``) and prints the report.
rclpy is imported only when a command runs, so ``flexhrc --help`` works without the extra
(docs/ros2.md).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from flexhrc.cli.common import (
    TermFlag,
    add_cell_options,
    add_json_flag,
    add_seed_option,
    add_segments_option,
    config_of,
    emit,
    progress,
)


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", metavar="SCENARIO", help="table_assembly, or a scenario file")
    add_segments_option(p)
    p.add_argument(
        "--cell",
        default="default",
        metavar="NAME",
        help="cell name: topics live under /flexhrc/NAME/ (default 'default')",
    )
    p.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="ROS domain id 0..232 (default: $ROS_DOMAIN_ID, else 0)",
    )
    add_seed_option(p, "scenario seed (the same in every node)")
    p.add_argument("--quiet", action="store_true", help="no live trace")


def _cell_options(cell: argparse.ArgumentParser) -> None:
    add_cell_options(
        cell,
        wait_s=60.0,
        waits_for="the agent nodes",
        simulator_help="the Task Manager's branch simulator (default: the scenario's)",
    )
    cell.add_argument(
        "--markers-rate",
        type=float,
        default=2.0,
        metavar="HZ",
        help="MarkerArray rate for RViz (default 2 Hz)",
    )
    from flexhrc.cli.panel import add_web_options

    add_web_options(cell)  # the operator panel (docs/panel.md): the person at the page operates


def _human_options(human: argparse.ArgumentParser) -> None:
    human.add_argument("--name", required=True, metavar="NAME", help="which operator (e.g. human)")
    human.add_argument(
        "--profile",
        default="passive",
        metavar="PROFILE",
        help="passive (default), takeover, cooperative, random or reluctant (declines some "
        "requests, answers cannot to some actions); seeded by --seed",
    )


def _arm_options(arm: argparse.ArgumentParser) -> None:
    arm.add_argument("--arm", required=True, metavar="NAME", help="which arm (e.g. left)")
    arm.add_argument(
        "--rate", type=float, default=50.0, help="joint-state rate while moving, Hz (default 50)"
    )
    arm.add_argument(
        "--execute",
        choices=["sim", "external"],
        default="sim",
        help="sim: the kinematic simulator (default); external: a real arm via JointTrajectory",
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


def _progress(args: argparse.Namespace) -> Callable[[str], None] | None:
    return None if args.quiet else progress


def cmd_node(args: argparse.Namespace) -> int:
    """``ros2 arm`` and ``ros2 human``: one agent of the cell until it ends (or SIGTERM)."""
    from flexhrc.ros2 import serve

    nodes: dict[str, tuple[type, Callable[..., dict[str, Any]]]] = {
        "arm": (serve.Ros2ArmConfig, serve.serve_ros2_arm),
        "human": (serve.Ros2HumanConfig, serve.serve_ros2_human),
    }
    config_type, run = nodes[args.ros2_command]
    data = run(config_of(config_type, args), progress=_progress(args), until=TermFlag())
    if args.json:
        emit(args, data)
    return 0


def cmd_cell(args: argparse.Namespace) -> int:
    import flexhrc.planning.policies  # noqa: F401  (registers --policy lookahead)
    from flexhrc.cell.serve import summary_line
    from flexhrc.cli.panel import run_cell
    from flexhrc.ros2.serve import Ros2CellConfig, serve_ros2_cell

    config = config_of(Ros2CellConfig, args)

    def start(trace: Any, attach: list[Any], servers: list[Any]) -> dict[str, Any]:
        return serve_ros2_cell(config, trace=trace, progress=_progress(args), attach=attach)

    # the page stands in for the scenario's operators (their tokens)
    data = run_cell(args, start, operator=True)
    emit(args, data, lambda: summary_line(data, args.store))
    return 0 if data["outcome"] == "solved" else 1


#: The nodes: (name, options, command, help, description).
_NODES: tuple[tuple[str, Callable[[Any], None], Callable[[Any], int], str, str], ...] = (
    (
        "cell",
        _cell_options,
        cmd_cell,
        "the cell's manager as a ROS 2 node (waits for its agent nodes)",
        "The cell's manager (the loop of `flexhrc cell`, docs/cell.md) as a ROS 2 "
        "node. It waits for every agent of the scenario — `flexhrc ros2 arm` nodes, and an "
        "operator client — like `flexhrc cell --agents external`.",
    ),
    (
        "human",
        _human_options,
        cmd_node,
        "a simulated operator node: follows suggestions and, unless passive, acts alone",
        "The cell's simulated operator (`flexhrc agent human`) as a ROS 2 node: it "
        "carries out each suggestion on suggest/<name> and reports the human actions on human; "
        "with a profile other than passive it answers the options on options/<name> with "
        "intents on intent (reluctant: some requests with decline or cannot on human). It "
        "exits when the cell ends.",
    ),
    (
        "arm",
        _arm_options,
        cmd_node,
        "a simulated (or real) robot arm node",
        "A robot arm of the cell as a ROS 2 node: executes the manager's commands "
        "with the kinematic simulator (or on a real arm through JointTrajectory, --execute "
        "external), acknowledges them, and publishes its joint states, end-effector pose and "
        "planned trajectories. It exits when the cell ends.",
    ),
)


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "ros2",
        help="the cell as ROS 2 nodes (manager, arms) with standard messages",
        description="Run the parts of a cell as ROS 2 nodes. Protocol messages travel as JSON "
        "on std_msgs/String topics under /flexhrc/<cell>/; arms also publish "
        "sensor_msgs/JointState, geometry_msgs/PoseStamped and trajectory_msgs/JointTrajectory, "
        "the manager a visualization_msgs/MarkerArray (docs/ros2.md).",
    )
    sub = p.add_subparsers(dest="ros2_command", metavar="NODE", required=True)
    for name, options, command, help_, description in _NODES:
        node = sub.add_parser(name, help=help_, description=description)
        _add_common(node)
        options(node)
        add_json_flag(node)
        node.set_defaults(func=command)
