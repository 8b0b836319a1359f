"""``flexhrc cell`` and ``flexhrc agent`` as functions: a config in, the summary out.

* :func:`serve_cell` (:class:`CellConfig`) — a cell of a scenario as ``flexhrc cell`` runs it:
  the transport, the simulated agents inside or the agent processes it waits for, the store,
  the ready file; returns the summary of ``--json`` (:func:`summary_line`: its text).
* :func:`join_cell` (:class:`AgentConfig`) — ``flexhrc agent robot|human``: a simulated agent
  that joins a cell over Zenoh and serves it until the cell ends.

A config checks its options when it is made, naming the command's option, so a script and the
command fail alike and before any work. The cell stands below :mod:`flexhrc.scenario` and the
panel (:mod:`flexhrc.web`): the caller brings a loaded scenario and, for the panel, an ``attach``
factory — called with the :class:`~flexhrc.cell.supervisor.Cell`, it returns a
:class:`Component` the loop polls like an agent and closes at the end (``docs/cell.md``).
"""

from __future__ import annotations

import json
import math
import os
import re
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, TypeVar

from flexhrc import events
from flexhrc.cell.components import (
    HumanAgent,
    RobotAgent,
    ScenarioLike,
    check_agent_name,
    check_profile,
    execution_model,
    run_agent,
)
from flexhrc.cell.store import EventStore
from flexhrc.cell.supervisor import Cell, answer_timeout_of, decision_policy, failure_policy
from flexhrc.errors import FlexhrcError
from flexhrc.files import OutputPathError, atomic_write_text, check_output
from flexhrc.taskmanager.operator import PROFILES, operator_seed
from flexhrc.taskmanager.replay import solved_by_line
from flexhrc.transport import InProcessBus, Transport

#: Where a cell listens over Zenoh when given neither ``listen`` nor ``connect``.
DEFAULT_LISTEN = "tcp/127.0.0.1:7447"
#: What ``--simulator`` may name: ``auto`` (the scenario's own) or a simulator of the catalogue.
SIMULATORS = ("auto", *events.SIMULATORS)


class Component(Protocol):
    """What the cell's loop does with an attached component (and with its agents)."""

    def poll(self) -> None: ...

    def close(self) -> None: ...


def _choice(option: str, value: str, choices: Iterable[str]) -> None:
    if value not in choices:
        raise FlexhrcError(f"{option} {value!r}: choose one of {', '.join(choices)}")


def _check_cell_name(name: str) -> None:
    if not re.fullmatch(r"[A-Za-z0-9_\-]+", name):
        raise FlexhrcError(f"--cell {name!r}: letters, digits, '_' and '-' only")


def check_manager_options(config: Any) -> None:
    """The options of a cell's manager that ``flexhrc cell`` and ``flexhrc ros2 cell`` share
    (the fields of their configs), checked in the words of the command's options."""
    _choice("--simulator", config.simulator, SIMULATORS)
    if config.on_failure is not None:
        failure_policy(None, config.on_failure)
    if config.policy is not None:
        decision_policy(None, config.policy)
    answer_timeout_of(None, config.answer_timeout)
    if not (math.isfinite(config.realtime) and config.realtime >= 0):
        raise FlexhrcError(f"--realtime must be a finite number >= 0, got {config.realtime}")
    if not (math.isfinite(config.wait) and config.wait > 0):
        raise FlexhrcError(f"--wait must be a positive number of seconds, got {config.wait}")


