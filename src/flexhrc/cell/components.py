"""Simulated agents of a cell: a robot arm and a human operator, each talking only protocol.

Both work the same over the in-process bus (``flexhrc cell`` with ``--agents internal``) and over
Zenoh in their own processes (``flexhrc agent robot|human``). They load the scenario themselves
(so they know the domain and the objects' shapes) and take the live state of the world —
positions and facts — from each command or suggestion, exactly as a real arm takes a target from
its controller.

* :class:`RobotAgent` executes a :class:`~flexhrc.taskmanager.manager.Command` with the
  execution model — the scenario's simulator, the same object that plays the real world in
  :class:`~flexhrc.cell.local.LocalCell` — and answers with an ``ack`` carrying
  where things are afterwards. **It never executes one command id twice**: a repeated id (the
  manager resumed after a crash) gets the stored ack again, or nothing while it is running; with
  a ``journal`` this holds across restarts of the agent's process too. Its memory is per run
  (the command's ``run``, :mod:`flexhrc.cell.identity`): another run's command 3 is a new
  command, and a repeated id with another action is refused, never answered from memory.
* :class:`HumanAgent` follows suggestions step by step: it carries out the step the manager
  names, in the world the message carries, and reports it as a ``human_action``; a repeated step
  gets its report again. With a profile that acts on its own (``takeover``, ``cooperative``,
  ``random``: :mod:`flexhrc.taskmanager.operator`) it also answers the manager's ``options``
  — the cooperation steps it may do alone now, each with its hyper-arcs, costs and ground
  branches — with an ``intent``: to act (which branch, after how long) or not. The manager then
  hands it its own plan step by step, as it hands a suggestion. The person decides; the manager
  only says what is possible and keeps the time order (``docs/protocol.md``).

``realtime`` (from the message) > 0 makes an agent take ``duration / realtime`` seconds of wall
time before it answers, so a process can be killed in the middle of an action; 0 answers at once
with the simulated end time ``t``.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from flexhrc.cell import identity
from flexhrc.cell import protocol as P
from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.files import EventLogWriter
from flexhrc.knowledge import KnowledgeBase
from flexhrc.representation import OnlineGraph
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.operator import PROFILES, SimulatedOperator
from flexhrc.taskmanager.simulator import AnalyticSimulator, ExecutionModel
from flexhrc.transport import Transport

log = logging.getLogger("flexhrc.cell")

HUMAN_PROFILES = PROFILES
# an operator agent's profile goes out again this often until the manager has acknowledged it
ANNOUNCE_RETRY_S = 0.5
# how long a process that dials asks whether its agent name is held before taking it
HOLDER_SETTLE_S = 0.5
#: How long a simulated operator takes to say "not now", "I can't" or "take it back"
#: (seconds of the cell's clock): an answer takes a moment, and a person who always says
#: "not now" makes the clock go on rather than the manager ask again at the same instant.
REPLY_S = 1.0

#: A simulated operator's answer to step ``step`` of a request for hyper-arc ``element`` with
#: ``actions`` (``docs/protocol.md``, "Operator answers"): None does it; ``"decline"``,
#: ``("cannot", reason)``, ``"give_back"`` answer so; ``"start"`` says "I'm starting" first and
#: then reports the step without its start (as a panel's "done" did); ``"ignore"`` never answers.
Replies = Callable[[str, list[str], int], "str | tuple[str, str] | None"]


class ScenarioLike(Protocol):
    """What the cell and its agents read of a task: exactly the members of
    :class:`flexhrc.scenario.Scenario` they use (the cell stands below :mod:`flexhrc.scenario`
    and never imports it). Every call of :meth:`world` and :meth:`online_graph` returns new
    objects: each process, each agent owns its copies."""

    name: str
    domain: Domain  # agents, action schemas, processes

    def world(self) -> KnowledgeBase:
        """A fresh knowledge base: objects, places, agents' hands, initial facts."""
        ...

    def online_graph(self) -> OnlineGraph:
        """A fresh online AND/OR graph for one run."""
        ...

    def make_simulator(self, choice: str | None = None) -> Any:
        """The simulator ``choice`` names (``analytic``, ``kinematic``, ``auto``); None: the
        scenario's own. Branch simulator of the manager, simulated world of an agent."""
        ...


def execution_model(choice: str = "auto", scenario: ScenarioLike | None = None) -> ExecutionModel:
    """The simulated real world as the scenario makes it (``auto``: the scenario's own choice;
    :meth:`ScenarioLike.make_simulator`); without a scenario only ``analytic`` (the choice
    between simulators is made above the cell, in :mod:`flexhrc.scenario`)."""
    if scenario is not None:
        model: ExecutionModel = scenario.make_simulator(None if choice == "auto" else choice)
        return model
    if choice != "analytic":
        raise FlexhrcError(f"the {choice} simulator is made by a scenario: give one")
    return AnalyticSimulator()


@dataclass(frozen=True)
class Executed:
    """One action an in-process agent carries out, as its ``on_executed`` observer sees it: who,
    what, where the agent *believed* things were when it started (the world its message
    carried), and when it starts and ends on the cell's clock. ``command`` is the command id of
    a robot, the report id of an operator. The agent answers at once; the observer (e.g. the
    truth of a simulated workspace, :mod:`flexhrc.sensing.loop`) applies the effect at ``end``."""

    agent: str
    command: int | str
    action: GroundAction
    believed: dict[str, tuple[float, float, float]]
    start: float
    end: float
    status: str


#: ``on_executed(executed)``: None, or why the action failed in the world (a grasp that closes
#: on nothing); only a ``done`` robot action can be failed so.
OnExecuted = Callable[[Executed], "str | None"]


