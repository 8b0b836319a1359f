"""``flexhrc ros2 cell|arm``: the cell's manager and arms as ROS 2 nodes (the ``ros2`` extra).

Examples (one shell each; ``export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``)::

    flexhrc ros2 cell table_assembly --realtime 1
    flexhrc ros2 arm table_assembly --arm left
    flexhrc ros2 arm table_assembly --arm right

``flexhrc ros2 cell`` is ``flexhrc cell ... --agents external`` with the ROS 2 transport: the same
manager loop (:class:`flexhrc.cell.Cell`), the same event store and resume. rclpy is imported
only when a command runs, so ``flexhrc --help`` works without the extra (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
import uuid
from typing import Any

from flexhrc.cli.common import (
    add_cell_options,
    add_json_flag,
    add_segments_option,
    emit,
    serve_agent,
)
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager.replay import solved_by_line


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
    p.add_argument("--seed", type=int, default=0, help="scenario seed (the same in every node)")
    p.add_argument("--quiet", action="store_true", help="no live trace")


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

    cell = sub.add_parser(
        "cell",
        help="the cell's manager as a ROS 2 node (waits for its agent nodes)",
        description="The cell's manager (the loop of `flexhrc cell`, docs/cell.md) as a ROS 2 "
        "node. It waits for every agent of the scenario — `flexhrc ros2 arm` nodes, and an "
        "operator client — like `flexhrc cell --agents external`.",
    )
    _add_common(cell)
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
    add_json_flag(cell)
    cell.set_defaults(func=cmd_cell)

    human = sub.add_parser(
        "human",
        help="a simulated operator node: follows suggestions and, unless passive, acts alone",
        description="The cell's simulated operator (`flexhrc agent human`) as a ROS 2 node: it "
        "carries out each suggestion on suggest/<name> and reports the human actions on human; "
        "with a profile other than passive it answers the options on options/<name> with "
        "intents on intent. It exits when the cell ends.",
    )
    _add_common(human)
    human.add_argument("--name", required=True, metavar="NAME", help="which operator (e.g. human)")
    human.add_argument(
        "--profile",
        default="passive",
        metavar="PROFILE",
        help="passive (default), takeover, cooperative or random (seeded by --seed)",
    )
    add_json_flag(human)
    human.set_defaults(func=cmd_human)

    arm = sub.add_parser(
        "arm",
        help="a simulated (or real) robot arm node",
        description="A robot arm of the cell as a ROS 2 node: executes the manager's commands "
        "with the kinematic simulator (or on a real arm through JointTrajectory, --execute "
        "external), acknowledges them, and publishes its joint states, end-effector pose and "
        "planned trajectories. It exits when the cell ends.",
    )
    _add_common(arm)
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
    add_json_flag(arm)
    arm.set_defaults(func=cmd_arm)


def _transport(args: argparse.Namespace, role: str) -> Any:
    from flexhrc.ros2.transport import Ros2Transport, ros_topic

    ros_topic("flexhrc", args.cell)  # a cell name must be a valid ROS name part
    return Ros2Transport(
        prefix=f"flexhrc/{args.cell}",
        node_name=f"flexhrc_{args.cell}_{role}",
        domain_id=args.domain_id,
    )


def _progress(args: argparse.Namespace) -> Any:
    def progress(line: str) -> None:
        if not args.quiet:
            print(line, file=sys.stderr, flush=True)

    return progress


def cmd_arm(args: argparse.Namespace) -> int:
    from flexhrc.cell.components import check_agent_name
    from flexhrc.ros2.arm import ArmNode
    from flexhrc.ros2.transport import ros_topic
    from flexhrc.scenario import load_scenario

    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    ros_topic("", args.arm)
    if not (math.isfinite(args.rate) and 30 <= args.rate <= 1000):
        raise FlexhrcError(f"--rate must be between 30 and 1000 Hz, got {args.rate}")
    check_agent_name(scenario.domain, args.arm, "robot", "--arm")
    if args.execute == "external" and not (args.trajectory_topic and args.joint_states_topic):
        raise FlexhrcError(
            "--execute external needs --trajectory-topic and --joint-states-topic "
            "(the real arm's controller command and its joint states)"
        )
    progress = _progress(args)

    def say(line: str) -> None:
        progress(f"[{args.arm}] {line}")

    transport = _transport(args, f"arm_{args.arm}")
    node, outcome = serve_agent(
        lambda: ArmNode(
            args.arm,
            scenario,
            transport,
            rate_hz=args.rate,
            execute=args.execute,
            trajectory_topic=args.trajectory_topic,
            joint_states_topic=args.joint_states_topic,
            tolerance_rad=args.tolerance,
            trace=say,
        ),
        transport,
        say,
        f"ready: cell {args.cell!r}, ROS domain {transport.domain_id}, "
        f"commands on {transport.ros_name('cmd/' + args.arm)}",
    )
    data = {
        "agent": args.arm,
        "outcome": outcome,
        "received": node.received,
        "dropped": node.dropped,
        "executed": list(node.executed),
    }
    if args.json:
        emit(args, data)
    return 0


def cmd_human(args: argparse.Namespace) -> int:
    from flexhrc.cell import HumanAgent
    from flexhrc.cell.components import check_agent_name, check_profile
    from flexhrc.ros2.transport import ros_topic
    from flexhrc.scenario import load_scenario

    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    ros_topic("", args.name)
    check_agent_name(scenario.domain, args.name, "human", "--name")  # before the network
    check_profile(args.profile)
    progress = _progress(args)

    def say(line: str) -> None:
        progress(f"[{args.name}] {line}")

    transport = _transport(args, f"human_{args.name}")
    agent, outcome = serve_agent(
        lambda: HumanAgent(
            args.name, scenario, transport, profile=args.profile, seed=args.seed, trace=say
        ),
        transport,
        say,
        f"ready: cell {args.cell!r}, ROS domain {transport.domain_id}",
    )
    if args.json:
        emit(args, {"agent": args.name, "outcome": outcome, "received": agent.received,
                    "dropped": agent.dropped})  # fmt: skip
    return 0


def _target(cell: Any, cid: int) -> tuple[str, Any] | None:
    """Where command ``cid``'s arms are going: the last object its action names."""
    cmd = cell.commands.get(cid)
    if cmd is None:
        return None
    objs = [a for a in cmd.action.args if a in cell.kb.objects and a not in cmd.agents]
    return "+".join(cmd.agents), cell.kb.position(objs[-1]) if objs else None