@dataclass(frozen=True)
class CellConfig:
    """What :func:`serve_cell` runs: the options of ``flexhrc cell``, with its defaults.

    ``transport`` ``inprocess`` or ``zenoh`` (``listen``/``connect``: Zenoh endpoints; with
    neither, the cell listens on :data:`DEFAULT_LISTEN`); ``cell`` the name its keys live under
    (``flexhrc/NAME/``). ``agents`` ``internal``: simulated arms and operators in this process,
    the operators with the ``human`` profile, seeded from ``seed`` as ``flexhrc run`` seeds them;
    ``external``: agent processes (Zenoh only), waited for ``wait`` seconds. ``zenoh_config``: a
    Zenoh configuration file (json5, ``--zenoh-config``) the session starts from — TLS
    certificates, access control (``docs/cell.md``, "Securing a cell"); without
    ``listen``/``connect`` its endpoints are used. ``store`` an SQLite
    event store; ``resume`` continues the cooperation kept there. ``realtime`` 0: as fast as the
    agents answer, else simulated seconds per wall second. ``simulator`` the branch simulator and
    the internal arms' world. ``on_failure`` ``retry`` or ``paper``: what a failed robot action
    does to its hyper-arc (None: the scenario's ``on_failure``, else ``retry``). ``policy``
    ``paper`` or ``lookahead``: how the manager decides (None: the scenario's ``policy``, else
    ``paper``; ``lookahead`` needs :mod:`flexhrc.planning` imported). ``ready_file``:
    once the cell listens, JSON with the endpoints as bound, the pid and the cell's name, written
    atomically. ``operators``: an operator model file (``flexhrc learn``, ``docs/operators.md``)
    the manager times each person's steps by, updated online as they act.
    """

    seed: int = 0
    transport: str = "inprocess"
    agents: str = "internal"
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    cell: str = "default"
    store: str | Path | None = None
    resume: bool = False
    realtime: float = 0.0
    simulator: str = "auto"
    on_failure: str | None = None
    answer_timeout: float | None = None
    policy: str | None = None
    wait: float = 30.0
    human: str = "passive"
    ready_file: str | Path | None = None
    zenoh_config: str | Path | None = None
    operators: str | Path | None = None

    def __post_init__(self) -> None:
        _choice("--transport", self.transport, ("inprocess", "zenoh"))
        _choice("--agents", self.agents, ("internal", "external"))
        _choice("--human", self.human, PROFILES)
        check_manager_options(self)
        if self.agents == "external" and self.transport != "zenoh":
            raise FlexhrcError("--agents external needs --transport zenoh")
        if self.transport == "inprocess" and (self.listen or self.connect):
            raise FlexhrcError("--listen and --connect go with --transport zenoh")
        if self.transport == "inprocess" and self.zenoh_config:
            raise FlexhrcError("--zenoh-config goes with --transport zenoh")
        if self.resume and not self.store:
            raise FlexhrcError("--resume needs --store FILE.db")
        if self.human != "passive" and self.agents == "external":
            raise FlexhrcError(
                "--human goes with --agents internal (an external operator has its own "
                "`flexhrc agent human --profile`)"
            )
        if self.transport == "zenoh":
            _check_cell_name(self.cell)  # a part of every Zenoh key

    @property
    def listen_on(self) -> list[str]:
        """The Zenoh endpoints to listen on: ``listen``, else :data:`DEFAULT_LISTEN` unless the
        cell only connects or its ``zenoh_config`` file says where."""
        return list(self.listen) or ([] if self.connect or self.zenoh_config else [DEFAULT_LISTEN])