class HumanSensing(Protocol):
    """A wearable sensor of the operator (``flexhrc.perception.human.sensing``): what it made of
    one performed action — ``.recognised`` (a task action name or None), ``.samples`` (0: no
    motion of the sensor plays this action) and ``.to_dict()``."""

    def sense(self, action: str) -> Any: ...


def ground(
    domain: Domain, text: str, agents: tuple[str, ...] | None = None, *, process: bool = False
) -> GroundAction:
    """``approach(left, leg1)`` as the domain's ground action (agents: the schema's agent);
    ``process=True`` for a round of a node process such as ``hold(tabletop)`` (a name only
    processes have is one too: a person asked to run a process reports it so)."""
    name = text.partition("(")[0].strip()
    process = process or (name in domain.processes and name not in domain.actions)
    schema, terms = domain.invocation(text, process=process)
    if any(str(t).startswith("?") for t in terms):
        raise P.ProtocolError(f"action {text!r} is not ground")
    if agents is None:
        spec = schema.agents
        if spec.variable is not None:
            binding = dict(zip(schema.variables, terms, strict=True))
            agents = (binding[spec.variable],)
        else:
            agents = tuple(spec.names)
    return GroundAction(schema, tuple(str(t) for t in terms), tuple(agents))


def unknown_name(domain: Domain, kb: KnowledgeBase, action: GroundAction) -> str | None:
    """``None`` when every argument of ``action`` names what its parameter's type asks for — an
    agent of the domain for ``agent``, else an agent or an object of the world of that type (or
    a subtype) — else why not, in one line: a person cannot pick up an object the world does not
    know, nor the robot arm ``left`` as a ``leg`` (probe 2026-12-02, P31)."""
    for (var, typ), arg in zip(action.schema.parameters, action.args, strict=True):
        agent = domain.agents.get(arg)
        rec = kb.objects.get(arg)
        if agent is None and rec is None:
            return f"{action}: no agent or object {arg!r} in this cell's world"
        if typ == "agent":
            ok = agent is not None
        else:
            ok = (rec is not None and typ in kb.type_chain(rec.type)) or (
                agent is not None and (typ == agent.kind or typ in agent.types)
            )
        if not ok:
            what = rec.type if rec is not None else f"{agent.kind if agent else '?'} agent"
            return f"{action}: {arg!r} ({what}) is not what {var} of {action.name} takes ({typ})"
    return None


def check_agent_name(domain: Domain, name: str, kind: str, option: str) -> None:
    """``name`` is a ``kind`` (``robot`` or ``human``) agent of the domain, or one
    :class:`~flexhrc.errors.UnknownNameError` naming ``option`` and the agents there are."""
    agent = domain.agents.get(name)
    if agent is not None and agent.is_human == (kind == "human"):
        return
    names = [a.name for a in domain.agents.values() if a.is_human == (kind == "human")]
    raise UnknownNameError(
        f"{option} {name!r}: no {kind} agent of that name in the scenario "
        f"({kind}s: {', '.join(names) or 'none'})"
    )


def check_profile(profile: str) -> None:
    """``profile`` is one of the operator :data:`HUMAN_PROFILES`, or one
    :class:`~flexhrc.errors.FlexhrcError` naming ``--profile`` and the choices."""
    if profile not in HUMAN_PROFILES:
        raise FlexhrcError(
            f"--profile {profile!r}: unknown operator profile; choose one of "
            f"{', '.join(HUMAN_PROFILES)}"
        )


def world_of(kb: KnowledgeBase) -> dict[str, Any]:
    """The part of the knowledge base an agent needs to act: positions and facts."""
    return {
        "positions": {k: list(o.position) for k, o in kb.objects.items()},
        "facts": sorted(list(f) for f in kb.facts),
    }


def sync_world(kb: KnowledgeBase, world: dict[str, Any]) -> None:
    """Make a local knowledge base show the world a message carries."""
    for obj, p in (world.get("positions") or {}).items():
        if obj in kb.objects:
            kb.move(obj, p)
    facts = world.get("facts")
    if isinstance(facts, list):
        # a parsed message's facts are lists of names (events._world): no str() of each
        want = {tuple(f) for f in facts if isinstance(f, list)}
        have = set(kb.facts)
        for f in have - want:
            kb.retract_fact(*f)
        for f in want - have:
            kb.assert_fact(*f)


