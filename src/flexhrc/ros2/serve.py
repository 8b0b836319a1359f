"""The nodes of a ROS 2 cell from Python: ``flexhrc ros2 cell|arm|human`` as functions.

Each command is a config in and a report out; the command only translates its options into the
config (the fields are the options, under the same names and defaults) and prints the report:

* :class:`Ros2CellConfig` -> :func:`serve_ros2_cell`: the cell's manager — the one loop,
  :class:`flexhrc.cell.Cell`, on a :class:`~flexhrc.ros2.transport.Ros2Transport`, with the
  markers for RViz, object poses and wrist IMU readings in
  (:class:`~flexhrc.ros2.extras.ManagerInterfaces`); returns the cell's summary;
* :class:`Ros2ArmConfig` -> :func:`serve_ros2_arm`: one robot arm
  (:class:`~flexhrc.ros2.arm.ArmNode`);
* :class:`Ros2HumanConfig` -> :func:`serve_ros2_human`: a simulated operator
  (:class:`flexhrc.cell.HumanAgent`).

A config checks its fields when it is made; the names of the cell and of the agent are checked
against ROS 2 and the scenario before a node joins the network. Bad input is one
:class:`~flexhrc.errors.FlexhrcError` naming the command's option (``--rate``, ``--arm``, ...).
``rclpy`` is imported only when a function runs.
"""

from __future__ import annotations

import itertools
import math
import uuid
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError

Progress = Callable[[str], None]

__all__ = [
    "Ros2ArmConfig",
    "Ros2CellConfig",
    "Ros2HumanConfig",
    "Ros2NodeConfig",
    "serve_ros2_arm",
    "serve_ros2_cell",
    "serve_ros2_human",
]


@dataclass(frozen=True)
class Ros2NodeConfig:
    """What every node of one cell is given alike.

    ``scenario`` is a name or a file, as every command takes it
    (:func:`flexhrc.scenario.load_scenario` with ``seed`` and ``segments``), or a scenario
    already loaded; every node of a cell runs the same one. The cell's topics live under
    ``/flexhrc/<cell>/`` (``cell`` is a ROS name part: letters, digits, ``_``); ``domain_id`` is
    the ROS domain, 0..232 (None: ``$ROS_DOMAIN_ID``, else 0).
    """

    scenario: str | Path | Any
    segments: str | None = None
    cell: str = "default"
    domain_id: int | None = None
    seed: int = 0


@dataclass(frozen=True)
class Ros2CellConfig(Ros2NodeConfig):
    """``flexhrc ros2 cell``: the cell's manager.

    ``store`` keeps every event in a SQLite file, ``resume`` continues the cooperation kept
    there. ``realtime`` 0 runs as fast as the agents answer; ``SPEED > 0`` makes actions take
    their simulated time divided by SPEED. ``simulator`` is the Task Manager's branch simulator
    (``auto``: the scenario's); ``on_failure`` ``retry`` or ``paper`` (None: the scenario's
    ``on_failure``, else ``retry``); ``policy`` ``paper`` or ``lookahead`` (None: the scenario's
    ``policy``, else ``paper``); ``wait`` how long (s) to wait for the agent nodes to appear;
    ``markers_rate`` the rate of the ``MarkerArray`` (Hz).
    """

    store: str | Path | None = None
    resume: bool = False
    realtime: float = 0.0
    simulator: str = "auto"
    on_failure: str | None = None
    answer_timeout: float | None = None
    policy: str | None = None
    wait: float = 60.0
    markers_rate: float = 2.0

    def __post_init__(self) -> None:
        from flexhrc.cell.serve import check_manager_options

        check_manager_options(self)
        if not (math.isfinite(self.markers_rate) and 0 < self.markers_rate <= 100):
            raise FlexhrcError(f"--markers-rate must be in (0, 100] Hz, got {self.markers_rate}")
        if self.resume and not self.store:
            raise FlexhrcError("--resume needs --store FILE.db")


@dataclass(frozen=True)
class Ros2ArmConfig(Ros2NodeConfig):
    """``flexhrc ros2 arm``: the robot ``arm`` of the scenario (see
    :class:`~flexhrc.ros2.arm.ArmNode`). ``rate`` is its joint-state rate while moving (Hz,
    30..1000). ``execute`` ``sim`` plays the kinematic simulator's motion; ``external`` drives a
    real arm through its controller's ``trajectory_topic`` (``JointTrajectory``) and its
    ``joint_states_topic`` (``JointState``), a motion being done within ``tolerance`` rad.
    """

    arm: str = field(kw_only=True)
    rate: float = 50.0
    execute: str = "sim"
    trajectory_topic: str | None = None
    joint_states_topic: str | None = None
    tolerance: float = 0.01

    def __post_init__(self) -> None:
        from flexhrc.ros2.arm import check_arm_options

        check_arm_options(
            self.rate, self.execute, self.trajectory_topic, self.joint_states_topic, self.tolerance
        )