def serve_cell(
    scenario: ScenarioLike,
    config: CellConfig | None = None,
    *,
    trace: Callable[[dict[str, Any]], None] | None = None,
    progress: Callable[[str], None] | None = None,
    attach: Iterable[Callable[[Cell], Component]] = (),
    ready_extra: Callable[[], Mapping[str, Any]] | None = None,
) -> dict[str, Any]:
    """Run the cooperation of ``scenario`` as a cell configured by ``config`` to its end:
    ``flexhrc cell`` as a function. ``trace`` gets every event as it happens (:func:`trace_line`
    is the command's words for it), ``progress`` the lines the command prints on stderr (where
    it listens, what it waits for, a warning). ``attach``: factories of components the loop
    polls beside its agents, e.g. the panel (module docstring); ``ready_extra()``: more keys for
    the ready file (the panel's address, once the attached panel listens). Returns the cell's
    summary (the keys of ``flexhrc cell --json``); the store and the transport are closed on the
    way out."""
    config = config or CellConfig()
    say = progress or (lambda line: None)
    model = None
    if config.operators is not None:  # read first: a bad file leaves no store behind
        from flexhrc.taskmanager.operator_model import read_model

        model = read_model(config.operators)
    store = EventStore(config.store, resume=config.resume) if config.store else None
    if store is not None:
        store.on_lost = lambda reason: say(f"warning: {reason}")
    transport: Any = None
    try:
        zenoh = config.transport == "zenoh"
        if zenoh:
            transport = zenoh_for_cell(
                config.cell,
                config.listen_on,
                config.connect,
                warn=say,
                config_file=config.zenoh_config,
            )
        else:
            transport = InProcessBus()
        internal = config.agents == "internal"
        # in one process the manager's model of the robot and the arms' simulated world are one
        # object, as in `flexhrc run`: the manager plans from where the arms really are
        simulator: Any = execution_model(config.simulator, scenario)
        if model is not None:  # the manager's belief about the people; the world stays as is
            from flexhrc.taskmanager.operator_model import OperatorModelSimulator

            simulator = OperatorModelSimulator(simulator, model)
        cell = Cell(
            scenario,
            transport,
            store=store,
            resume=config.resume,
            realtime=config.realtime,
            ordered=True if internal else None,
            agent_speed=0.0 if internal else config.realtime,
            simulator=simulator,
            liveliness=zenoh,
            name=config.cell,
            trace=trace,
            seed=config.seed,
            shared_model=internal,  # the internal arms execute on the manager's model
            on_failure=config.on_failure,
            answer_timeout=config.answer_timeout,
            policy=config.policy,
        )
        agents: list[Component] = []
        if internal:
            agents += _internal_agents(scenario, transport, config, world=simulator)
            if not zenoh:
                for st in cell.agents.values():
                    st.alive = st.seen = True
        agents += [make(cell) for make in attach]

        def pump(timeout: float) -> None:
            wait = getattr(transport, "wait", None)
            if wait is not None and not (internal and transport.pending()):
                wait(timeout)
            delivered = transport.flush()
            for agent in agents:
                agent.poll()
            if wait is None and not delivered:
                time.sleep(0.001)  # nothing moved (e.g. waiting for a resend): do not spin

        endpoints: list[str] = []
        if zenoh:
            from flexhrc.transport.zenoh import listening_on

            endpoints = listening_on(transport, config.listen_on or transport.listen_endpoints)
            where = ", ".join(endpoints)
            say(
                f"cell {config.cell!r} on zenoh"
                + (f", listening on {where}" if where else "")
                + (f", connected to {', '.join(config.connect)}" if config.connect else "")
            )
        if config.ready_file:  # the manager's subscriptions and token are declared: agents may come
            record = {"listen": endpoints, "pid": os.getpid(), "cell": config.cell}
            if ready_extra is not None:
                record.update(ready_extra())
            write_ready_file(config.ready_file, record)
        data = cell.run(pump=pump, agents_timeout=config.wait, progress=progress)
        if store is not None and store.lost:
            data["cell"]["store_lost"] = store.lost
        for agent in agents:
            agent.close()
        cell.close()
        if zenoh:
            time.sleep(0.2)  # let the end message leave before the session closes
    finally:
        close_made(store, transport)
    return data


def _internal_agents(
    scenario: ScenarioLike, transport: Transport, config: CellConfig, *, world: Any
) -> list[Component]:
    """A simulated arm for each robot agent, an operator for each human one. The arms share one
    simulated world, as in ``flexhrc run``: what the follower of a joint command did, and where
    the other arm is, are in it; the operators are seeded as ``flexhrc run`` seeds them."""
    humans = [a.name for a in scenario.domain.agents.values() if a.is_human]
    return [
        HumanAgent(
            a.name,
            scenario,
            transport,
            profile=config.human,
            seed=operator_seed(config.seed, humans.index(a.name)),
            execution=execution_model("analytic", scenario),
        )
        if a.is_human
        else RobotAgent(a.name, scenario, transport, execution=world)
        for a in scenario.domain.agents.values()
    ]