class _Agent:
    def __init__(
        self,
        name: str,
        scenario: ScenarioLike,
        transport: Transport,
        *,
        execution: ExecutionModel | None = None,
        trace: Callable[[str], None] | None = None,
    ) -> None:
        _check_single_holder(transport, name)
        self.name = name
        self.scenario = scenario
        # why this agent must stop (a cell of another scenario, a journal of another run): the
        # agent's loop ends with this error (``run_agent``)
        self.fatal: str | None = None
        self.domain: Domain = scenario.domain
        self.kb: KnowledgeBase = scenario.world()
        self.transport = transport
        # this process's Zenoh session: the manager grants the agent's name to one session
        # and addresses its messages to it (None over a transport without sessions)
        self.session: str | None = getattr(transport, "session_id", None)
        self.execution = execution if execution is not None else execution_model("auto", scenario)
        self.trace = trace or (lambda line: None)
        self.ended: str | None = None  # the cell's outcome once it announced its end
        self.dropped = 0
        self.received = 0
        self._timers: list[tuple[float, Callable[[], None]]] = []
        self._subs = [transport.subscribe(P.STATE_TOPIC, self._on_state)]
        self.token: Any = None
        watch = getattr(transport, "watch_liveliness", None)
        if watch is not None:  # a manager that (re)appears is told who joins
            self._subs.append(watch(P.alive_key(P.MANAGER), self._on_manager_alive))

    @property
    def fingerprint(self) -> str:
        """This agent's scenario fingerprint (:func:`flexhrc.cell.identity.fingerprint`)."""
        return identity.fingerprint(self.scenario)

    def _join(self) -> None:
        """Tell the manager who joins and of which scenario (over a transport with liveliness
        tokens: agents of other processes); the manager refuses one of another scenario."""
        if getattr(self.transport, "declare_token", None) is None:
            return
        role = "robot" if isinstance(self, RobotAgent) else "human"
        msg = P.message(
            "join",
            agent=self.name,
            role=role,
            scenario=str(self.scenario.name),
            fingerprint=self.fingerprint,
        )
        self.transport.publish(P.JOIN_TOPIC, msg)

    def _on_manager_alive(self, key: str, alive: bool) -> None:
        if alive and self.fatal is None:
            self._join()

    def _of_this_scenario(self, msg: dict[str, Any]) -> bool:
        """The message's ``fingerprint`` (if any) is this agent's scenario's; else the agent
        stops with a clear error (:attr:`fatal`) and tells the manager why (its ``join``)."""
        theirs = msg.get("fingerprint")
        if not isinstance(theirs, str) or theirs == self.fingerprint:
            return True
        if self.fatal is None:
            scenario = msg.get("scenario")
            named = f"scenario {scenario}, " if isinstance(scenario, str) else ""
            self.fatal = (
                f"agent {self.name}: the cell runs another scenario ({named}fingerprint {theirs}) "
                f"than this agent's {self.scenario.name} (fingerprint {self.fingerprint}): "
                "start the agent with the cell's scenario and --seed"
            )
            log.error("%s", self.fatal)
            self._join()  # the manager logs the refusal too
        return False

    def _announce(self) -> None:
        """Declare the liveliness token — last, once every subscription is declared, so the
        manager never sends to an agent that cannot hear yet (Zenoh keeps a session's
        declarations in order)."""
        declare = getattr(self.transport, "declare_token", None)
        if declare is not None:
            self.token = declare(P.alive_key(self.name))

    def _on_state(self, data: Any) -> None:
        if isinstance(data, dict) and data.get("type") == "end":
            # only the manager's own end: a spoofed or foreign one is dropped (P15, P16)
            try:
                self.ended = str(P.parse_end(data, run=getattr(self, "run", None))["outcome"])
            except P.ProtocolError as exc:
                self._bad(data, exc)
        elif isinstance(data, dict) and data.get("type") == "state":
            self._of_this_scenario(data)
            refused = data.get("refused_sessions")
            why = refused.get(self.session) if isinstance(refused, dict) and self.session else None
            if isinstance(why, str) and self.fatal is None:  # another process has the name (K09)
                self.fatal = why
                log.error("%s", why)
            unjoined = data.get("unjoined")
            if isinstance(unjoined, list) and self.name in unjoined and self.fatal is None:
                self._join()  # the manager never got this process's join (lost): again

    def _for_me(self, msg: dict[str, Any]) -> bool:
        """A message the manager addressed to another process of this agent's name (its
        ``session``: the one it granted the name) is left alone: one process per agent
        executes (probe K09). A message that names no session, or a transport without
        sessions, cannot tell: taken."""
        theirs = msg.get("session")
        if theirs is None or self.session is None or theirs == self.session:
            return True
        self.trace(f"{msg['type']} {msg.get('id')} is for another process (session {theirs})")
        return False

    def _receive(
        self,
        data: Any,
        expect: str | tuple[str, ...],
        handle: Callable[[dict[str, Any]], None],
    ) -> None:
        """Count a message, check it, and hand it to ``handle`` unless it is for another
        process (:meth:`_for_me`); a malformed or refused one is dropped (:meth:`_bad`)."""
        self.received += 1
        try:
            msg = P.parse(data, expect=expect)
            if self._for_me(msg):
                handle(msg)
        except FlexhrcError as exc:
            self._bad(data, exc)

    def _bad(self, data: Any, exc: Exception) -> None:
        self.dropped += 1
        log.warning("%s: dropped a malformed message: %s", self.name, exc)
        self.trace(f"dropped: {exc}")

    def _later(self, delay: float, fn: Callable[[], None]) -> None:
        if delay <= 0:
            fn()
        else:
            self._timers.append((time.monotonic() + delay, fn))

    def _paced(self, msg: dict[str, Any], seconds: float, fn: Callable[[], None]) -> None:
        """``fn`` after ``seconds`` of cell time at the pace ``msg`` asks (``realtime``; none:
        at once)."""
        speed = float(msg.get("realtime", 0.0))
        self._later(seconds / speed if speed > 0 else 0.0, fn)

    def poll(self) -> None:
        """Run what is due (answers paced in real time)."""
        if not self._timers:
            return
        now = time.monotonic()
        due = [x for x in self._timers if x[0] <= now]
        self._timers = [x for x in self._timers if x[0] > now]
        for _, fn in sorted(due, key=lambda x: x[0]):
            fn()

    def next_due(self) -> float | None:
        return min((d for d, _ in self._timers), default=None)

    def close(self) -> None:
        for sub in self._subs:
            sub.cancel()
        if self.token is not None:
            self.token.undeclare()