@dataclass(frozen=True)
class Ros2HumanConfig(Ros2NodeConfig):
    """``flexhrc ros2 human``: the scenario's operator ``name``, simulated with ``profile``
    (passive, takeover, cooperative, or random seeded by ``seed``)."""

    name: str = field(kw_only=True)
    profile: str = "passive"

    def __post_init__(self) -> None:
        from flexhrc.cell.components import check_profile

        check_profile(self.profile)


def serve_ros2_cell(
    config: Ros2CellConfig,
    *,
    trace: Callable[[dict[str, Any]], None] | None = None,
    progress: Progress | None = None,
    attach: Iterable[Callable[[Any], Any]] = (),
) -> dict[str, Any]:
    """Run the cell's manager on ROS 2 until the cooperation ends: ``flexhrc ros2 cell`` as a
    function. It waits (``config.wait``) for a node of every agent of the scenario — arm nodes
    (:func:`serve_ros2_arm`), operator nodes (:func:`serve_ros2_human`) or clients of your own
    (``docs/ros2.md``) — then runs the cooperation. Object poses from ROS 2 enter as the cell's
    percepts, IMU readings go out again as ``imu/<operator>`` messages, and the markers draw an
    arrow for each running command until it ends.

    ``trace(event)`` sees each event of the cell as it happens, ``progress(line)`` the start-up
    and waiting lines. ``attach``: factories, each called with the cell, of components the loop
    polls (``poll()``) and closes when the cooperation has ended (``close()``) — the operator
    panel: a :class:`flexhrc.web.live.CellPanel` with ``operator=True`` stands in for the
    scenario's operators. Returns the cell's summary (what ``--json`` prints: the keys of
    ``flexhrc run --json`` and the cell's ``cell``).
    """
    from flexhrc.cell import Cell, EventStore
    from flexhrc.cell import protocol as P
    from flexhrc.cell.components import execution_model
    from flexhrc.cell.serve import close_made
    from flexhrc.ros2.extras import ManagerInterfaces

    scenario = _scenario(config)
    branches: Any = execution_model(config.simulator, scenario)  # the scenario may force one
    marks: list[Any] = []  # (interfaces, cell) once both exist

    def observe(ev: dict[str, Any]) -> None:
        if marks:
            _mark(marks[0], marks[1], ev)
        if trace is not None:
            trace(ev)

    store = EventStore(config.store, resume=config.resume) if config.store else None
    transport: Any = None
    try:
        transport = _transport(config, "manager")
        cell = Cell(
            scenario,
            transport,
            store=store,
            resume=config.resume,
            realtime=config.realtime,
            agent_speed=config.realtime,
            simulator=branches,
            liveliness=True,
            name=config.cell,
            trace=observe,
            seed=config.seed,
            on_failure=config.on_failure,
            answer_timeout=config.answer_timeout,
            policy=config.policy,
        )
        cell.agents_hint = (
            "start them with `flexhrc ros2 arm SCENARIO --arm NAME` and `flexhrc ros2 human "
            "SCENARIO --name NAME` (the same --cell)"
        )
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
            operators=[a.name for a in cell.domain.agents.values() if a.is_human],
            on_percept=percept,
            on_imu=imu,
            rate_hz=config.markers_rate,
            skip=cell.domain.agents,
        )
        marks.extend([interfaces, cell])
        extras = [make(cell) for make in attach]

        def pump(timeout: float) -> None:
            transport.wait(timeout)
            transport.flush()
            for extra in extras:
                extra.poll()
            interfaces.poll()

        if progress is not None:
            progress(
                f"cell {config.cell!r} on ROS 2 (domain {transport.domain_id}): "
                f"topics under {transport.ros_name('state').rsplit('/', 1)[0]}/"
            )
        data = cell.run(pump=pump, agents_timeout=config.wait, progress=progress)
        for cid in list(interfaces.commands):  # the cell is over: no arrow stays
            interfaces.command_finished(cid)
        interfaces.publish_markers()
        for extra in extras:
            extra.close()
        cell.close()
        # (closing the transport waits until the end message is acknowledged)
    finally:
        close_made(store, transport)
    return data