def summary_line(data: dict[str, Any], store: str | Path | None = None) -> str:
    """The one line ``flexhrc cell`` prints for a cell's summary (``store``: where it is kept)."""
    return (
        f"outcome {data['outcome']}"
        + (f" ({data['reason']})" if data["reason"] else "")
        + f"; {solved_by_line(data)}; {data['decisions']} decision trees; "
        f"{data['robot_actions']} robot and {data['human_actions']} human actions; "
        f"{data['cell']['events']} events"
        + (f" in {store}" if store and not data["cell"].get("store_lost") else "")
        + (
            "; NOT STORED: the store was deleted while the cell ran"
            if data["cell"].get("store_lost")
            else ""
        )
        + (
            f"; {data['cell']['dropped']} malformed messages dropped"
            if data["cell"]["dropped"]
            else ""
        )
    )


def trace_line(ev: dict[str, Any]) -> str | None:
    """The live trace's line for a cell's event (None: not shown)."""
    kind = ev["type"]
    if kind == "command":
        line = f"{'+'.join(ev['agents']):<6} {ev['action']}  [cmd {ev['id']}]"
    elif kind == "ack":
        if ev["status"] == "done":
            return None
        line = f"cmd {ev['id']} {ev['status']}: {ev.get('reason')}"
    elif kind == "suggestion":
        line = f"ask {ev['agent']}: {ev['element']}: {'; '.join(ev['actions'])}"
    elif kind == "human_action":
        line = f"{ev['agent']} did {ev['action']}"
    elif kind == "decision":
        line = f"decide {ev['element']} (cost {ev['cost']}): {len(ev['branches'])} branches"
    elif kind == "agent_down":
        line = f"AGENT LOST: {ev['agent']}"
    elif kind == "agent_up":
        line = f"agent back: {ev['agent']}"
    elif kind == "dropped":
        line = f"dropped a message: {ev['reason']}"
    elif kind == "refused":
        line = str(ev["reason"])
    elif kind in ("abort", "action_failed", "infeasible"):
        line = f"{kind} {ev['element']}: {ev.get('reason')}"
    elif kind == "outcome":
        line = f"outcome: {str(ev['outcome']).upper()}" + (
            f" ({ev['reason']})" if ev.get("reason") else ""
        )
    else:
        return None
    return f"{ev['t']:8.2f}s  {line}"


def write_ready_file(path: str | Path, record: dict[str, Any]) -> None:
    """Write ``record`` as JSON to ``path`` atomically (a reader sees all of it or nothing)."""
    try:
        atomic_write_text(path, json.dumps(record) + "\n")
    except OutputPathError as exc:
        raise FlexhrcError(f"--ready-file {exc}") from None


def zenoh_for_cell(
    cell: str,
    listen: Iterable[str] = (),
    connect: Iterable[str] = (),
    *,
    warn: Callable[[str], None] | None = None,
    config_file: str | Path | None = None,
) -> Any:
    """A Zenoh transport for the cell named ``cell`` (keys under ``flexhrc/CELL/``), for the
    cell itself or an agent of it (:func:`flexhrc.transport.zenoh.open_zenoh`, which refuses
    a listener other hosts reach without TLS; ``config_file``: ``--zenoh-config``; without
    the ``zenoh`` extra, an :class:`~flexhrc.errors.OptionalDependencyError` that says so)."""
    _check_cell_name(cell)
    from flexhrc.transport.zenoh import open_zenoh

    return open_zenoh(
        list(listen), list(connect), prefix=f"flexhrc/{cell}", warn=warn, config_file=config_file
    )