class RobotAgent(_Agent):
    """A simulated robot arm (see the module docstring)."""

    def __init__(
        self,
        name: str,
        scenario: ScenarioLike,
        transport: Transport,
        *,
        execution: ExecutionModel | None = None,
        timeout_factor: float = 3.0,
        trace: Callable[[str], None] | None = None,
        journal: str | Path | None = None,
        on_executed: OnExecuted | None = None,
    ) -> None:
        super().__init__(name, scenario, transport, execution=execution, trace=trace)
        check_agent_name(self.domain, name, "robot", "--arm")
        self.timeout_factor = timeout_factor
        # an observer of what this arm physically does (a simulated workspace's truth)
        self.on_executed = on_executed
        # what this arm did, per run (a command id names a command of one run only)
        self.runs: dict[str | None, _RunMemory] = {}
        self.run: str | None = None  # the run of the last command
        self._mem = self.runs.setdefault(None, _RunMemory())
        self.executed: list[int] = []  # command ids in execution order (each once per run)
        self.journal: EventLogWriter | None = None
        self.journal_path = Path(journal) if journal is not None else None
        self.journal_run: str | None = None  # the run the journal keeps (None: none yet)
        if journal is not None:
            self._load_journal(Path(journal))
            self.journal = EventLogWriter(journal, option="--journal", append=True)
        self._subs.append(transport.subscribe(P.cmd_topic(name), self._on_message))
        self._join()
        self._announce()

    # the memory of the current run (the ROS 2 arm reads these three)
    @property
    def acks(self) -> dict[int, dict[str, Any]]:
        """Command id -> its ack, sent again when the id is repeated (this run)."""
        return self._mem.acks

    @property
    def running(self) -> set[int]:
        return self._mem.running

    @property
    def stopped(self) -> set[int]:
        return self._mem.stopped

    @property
    def interrupted(self) -> set[int]:
        """Commands of this run an earlier process of this agent started and never finished."""
        return self._mem.interrupted

    def _enter_run(self, msg: dict[str, Any]) -> bool:
        """Switch the memory to the run ``msg`` belongs to; False (and :attr:`fatal`) when the
        journal keeps another run."""
        run = msg.get(identity.RUN)
        if run is not None and self.journal_path is not None:
            if self.journal_run is None:
                self.journal_run = str(run)
            elif run != self.journal_run:
                if self.fatal is None:
                    self.fatal = (
                        f"--journal {self.journal_path}: the journal is of run "
                        f"{self.journal_run}, the cell runs run {run}: a journal keeps one "
                        "run; give this agent a new journal file"
                    )
                    log.error("%s", self.fatal)
                return False
        if run != self.run:
            self.run = run
            self._mem = self.runs.setdefault(run, _RunMemory())
        return True

    def _load_journal(self, path: Path) -> None:
        """What earlier processes of this agent did (``--journal``): their acks are answered
        again, a command they started and never finished is answered ``failed``."""
        if not path.exists() or path.stat().st_size == 0:
            return
        from flexhrc.files import read_text

        started: dict[str | None, set[int]] = {}
        for n, line in enumerate(read_text(path).splitlines(), 1):
            try:
                rec = json.loads(line)
                cid = int(rec["id"])
                run = rec.get(identity.RUN)
                if run is not None and not isinstance(run, str):
                    raise TypeError("run")
            except (ValueError, KeyError, TypeError):
                log.warning("%s:%d: not a journal record (a write cut short?): skipped", path, n)
                continue
            mem = self.runs.setdefault(run, _RunMemory())
            if run is not None:
                self.journal_run = run  # a journal keeps one run (``_enter_run``)
            if rec.get("event") == "start":
                started.setdefault(run, set()).add(cid)
                if isinstance(rec.get("action"), str):
                    mem.actions[cid] = rec["action"]
            elif rec.get("event") == "ack" and isinstance(rec.get("ack"), dict):
                mem.acks[cid] = rec["ack"]
        for run, ids in started.items():
            mem = self.runs[run]
            mem.interrupted = ids - set(mem.acks)
        done = sum(len(m.acks) for m in self.runs.values())
        cut = sum(len(m.interrupted) for m in self.runs.values())
        of = f" of run {self.journal_run}" if self.journal_run else ""
        self.trace(f"journal {path}{of}: {done} commands done, {cut} interrupted")

    def _run_field(self) -> dict[str, Any]:
        """``{"run": ...}`` of the current run for an answer or a journal line (none: legacy)."""
        return {identity.RUN: self.run} if self.run is not None else {}

    def _journal(self, record: dict[str, Any]) -> None:
        if self.journal is not None:
            self.journal.write(record)

    def close(self) -> None:
        super().close()
        if self.journal is not None:
            self.journal.close()

    def _on_message(self, data: Any) -> None:
        self._receive(data, ("command", "stop"), self._command_or_stop)

    def _command_or_stop(self, msg: dict[str, Any]) -> None:
        if msg["type"] == "stop":
            self._stop(msg)
        else:
            self._command(msg)

    def _stop(self, msg: dict[str, Any]) -> None:
        cid = int(msg["id"])
        if self.run is not None and msg.get("run") != self.run:
            raise P.ProtocolError(f"a stop of run {msg.get('run')!r} for cmd {cid}: not ours")
        if cid in self.running:
            self.running.discard(cid)
            self.stopped.add(cid)
            self.trace(f"cmd {cid} stopped: {msg.get('reason')}")

    def _started(self, cid: int, action: GroundAction, ack: dict[str, Any]) -> None:
        """Command ``cid`` was executed on the model and now runs; ``ack`` is the answer due at
        its end (``ack["duration"]`` simulated seconds). A hook: the ROS 2 arm publishes the
        command's joint trajectory here."""

    def _take_joints(self, joints: dict[str, list[float]]) -> None:
        """Start from where the manager's robot model has the command's arms: in a process of
        its own this arm's world does not see the other arms' commands — nor its own part of a
        joint command its lead arm executed. (The ROS 2 arm reads the arms' joint states
        instead.)"""
        set_joint_state = getattr(self.execution, "set_joint_state", None)
        if joints and set_joint_state is not None:
            set_joint_state(joints)

    def _fail_at_once(self, cid: int, msg: dict[str, Any], reason: str, said: str) -> None:
        """Answer command ``cid`` with a failed ack without running it (it names its run, as
        every ack does, in the message and in the journal)."""
        ack = P.message(
            "ack", id=cid, agent=self.name, status="failed", reason=reason, t=float(msg["t"]),
            duration=0.0, positions={}, **self._run_field(),
        )  # fmt: skip
        self.acks[cid] = ack
        self._journal({"id": cid, "event": "ack", "ack": ack, **self._run_field()})
        self.transport.publish(P.ACK_TOPIC, ack)
        self.trace(f"cmd {cid} {said}: failed")

    def _command(self, msg: dict[str, Any]) -> None:
        cid = int(msg["id"])
        if not self._of_this_scenario(msg) or not self._enter_run(msg):
            return
        mem = self._mem
        known = mem.actions.get(cid)
        if known is not None and known != msg["action"]:
            raise P.ProtocolError(
                f"command {cid} repeated with another action: {msg['action']} (it was "
                f"{known}); refused, not answered from memory"
            )
        if cid in self.acks:  # already done: the manager missed the answer (it restarted)
            self.trace(f"cmd {cid} repeated: ack sent again")
            self.transport.publish(P.ACK_TOPIC, self.acks[cid])
            return
        if cid in self.running:
            self.trace(f"cmd {cid} repeated while running: ignored")
            return
        if cid in self.stopped:
            # the manager sends a command again that this arm was told to stop: it did not
            # send that stop (a spoofed one, P14) or no longer knows of it; a failed ack lets
            # it re-plan instead of waiting for an answer that never comes
            self.stopped.discard(cid)
            self._fail_at_once(cid, msg, "stopped before its end", "repeated after a stop")
            return
        if cid in self.interrupted:  # started by a process of this agent that died
            self.interrupted.discard(cid)
            self._fail_at_once(
                cid, msg, "interrupted: the agent's process was restarted during it",
                "was interrupted by a restart",
            )  # fmt: skip
            return
        if self.name not in msg["agents"]:
            raise P.ProtocolError(f"command {cid} is for {msg['agents']}, not {self.name}")
        action = ground(
            self.domain, msg["action"], tuple(msg["agents"]), process=bool(msg.get("process"))
        )
        sync_world(self.kb, msg.get("world") or {})
        self._take_joints(msg.get("joints") or {})
        positions = {k: o.position for k, o in self.kb.objects.items()}
        before = dict(positions)
        self.executed.append(cid)
        mem.actions[cid] = msg["action"]
        self._journal({"id": cid, "event": "start", "action": msg["action"], **self._run_field()})
        report = self.execution.execute(action, positions, self.kb, self.domain)
        status, duration = report.status, float(report.duration_s)
        # a process round's report says what its behaviour observed (a push undone)
        reason = None if status == "done" and not msg.get("process") else report.reason
        limit = max(float(msg.get("expected_s", 0.0)) * self.timeout_factor, 1.0)
        if status == "done" and duration > limit:
            status, reason, duration = "timed_out", f"no result after {limit:.1f} s", limit
        if self.on_executed is not None:
            t0 = float(msg["t"])
            ex = Executed(self.name, cid, action, before, t0, t0 + duration, status)
            failed = self.on_executed(ex)
            if failed is not None and status == "done":
                status, reason = "failed", failed
        moved = {k: list(map(float, p)) for k, p in positions.items() if before.get(k) != p}
        joint_state = getattr(self.execution, "joint_state", None)
        joints = {} if joint_state is None else joint_state(action.agents)
        ack = P.message(
            "ack",
            id=cid,
            agent=self.name,
            status=status,
            reason=reason,
            t=float(msg["t"]) + duration,  # unrounded: the cell's clock adds up exactly
            duration=round(duration, 6),
            positions=moved if status == "done" else {},
            **({"joints": joints} if joints else {}),
            **self._run_field(),
        )
        self.running.add(cid)
        run = self._run_field()
        self.trace(f"execute cmd {cid} {action} ({duration:.2f} s)")
        self._started(cid, action, ack)

        def finish() -> None:
            if cid not in mem.running:
                return  # stopped meanwhile
            mem.running.discard(cid)
            mem.acks[cid] = ack
            self._journal({"id": cid, "event": "ack", "ack": ack, **run})
            self.transport.publish(P.ACK_TOPIC, ack)
            self.trace(f"cmd {cid} {status}")

        self._paced(msg, duration, finish)