def serve_ros2_arm(
    config: Ros2ArmConfig,
    *,
    progress: Progress | None = None,
    until: Callable[[], bool] | None = None,
) -> dict[str, Any]:
    """Serve the cell as one of its robot arms until the cell ends (or ``until()`` is true):
    ``flexhrc ros2 arm`` as a function. ``progress(line)`` sees what the arm does
    (``[left] ...``). Returns its report: ``agent``, ``outcome`` (the cell's, ``stopped`` by
    ``until``), the commands ``received``, the messages ``dropped``, the ids ``executed``."""
    from flexhrc.ros2.arm import ArmNode

    def make(scenario: Any, transport: Any, say: Progress) -> Any:
        return ArmNode(
            config.arm,
            scenario,
            transport,
            rate_hz=config.rate,
            execute=config.execute,
            trajectory_topic=config.trajectory_topic,
            joint_states_topic=config.joint_states_topic,
            tolerance_rad=config.tolerance,
            trace=say,
        )

    node, report = _serve_agent(config, config.arm, "robot", make, progress, until)
    return {**report, "executed": list(node.executed)}


def serve_ros2_human(
    config: Ros2HumanConfig,
    *,
    progress: Progress | None = None,
    until: Callable[[], bool] | None = None,
) -> dict[str, Any]:
    """Serve the cell as its simulated operator ``config.name`` until the cell ends (or
    ``until()`` is true): ``flexhrc ros2 human`` as a function. Returns its report: ``agent``,
    ``outcome``, ``received`` and ``dropped``."""
    from flexhrc.cell import HumanAgent

    def make(scenario: Any, transport: Any, say: Progress) -> Any:
        return HumanAgent(
            config.name, scenario, transport, profile=config.profile, seed=config.seed, trace=say
        )

    return _serve_agent(config, config.name, "human", make, progress, until)[1]


def _scenario(config: Ros2NodeConfig) -> Any:
    if not isinstance(config.scenario, str | Path):
        return config.scenario
    from flexhrc.scenario import load_scenario

    return load_scenario(config.scenario, seed=config.seed, segments=config.segments)


def _transport(config: Ros2NodeConfig, role: str) -> Any:
    from flexhrc.ros2.transport import Ros2Transport, check_exposure, ros_topic

    ros_topic("flexhrc", config.cell)  # a cell name must be a valid ROS name part
    check_exposure()  # other hosts' nodes only with SROS2, as a Zenoh cell only with TLS
    return Ros2Transport(
        prefix=f"flexhrc/{config.cell}",
        node_name=f"flexhrc_{config.cell}_{role}",
        domain_id=config.domain_id,
    )


def _serve_agent(
    config: Ros2NodeConfig,
    name: str,
    kind: str,
    make: Callable[[Any, Any, Progress], Any],
    progress: Progress | None,
    until: Callable[[], bool] | None,
) -> tuple[Any, dict[str, Any]]:
    """Check the agent's name, make it on a transport of its own and serve the cell until it
    ends; the agent and the transport are closed whatever happens."""
    from flexhrc.cell.components import check_agent_name
    from flexhrc.cell.serve import serve_until_end
    from flexhrc.ros2.transport import ros_topic

    scenario = _scenario(config)
    ros_topic("", name)
    option = "--arm" if kind == "robot" else "--name"
    check_agent_name(scenario.domain, name, kind, option)  # before the network

    def say(line: str) -> None:
        if progress is not None:
            progress(f"[{name}] {line}")

    transport = _transport(config, f"{'arm' if kind == 'robot' else 'human'}_{name}")
    where = f", commands on {transport.ros_name('cmd/' + name)}" if kind == "robot" else ""
    ready = f"ready: cell {config.cell!r}, ROS domain {transport.domain_id}{where}"
    agent, outcome = serve_until_end(
        lambda: make(scenario, transport, say), transport, say=say, ready=ready, until=until
    )
    return agent, {
        "agent": name,
        "outcome": outcome,
        "received": agent.received,
        "dropped": agent.dropped,
    }


def _mark(interfaces: Any, cell: Any, ev: dict[str, Any]) -> None:
    """A command's arrow in the markers, from its start to its end (ack or stop), pointing at
    the object its action goes to (:func:`~flexhrc.ros2.motion.action_target`)."""
    from flexhrc.ros2.motion import action_target

    kind = ev.get("type")
    if kind == "command":
        cmd = cell.commands.get(int(ev["id"]))
        if cmd is not None:
            where = action_target(cmd.action, {k: o.position for k, o in cell.kb.objects.items()})
            interfaces.command_started(int(ev["id"]), "+".join(cmd.agents), where)
    elif kind in ("ack", "stop") and "id" in ev:
        interfaces.command_finished(int(ev["id"]))