def _mark(interfaces: Any, cell: Any, ev: dict[str, Any]) -> None:
    """A command's arrow from its start to its end (ack or stop) in the markers."""
    kind = ev.get("type")
    if kind == "command":
        where = _target(cell, int(ev["id"]))
        if where is not None:
            interfaces.command_started(int(ev["id"]), *where)
    elif kind in ("ack", "stop") and "id" in ev:
        interfaces.command_finished(int(ev["id"]))


def cmd_cell(args: argparse.Namespace) -> int:
    from flexhrc.cell import Cell, EventStore
    from flexhrc.cell import protocol as P
    from flexhrc.cell.components import execution_model
    from flexhrc.cell.serve import trace_line
    from flexhrc.ros2.extras import ManagerInterfaces
    from flexhrc.scenario import load_scenario

    if not (math.isfinite(args.wait) and args.wait > 0):
        raise FlexhrcError(f"--wait must be a positive number of seconds, got {args.wait}")
    if not (math.isfinite(args.markers_rate) and 0 < args.markers_rate <= 100):
        raise FlexhrcError(f"--markers-rate must be in (0, 100] Hz, got {args.markers_rate}")
    if args.resume and not args.store:
        raise FlexhrcError("--resume needs --store FILE.db")
    from flexhrc.cli.panel import check_web, serve

    web = check_web(args)  # a non-loopback --web without --token is refused before any work
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    progress = _progress(args)
    stream = sys.stderr if args.json else sys.stdout

    marks: list[Any] = []  # (interfaces, cell) once both exist

    def trace(ev: dict[str, Any]) -> None:
        if marks:
            _mark(marks[0], marks[1], ev)
        line = trace_line(ev)
        if line and not args.quiet:
            print(line, file=stream, flush=True)

    store = EventStore(args.store, resume=args.resume) if args.store else None
    transport: Any = None
    server: Any = None
    try:
        transport = _transport(args, "manager")
        cell = Cell(
            scenario,
            transport,
            store=store,
            resume=args.resume,
            realtime=args.realtime,
            agent_speed=args.realtime,
            simulator=execution_model(args.simulator, scenario),  # type: ignore[arg-type]
            liveliness=True,
            name=args.cell,
            trace=trace,
            seed=args.seed,
        )
        humans = [a.name for a in cell.domain.agents.values() if a.is_human]

        session = uuid.uuid4().hex[:8]  # percept ids stay unique across restarts and resumes
        counter = itertools.count(1)

        def percept(p: dict[str, Any]) -> None:
            # an object pose from ROS 2 perception enters the cell as its protocol's percept,
            # so it is stored and applied like any percept (docs/protocol.md)
            obj = cell.kb.objects.get(p["object"])
            message = P.message(
                "percept",
                id=f"ros2:{session}:{next(counter)}",
                object=p["object"],
                object_type=obj.type if obj is not None else "object",
                pose=[*p["position"], *p["orientation"]],
            )
            transport.publish(P.PERCEPT_TOPIC, message)

        def imu(who: str, sample: dict[str, Any]) -> None:
            transport.publish(f"imu/{who}", {"v": 1, "type": "imu", "agent": who, **sample})

        interfaces = ManagerInterfaces(
            transport,
            cell.kb,
            operators=humans,
            on_percept=percept,
            on_imu=imu,
            rate_hz=args.markers_rate,
            skip=cell.domain.agents,
        )
        marks.extend([interfaces, cell])

        panel: Any = None
        if web is not None:  # the page stands in for the scenario's operators (their tokens)
            from flexhrc.web.live import CellPanel

            panel = CellPanel(cell, operator=True)
            server = serve(web, args.token, panel)

        def pump(timeout: float) -> None:
            transport.wait(timeout)
            transport.flush()
            if panel is not None:
                panel.poll()
            interfaces.poll()

        progress(
            f"cell {args.cell!r} on ROS 2 (domain {transport.domain_id}): "
            f"topics under {transport.ros_name('state').rsplit('/', 1)[0]}/"
        )
        data = cell.run(pump=pump, agents_timeout=args.wait, progress=progress)
        for cid in list(interfaces.commands):  # the cell is over: no arrow stays
            interfaces.command_finished(cid)
        interfaces.publish_markers()
        if panel is not None:
            panel.close()
        cell.close()
        # (closing the transport waits until the end message is acknowledged)
    finally:
        if server is not None:
            server.stop(grace=0.3)  # the page gets the last state first
        if store is not None:
            store.close()
        if transport is not None:
            transport.close()

    def text() -> str:
        return (
            f"outcome {data['outcome']}"
            + (f" ({data['reason']})" if data["reason"] else "")
            + f"; {solved_by_line(data)}; {data['decisions']} decision trees; "
            f"{data['robot_actions']} robot and {data['human_actions']} human actions; "
            f"{data['cell']['events']} events"
            + (f" in {args.store}" if args.store else "")
            + (
                f"; {data['cell']['dropped']} malformed messages dropped"
                if data["cell"]["dropped"]
                else ""
            )
        )

    emit(args, data, text)
    return 0 if data["outcome"] == "solved" else 1