class HumanAgent(_Agent):
    """A simulated operator: it carries out the suggestions it gets and, unless ``passive``,
    acts on its own as its profile says (see the module docstring)."""

    def __init__(
        self,
        name: str,
        scenario: ScenarioLike,
        transport: Transport,
        *,
        profile: str = "passive",
        seed: int = 0,
        execution: ExecutionModel | None = None,
        trace: Callable[[str], None] | None = None,
        takes: Iterable[int | str] | None = None,
        on_executed: OnExecuted | None = None,
        sensing: HumanSensing | None = None,
        replies: Replies | None = None,
    ) -> None:
        check_profile(profile)
        super().__init__(
            name, scenario, transport, execution=execution or AnalyticSimulator(), trace=trace
        )
        check_agent_name(self.domain, name, "human", "--name")
        self.profile = profile
        self.on_executed = on_executed
        # None: the manager is told what the operator did; else only what this wearable
        # sensor recognised (a miss is a miss: the report says nothing was recognised)
        self.sensing = sensing
        self.sensed: list[dict[str, Any]] = []  # what the sensor made of each action done
        # (run, suggestion) -> step -> report; (run, suggestion) -> its actions
        self.reports: dict[tuple[str | None, str], dict[int, dict[str, Any]]] = {}
        self.asked: dict[tuple[str | None, str], list[str]] = {}
        self.busy: set[tuple[str | None, str, int]] = set()  # steps being carried out
        # when the action in hand ends (simulated clock): a person finishes it before the next,
        # even when the manager has dropped the request it belonged to
        self.free_at = 0.0
        # its answers beyond "done" (see :data:`Replies`), and those it sent, by request step
        self.replies = replies
        self.replied: dict[tuple[str | None, str, int], dict[str, Any]] = {}
        self._subs.append(transport.subscribe(P.suggest_topic(name), self._on_message))
        # the profile's own decisions (the same code as the in-process operators)
        # ``takes``: a script (the K-th steps, 1-based, or node names) instead of the profile
        self.takes = set(takes) if takes is not None else None
        self.operator = (
            SimulatedOperator(name, profile, seed, self.takes)
            if profile != "passive" or self.takes is not None
            else None
        )
        # (run, options id) -> the intent sent for it, and the steps it answered
        self.intents: dict[tuple[str | None, str], dict[str, Any]] = {}
        self._offered: dict[tuple[str | None, str], Any] = {}
        self._announced_at = float("-inf")
        # the manager's ``state`` showed this operator's profile: only then its token goes out
        self.heard = self.operator is None
        self._join()  # first: the manager takes a profile only from the process that joined
        if self.operator is not None:
            self._subs.append(transport.subscribe(P.options_topic(name), self._on_options))
            watch = getattr(transport, "watch_liveliness", None)
            if watch is not None:  # a manager that (re)appears has not heard it yet
                self._subs.append(watch(P.alive_key(P.MANAGER), self._on_manager))
            self._announce_profile()
        self._announce()

    def _announce(self) -> None:
        """The liveliness token of an operator that acts on its own waits until the manager
        has acknowledged its profile (a ``state`` that shows it): a publication can be lost
        while the token is not (Zenoh drops a message its session knows no subscriber for
        yet, DDS one sent before the match; the token travels another way), and a manager
        that saw the token but not the profile would start without it (``docs/protocol.md``,
        "Operators that act on their own"). Over a transport without tokens (the in-process
        bus, which loses nothing) there is nothing to wait for."""
        if self.heard or getattr(self.transport, "declare_token", None) is None:
            super()._announce()

    def _announce_profile(self) -> None:
        """Tell the manager this operator acts on its own: at the start, again whenever the
        manager's token appears, every :data:`ANNOUNCE_RETRY_S` until the manager acknowledged
        it, and again if a snapshot shows it was not heard."""
        self._announced_at = time.monotonic()
        extra = {"scripted": True} if self.takes is not None else {}
        msg = P.message("operator", agent=self.name, profile=self.profile, **extra)
        self.transport.publish(P.INTENT_TOPIC, msg)
        if not self.heard and self.token is None:
            self._later(ANNOUNCE_RETRY_S, self._retry_announce)

    def _retry_announce(self) -> None:
        # a retry on a lossy channel (the answer is a ``state``), not a wait for time to pass
        if not self.heard and time.monotonic() - self._announced_at >= ANNOUNCE_RETRY_S:
            self._announce_profile()

    def _on_manager(self, key: str, alive: bool) -> None:
        if alive and not self.heard:
            # the manager declares its subscriptions before its token (and Zenoh keeps a
            # session's declarations in order): a profile sent now reaches it
            self._announce_profile()

    def _on_state(self, data: Any) -> None:
        super()._on_state(data)
        if self.operator is None or not isinstance(data, dict) or data.get("type") != "state":
            return
        known = data.get("operators")
        heard = isinstance(known, dict) and known.get(self.name) == self.profile
        if self.takes is not None:
            scripted = data.get("scripted")
            heard = heard and isinstance(scripted, list) and self.name in scripted
        if heard and not self.heard:
            self.heard = True
            self.trace(f"the manager knows profile {self.profile}: ready")
            self._announce()
        elif not heard and time.monotonic() - self._announced_at > 1.0:
            self._announce_profile()

    def _on_options(self, data: Any) -> None:
        self._receive(data, "options", self._options)

    def _options(self, msg: dict[str, Any]) -> None:
        """Decide, once per step, whether to act on it alone (:meth:`SimulatedOperator.decide`)
        and answer with an ``intent``; a repeated ``options`` gets the same answer."""
        op = self.operator
        assert op is not None
        if not self._of_this_scenario(msg):
            return
        run = msg.get(identity.RUN)
        oid = msg["id"]
        key = (run, oid)
        if key in self.intents:
            if self._offered.get(key) != msg["steps"]:
                raise P.ProtocolError(
                    f"options {oid} repeated with other steps; refused, not answered from memory"
                )
            self.transport.publish(P.INTENT_TOPIC, self.intents[key])
            return
        sync_world(self.kb, msg.get("world") or {})
        t = float(msg["t"])
        decided: list[str] = []
        fields: dict[str, Any] = {"act": False}
        for st in msg["steps"]:
            step = str(st["step"])
            arcs = [(float(a["cost"]), str(a["hyperarc"])) for a in st["arcs"]]
            decided.append(step)
            intention = op.decide(step, arcs)
            if intention is None:
                continue
            arc = next(a for a in st["arcs"] if a["hyperarc"] == intention.hyperarc)
            if not arc["branches"]:  # nothing of it is free for this operator: it gives up
                self.trace(f"gives up {intention.hyperarc} ({step}): nothing free to do it with")
                t += intention.delay_s  # after thinking, as a run's operator does
                break
            branches = [[ground(self.domain, x) for x in b] for b in arc["branches"]]
            branch = op.pick_branch(self.kb, self.domain, branches)
            fields = {
                "act": True,
                "step": step,
                "hyperarc": intention.hyperarc,
                "actions": [str(a) for a in branch],
                "delay": round(intention.delay_s, 6),
            }
            t = max(t + intention.delay_s, self.free_at)  # when it starts: the manager
            self.trace(f"decides to do {intention.hyperarc} ({step}) alone")  # keeps time order
            break
        intent = P.message(
            "intent", id=f"{self.name}:{oid}", agent=self.name, options=oid, decided=decided,
            t=t, **fields, **({identity.RUN: run} if run is not None else {}),
        )  # fmt: skip
        self.intents[key] = intent
        self._offered[key] = msg["steps"]
        self.transport.publish(P.INTENT_TOPIC, intent)

    def _on_message(self, data: Any) -> None:
        self._receive(data, "suggestion", self._suggestion)

    def _suggestion(self, msg: dict[str, Any]) -> None:
        """Carry out step ``step`` of a suggestion in the world the message carries; the manager
        sends the next step, with the world as it is then, once it has handled this one."""
        if not self._of_this_scenario(msg):
            return
        sid, k = msg["id"], int(msg.get("step", 0))
        run = msg.get(identity.RUN)
        key = (run, sid)
        asked = self.asked.setdefault(key, list(msg["actions"]))
        if asked != msg["actions"]:
            raise P.ProtocolError(
                f"suggestion {sid} repeated with other actions: {'; '.join(msg['actions'])} "
                f"(it was {'; '.join(asked)}); refused, not answered from memory"
            )
        done = self.reports.setdefault(key, {})
        if k in done:  # the manager missed the report (it restarted): send it again
            self.trace(f"suggestion {sid} step {k} repeated: report sent again")
            self.transport.publish(P.HUMAN_TOPIC, done[k])
            return
        if (run, sid, k) in self.busy:
            return
        steps = [ground(self.domain, a) for a in msg["actions"]]
        if not 0 <= k < len(steps):
            raise P.ProtocolError(f"suggestion {sid}: no step {k} in {len(steps)} actions")
        step = steps[k]
        if self.name not in step.agents:
            raise P.ProtocolError(f"suggestion {sid}: {step} is not for {self.name}")
        if (run, sid, k) in self.replied:  # asked again (the manager restarted): same answer
            self.transport.publish(P.HUMAN_TOPIC, self.replied[(run, sid, k)])
            return
        answer = self._answer(msg, k)
        if answer is not None and self._reply(msg, k, answer):
            return
        said_start = answer is not None
        sync_world(self.kb, msg.get("world") or {})
        positions = {key: o.position for key, o in self.kb.objects.items()}
        before = dict(positions)
        t = max(float(msg["t"]), self.free_at)
        dt = float(self.execution.execute(step, positions, self.kb, self.domain).duration_s)
        self.free_at = t + dt
        moved = {key: list(map(float, p)) for key, p in positions.items() if before.get(key) != p}
        rid = f"{self.name}:{sid}:{k}"
        if self.on_executed is not None:
            self.on_executed(Executed(self.name, rid, step, before, t, t + dt, "done"))
        fields: dict[str, Any] = {"action": str(step), **self._sense(step, steps, t + dt)}
        if not said_start:  # else the manager knows the start from the "I'm starting"
            fields["start"] = t
        rep = P.message(
            "human_action",
            id=rid,
            agent=self.name,
            suggestion=sid,
            step=k,
            t=t + dt,
            positions=moved,
            **fields,
            **({identity.RUN: run} if run is not None else {}),
        )
        if k == 0:
            self.trace(f"suggestion {sid}: {msg['element']}")
        self.busy.add((run, sid, k))

        def send() -> None:
            self.busy.discard((run, sid, k))
            done[k] = rep
            self.transport.publish(P.HUMAN_TOPIC, rep)
            self.trace(f"did {rep['action']}")

        self._paced(msg, dt, send)

    def _answer(self, msg: dict[str, Any], k: int) -> tuple[str, str | None] | None:
        """What this operator answers to step ``k`` of a request other than doing it (its
        ``replies``, else its profile's ``answer`` if it has one): (reply, reason) or None."""
        if msg.get("own"):
            return None  # its own plan: it decided to do it
        if self.replies is not None:
            said = self.replies(str(msg["element"]), list(msg["actions"]), k)
            if said is None:
                return None
            return (said, None) if isinstance(said, str) else (str(said[0]), str(said[1]))
        # a profile that answers (``reluctant``: SimulatedOperator.answer) says so once per
        # request, when it is put to it (step 0); a request asked again gets the same answer
        answer = getattr(self.operator, "answer", None)
        if answer is None or k != 0:
            return None
        kind, reason = answer([ground(self.domain, a) for a in msg["actions"]], self.domain)
        return None if kind == "follow" else (str(kind), reason)

    def _reply(self, msg: dict[str, Any], k: int, answer: tuple[str, str | None]) -> bool:
        """Send the ``reply`` (after :data:`REPLY_S`; ``start`` at once); returns whether
        that answers the step (False: ``start``, the step is done next)."""
        kind, reason = answer
        run, sid = msg.get(identity.RUN), str(msg["id"])
        if kind == "ignore":
            self.trace(f"suggestion {sid}: no answer")
            return True
        t = max(float(msg["t"]), self.free_at) + (0.0 if kind == "start" else REPLY_S)
        reply = P.message(
            "reply", id=f"{self.name}:{sid}:{k}:{kind}", agent=self.name, reply=kind,
            suggestion=sid, step=k, t=t, **({"reason": reason} if reason else {}),
            **({identity.RUN: run} if run is not None else {}),
        )  # fmt: skip
        self.trace(f"suggestion {sid}: {kind}" + (f" ({reason})" if reason else ""))
        if kind == "start":
            self.transport.publish(P.HUMAN_TOPIC, reply)
            return False
        self.replied[(run, sid, k)] = reply
        self._paced(msg, REPLY_S, lambda: self.transport.publish(P.HUMAN_TOPIC, reply))
        return True

    def sensing_figures(self) -> dict[str, int]:
        """What the wrist sensor made of this operator's actions (the ``human_sensing`` key of
        a run's JSON): ``performed`` = ``recognised`` + ``missed`` + ``false_reports``;
        ``uncovered`` actions no sensor motion plays are confirmed directly, counted apart."""
        out = {"performed": 0, "recognised": 0, "missed": 0, "false_reports": 0, "uncovered": 0}
        for rec in self.sensed:
            what = str(rec.get("outcome"))
            if what == "uncovered":
                out["uncovered"] += 1
                continue
            out["performed"] += 1
            out["false_reports" if what in ("false_report", "unusable") else what] += 1
        return out

    def _sense(self, step: GroundAction, plan: list[GroundAction], t: float) -> dict[str, Any]:
        """The fields a wearable sensor adds to a report: ``sensed`` (its figures), and
        ``recognised`` — false when it missed the action (the manager is not told); a
        recognised action other than the one done is reported in its place."""
        if self.sensing is None:
            return {}
        sensed = self.sensing.sense(step.name)
        rec = {"t": t, "action": str(step), **sensed.to_dict()}
        self.sensed.append(rec)
        if sensed.recognised is None:
            # no motion of the sensor plays this action (a visual check): the operator confirms
            # it some other way (the panel's "done"); else a miss
            rec["outcome"] = "uncovered" if not sensed.samples else "missed"
            return {"sensed": rec, "recognised": not sensed.samples}
        name = str(sensed.recognised)
        action = _fit(self.domain, name, step, plan)
        if action is None:
            rec["outcome"] = "unusable"
            return {"sensed": rec, "recognised": False}
        rec["outcome"] = "recognised" if action == str(step) else "false_report"
        return {"sensed": rec, "action": action}