# -- an agent process -------------------------------------------------------------------------
@dataclass(frozen=True)
class AgentConfig:
    """What :func:`join_cell` runs: the options of ``flexhrc agent robot|human``.

    ``kind`` ``robot`` (the arm ``name``; ``simulator`` its simulated world; ``journal`` keeps
    the commands it started and finished, so a restarted process never executes a command id
    twice) or ``human`` (the operator ``name`` with ``profile``, its choices seeded by
    ``seed``). ``connect``/``listen``: Zenoh endpoints (at least one, or a ``zenoh_config``
    file that names them; the cell's ``--listen`` endpoint to connect to); ``cell`` the cell's
    name; ``zenoh_config`` a Zenoh configuration file (``--zenoh-config``: its certificate).
    """

    kind: str
    name: str
    seed: int = 0
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    cell: str = "default"
    simulator: str = "auto"
    journal: str | Path | None = None
    profile: str = "passive"
    zenoh_config: str | Path | None = None

    def __post_init__(self) -> None:
        _choice("KIND", self.kind, ("robot", "human"))
        _choice("--simulator", self.simulator, SIMULATORS)
        if not self.connect and not self.listen and not self.zenoh_config:
            raise FlexhrcError("--connect ENDPOINT is needed (the cell's --listen endpoint)")
        _check_cell_name(self.cell)


def join_cell(
    scenario: ScenarioLike,
    config: AgentConfig,
    *,
    trace: Callable[[str], None] | None = None,
    progress: Callable[[str], None] | None = None,
    until: Callable[[], bool] | None = None,
) -> dict[str, Any]:
    """Join the cell of ``scenario`` over Zenoh as the agent ``config`` describes and serve it
    until it ends (or ``until()`` is true: outcome ``stopped``): ``flexhrc agent`` as a
    function. ``trace`` gets the agent's lines, ``progress`` a warning about the endpoints.
    Returns the summary ``flexhrc agent --json`` prints."""
    # the names are checked before the network is opened
    option = "--arm" if config.kind == "robot" else "--name"
    check_agent_name(scenario.domain, config.name, config.kind, option)
    if config.kind == "human":
        check_profile(config.profile)
    if config.journal:
        check_output(config.journal, option="--journal")
    transport = zenoh_for_cell(
        config.cell, config.listen, config.connect, warn=progress, config_file=config.zenoh_config
    )

    def make() -> RobotAgent | HumanAgent:
        if config.kind == "robot":
            world = execution_model(config.simulator, scenario)
            journal = config.journal
            return RobotAgent(
                config.name, scenario, transport, execution=world, trace=trace, journal=journal
            )
        return HumanAgent(
            config.name,
            scenario,
            transport,
            profile=config.profile,
            seed=config.seed,
            execution=execution_model("analytic", scenario),
            trace=trace,
        )

    say = trace or (lambda line: None)
    ready = f"ready ({config.kind}, cell {config.cell!r})"
    agent, outcome = serve_until_end(make, transport, say=say, ready=ready, until=until)
    return {
        "agent": config.name,
        "kind": config.kind,
        "outcome": outcome,
        "received": agent.received,
        "dropped": agent.dropped,
        "executed": list(getattr(agent, "executed", [])),
    }


_Agent = TypeVar("_Agent")


def serve_until_end(
    make: Callable[[], _Agent],
    transport: Any,
    *,
    say: Callable[[str], None],
    ready: str,
    until: Callable[[], bool] | None = None,
) -> tuple[_Agent, str]:
    """Make an agent on ``transport`` and serve the cell until it ends (or ``until()``): says
    ``ready`` once it is up and the cell's outcome at the end; closes the agent and the
    transport whatever happens. Returns the agent and the outcome (``stopped`` by ``until``)."""
    agent: Any = None
    try:
        agent = make()
        say(ready)
        outcome = run_agent(agent, transport, until=until)
        say(f"cell ended: {outcome}")
    finally:
        close_made(agent, transport)
    return agent, outcome


def close_made(*parts: Any) -> None:
    """Close, in order, each of ``parts`` that was made (None: not made, nothing to close)."""
    for part in parts:
        if part is not None:
            part.close()