def _fit(domain: Domain, name: str, step: GroundAction, plan: list[GroundAction]) -> str | None:
    """The recognised action ``name`` with the arguments its schema takes: those of the step
    done, or — when it takes more (a pick-up taken for a screw) — those of the operator's next
    step of that name that starts with them."""
    schema = domain.actions.get(name)
    if schema is None:
        return None
    n = len(schema.parameters)
    if n <= len(step.args):
        return f"{name}({', '.join(step.args[:n])})"
    for other in plan:
        if other.name == name and other.args[: len(step.args)] == step.args:
            return str(other)
    return None


def run_agent(agent: _Agent, transport: Any, *, until: Callable[[], bool] | None = None) -> str:
    """Serve until the cell announces its end (returns its outcome) or ``until()`` is true;
    a :class:`~flexhrc.errors.FlexhrcError` when the agent was refused (:attr:`_Agent.fatal`:
    a cell of another scenario, a journal of another run)."""

    def fatal() -> str | None:  # an agent of another kind (perception) is never refused
        return getattr(agent, "fatal", None)

    while agent.ended is None and fatal() is None and not (until and until()):
        due = agent.next_due()
        timeout = 0.2 if due is None else max(0.0, min(0.2, due - time.monotonic()))
        transport.wait(timeout)
        transport.flush()
        agent.poll()
    refused = fatal()
    if refused is not None:
        transport.flush()  # let the join that names the refusal leave
        raise FlexhrcError(refused)
    return agent.ended or "stopped"


@dataclass
class _RunMemory:
    """What a robot agent did in one run: acks (sent again on a repeated id), the action of
    each command id (a repeat with another action is refused), what runs, what was stopped,
    what an earlier process of the agent started and never finished."""

    acks: dict[int, dict[str, Any]] = field(default_factory=dict)
    actions: dict[int, str] = field(default_factory=dict)
    running: set[int] = field(default_factory=set)
    stopped: set[int] = field(default_factory=set)
    interrupted: set[int] = field(default_factory=set)


def _check_single_holder(transport: Any, name: str) -> None:
    """One process per agent name in a cell: a token ``alive/<name>`` already alive refuses
    this one (the first holder keeps it). Over a transport that cannot be asked (the
    in-process bus), nothing is checked."""
    holders = getattr(transport, "liveliness_holders", None)
    if holders is None:
        return
    # a session that just connected learns the tokens of peers beyond its first one a moment
    # later: ask again for a short while (at start only) before taking the name as free
    settle = time.monotonic() + (HOLDER_SETTLE_S if getattr(transport, "dials", False) else 0.0)
    held = holders(P.alive_key(name))
    while not held and time.monotonic() < settle:
        time.sleep(0.02)
        held = holders(P.alive_key(name))
    if held:
        raise FlexhrcError(
            f"agent {name}: another process already serves this agent in the cell (its "
            f"liveliness token {P.alive_key(name)} is alive); a second one is refused (a "
            "process that just died keeps it until its liveliness lease ends: about 10 s over "
            "Zenoh, 1 s over ROS 2)"
        )
