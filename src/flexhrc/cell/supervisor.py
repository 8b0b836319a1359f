"""The cell: the Task Manager as a service over a transport, with an event store.

:class:`Cell` is a thin loop around the sans-IO :class:`~flexhrc.taskmanager.TaskManager`:
**receive** a message, **store** it (committed), **feed** it to the manager, **send** what the
manager decided. Inputs are ``start``, ``ack``, ``human_action``, ``agent_up`` and
``agent_down``; outputs are commands, suggestions and stops (``docs/cell.md``).

Time. With ``realtime == 0`` (or agents inside the process) the cell runs a conservative
discrete-event loop: an answer carries the simulated time ``t`` at which the action ended, and
the cell handles the earliest answer only once every agent it waits for has answered. The order
of inputs — and so every decision — is then the same on every run with the same seed, whatever
the processes' speeds. With external agents and ``realtime > 0`` the agents take real time and the
cell handles answers as they come, like a real cell.

Where the arms are. On the kinematic robot model the manager scores each branch from where the
arms are. Each command carries the ``joints`` of its arms as the manager's model has them (an arm
in a process of its own starts from there), the model moves through the command as it is sent,
and the arm's ack carries the ``joints`` it really ended at. In one process whose arms execute
on the manager's model itself (``shared_model=True``) the model moves with them.

Lost agents. Over Zenoh every agent holds a liveliness token ``alive/<agent>``. When it goes (the
process died), the cell stores ``agent_down``, tells the manager the agent is unavailable and
acknowledges each command it was running as ``failed`` with reason ``agent lost`` (stored acks,
so a resume replays them); the manager re-plans with the others. When the token comes back
(``agent_up``) the agent is used again.

Operators that act on their own. An operator agent with a profile other than ``passive``
announces it (``operator``). Whenever such an operator is idle and a cooperation step it may do
alone has become reachable, the cell sends it ``options`` — the steps, their hyper-arcs with costs
(eq. 10) and the ground branches it can do alone now — and, in the discrete-event loop, waits for
its ``intent`` as it waits for an arm's ack. An intent to act carries the time the person starts
(after thinking); at that time the cell checks that the branch is still free and hands it to the
operator step by step, as a suggestion marked ``own``. The manager learns of it only from the
reported ``human_action`` s, as of any person who acts without being asked (paper 000, V-C).
Intents are stored inputs, so a resumed cell decides the same.

Resume. ``Cell(..., resume=True)`` replays the stored inputs into a fresh manager (deterministic:
the same commands with the same ids come out), then sends every outstanding command again under
its original id as soon as its agent is alive; agents answer a repeated id with their stored ack
and never execute it twice.

Boundary for panels and bridges: :meth:`Cell.snapshot` is the whole visible state as a JSON-able
dict (also published on ``state`` after every event); a person's inputs come in through
:meth:`Cell.human_input` (what they did), :meth:`Cell.human_take` (what they will do) and
:meth:`Cell.halt_agent` / :meth:`Cell.release_agent` (an arm stopped and resumed by hand). Each
is a stored input, so a resumed cell replays it; call them on the cell's own thread.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from flexhrc.cell import identity
from flexhrc.cell import protocol as P
from flexhrc.cell.components import ScenarioLike, ground, unknown_name, world_of
from flexhrc.cell.store import (
    EventStore,
    StoredEvent,
    action_end,
    action_start,
    check_events,
    log_events,
)
from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import STORED_LOG_TYPES  # the manager records the store keeps
from flexhrc.knowledge import Inconsistency
from flexhrc.logic import apply_substitution
from flexhrc.taskmanager.diagnose import stall_reason
from flexhrc.taskmanager.domain import GroundAction
from flexhrc.taskmanager.manager import (
    FAILURE_POLICIES,
    Ack,
    Command,
    Directive,
    HumanAction,
    Stop,
    Suggest,
    TaskManager,
    check_failure_policy,
)
from flexhrc.taskmanager.operator import PROFILES, SimulatedOperator
from flexhrc.taskmanager.physical import apply_physical
from flexhrc.taskmanager.policy import DEFAULT_POLICY, check_policy, make_policy
from flexhrc.taskmanager.simulator import Simulator, simulator_name
from flexhrc.transport import Transport

log = logging.getLogger("flexhrc.cell")

AGENT_LOST = "agent lost"
#: The loop did not run for this long (seconds, its own pacing aside): the manager process was
#: stalled, and liveliness tokens lost then are doubted (:meth:`Cell._pump`).
STALL_S = 2.0
#: How long a token lost during or just after a stall may take to come back (seconds): agents
#: re-dial within a second (``flexhrc.transport.zenoh``).
STALL_GRACE_S = 5.0
#: How long a resumed cell whose run had already ended waits for agent processes to come back
#: and hear the end (seconds).
END_WAIT_S = 5.0
#: How often a manager whose run has ended says so again while agent processes are still there.
END_REPEAT_S = 0.5
#: The ``source`` of an input that did not come over the bus (the panel's buttons, this process).
HERE = "here"


@dataclass
class AgentState:
    name: str
    kind: str  # robot | human
    alive: bool = False  # its liveliness token is present (always True in one process)
    available: bool = True  # the manager may plan with it
    seen: bool = False

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "alive": self.alive, "available": self.available}


class Cell:
    """The manager side of a cell (see the module docstring)."""

    _captured: list[tuple[str, dict[str, Any]]] | None = None
    #: how to start a missing agent, said when none came (a ROS 2 cell names its own nodes)
    agents_hint = "start them with `flexhrc agent robot|human SCENARIO ... --connect ENDPOINT`"

    def __init__(
        self,
        scenario: ScenarioLike,
        transport: Transport,
        *,
        store: EventStore | None = None,
        resume: bool = False,
        realtime: float = 0.0,
        ordered: bool | None = None,
        agent_speed: float | None = None,
        simulator: Simulator | None = None,
        liveliness: bool = True,
        name: str = "default",
        trace: Callable[[dict[str, Any]], None] | None = None,
        seed: int = 0,
        watchers: Iterable[str] = (),
        reaction: str = "conflicts",
        observers: Iterable[Callable[[dict[str, Any]], None]] = (),
        max_time_s: float | None = None,
        idle_s: float = 0.5,
        publish_state: bool = True,
        quiescent: Callable[[], bool] | None = None,
        shared_model: bool = False,
        on_failure: str | None = None,
        answer_timeout: float | None = None,
        policy: str | None = None,
    ) -> None:
        if not realtime >= 0 or realtime != realtime or realtime == float("inf"):
            raise FlexhrcError(f"--realtime must be a finite number >= 0, got {realtime}")
        self.scenario = scenario
        self.name = name
        self.seed = seed
        self.answer_timeout = answer_timeout_of(scenario, answer_timeout)
        self.transport = transport
        if liveliness:
            self._check_single_manager(transport, name)
        # run identity (flexhrc.cell.identity): a new run's id; a resume takes the stored one
        self.run_id = identity.new_run_id()
        self.refused: dict[str, str] = {}  # agent -> why its process was refused (join)
        # over a transport that names each message's sending session (Zenoh): agent -> the
        # session granted its name at its join; a message for it from any other is dropped
        self.sessions: dict[str, str] = {}
        self.refused_sessions: dict[str, str] = {}  # session -> why its join was refused
        self.sourced = callable(getattr(transport, "subscribe_from", None))
        self._token_alive: dict[str, bool] = {}  # agent -> its token, as Zenoh reports it
        # agents whose token went away since their name was granted: the granted process died
        # (or lost its link), so the next process to join takes the name — even when its token
        # arrives before its join, as it may on a loaded machine
        self._vacated: set[str] = set()
        self._asked_joins_at = -1e9  # when the manager last asked for missing joins
        self.store = store
        self.realtime = float(realtime)
        self.ordered = (self.realtime == 0) if ordered is None else ordered
        self.agent_speed = self.realtime if agent_speed is None else agent_speed
        self.trace = trace or (lambda ev: None)
        # the cooperation log as it happens (``flexhrc run --log``, the timeline, replay): every
        # manager event and the loop's own, in log form (see :func:`observe_record`)
        self.observers = list(observers)
        self.max_time_s = max_time_s
        self.idle_s = idle_s
        self.publish_state = publish_state  # the snapshot on ``state`` after every event
        # agents in this process: ``quiescent()`` says none of them has anything left to say,
        # so an agent the loop waits for (e.g. an operator no one plays) will never answer
        self.quiescent = quiescent
        self.shared_model = shared_model
        self._start_joints: dict[int, dict[str, Any]] = {}  # command id -> its "joints"
        # command id -> when it was issued: a command sent again (after a resume, or overdue)
        # still starts then, so an arm that executes it only now ends when it would have
        self._issued_at: dict[int, float] = {}
        self._stop_reason: str | None = None
        self._command_start: dict[int, float] = {}
        self.graph = scenario.online_graph()
        self.domain = scenario.domain
        self.kb = scenario.world()
        self.fingerprint = identity.fingerprint(scenario, graph=self.graph, world=self.kb)
        if simulator is None:
            simulator = scenario.make_simulator(None)  # the scenario's own choice
        self.tm = TaskManager(
            self.graph,
            self.domain,
            self.kb,
            simulator,
            log=self._tm_log,
            reaction=reaction,
            on_failure=failure_policy(scenario, on_failure),
            utility=getattr(scenario, "utility", None),
        )
        # the decision policy (``--policy``, the scenario's ``policy:``; paper: no advisor)
        self.policy = decision_policy(scenario, policy)
        self.tm.policy = make_policy(self.policy)
        self.agents = {
            a.name: AgentState(a.name, "human" if a.is_human else "robot")
            for a in self.domain.agents.values()
        }
        if not liveliness:
            for st in self.agents.values():
                st.alive = st.seen = True
        self.now = 0.0
        self.events: list[StoredEvent] = []
        #: wall seconds the Task Manager took to answer each input that made a decision (the
        #: decision latency, :func:`latency_figures`; not kept in the store: it is the
        #: machine's, not the cooperation's)
        self.decision_latencies_s: list[float] = []
        self.commands: dict[int, Command] = {}
        self.stored_commands: set[int] = set()
        self.acked: set[int] = set()
        self.stopped: set[int] = set()  # commands the manager stopped
        self.suggestions: dict[str, dict[str, Any]] = {}
        self.active_suggestion: dict[str, str] = {}
        # suggestion id -> (the step to do next, when it starts): the operator gets one step at
        # a time, in the world as it is when that step starts
        self.suggestion_step: dict[str, tuple[int, float]] = {}
        self._sent_step: dict[str, int] = {}
        self._down_reason: dict[str, str] = {}
        # a stalled manager (see _pump): agents whose token went while it did not run, and
        # until when their token may come back before they count as lost
        self._doubtful: dict[str, float] = {}
        self._turn_end = time.monotonic()  # when the loop last got its messages
        self._slept = 0.0  # the loop's own pacing since then (not a stall)
        self._stalled_until = 0.0
        self.human_ids: set[str] = set()
        self._reported: set[tuple[str, str]] = set()  # (person, action) of reports handled
        self.superseded: dict[str, float] = {}  # suggestion id -> when a new request replaced it
        self._last_suggestion: dict[str, str] = {}  # human -> the suggestion last sent to them
        self.pending: list[tuple[float, int, str, dict[str, Any]]] = []
        self._arrivals = 0
        self.dropped: list[str] = []
        self.started = False
        self.replaying = False
        self.resumed = False
        self._wall0 = time.perf_counter()
        self._clock0: float | None = None
        self._last_wall = time.perf_counter()
        self._panel_inputs = 0
        self._sent_at: dict[int, float] = {}  # command id -> when it was last sent (monotonic)
        self.resent = 0
        # operators that act on their own: profile, steps they decided on, open ``options``
        self.operators: dict[str, str] = {}
        self.scripted: set[str] = set()  # operators that follow a script of steps
        self.decided: dict[str, set[str]] = {}
        self.awaiting: dict[str, str] = {}  # operator -> id of the options it has to answer
        self.options: dict[str, dict[str, Any]] = {}
        self.intent_ids: set[str] = set()
        self._options_sent_at: dict[str, float] = {}
        # operator answers (docs/protocol.md, "Operator answers"): reply ids handled; request
        # id -> by when (cell time) it must be answered, and when it was sent (wall clock);
        # requests whose timeout is on its way; person -> (the action, when) they said they start
        self.reply_ids: set[str] = set()
        self._answer_due: dict[str, float] = {}
        self._asked_wall: dict[str, float] = {}
        self._timed_out: set[str] = set()
        self._starts: dict[str, tuple[str | None, float]] = {}
        self._subs = [
            self._listen(P.ACK_TOPIC, self._on_ack_message),
            self._listen(P.HUMAN_TOPIC, self._on_human_message),
            transport.subscribe(P.PERCEPT_TOPIC, self._on_percept_message),
            self._listen(P.INTENT_TOPIC, self._on_intent_message),
            self._listen(P.JOIN_TOPIC, self._on_join),
        ]
        self.percept_ids: set[str] = set()
        # perception agents the ordered loop waits for (see the module docstring): the manager
        # decides first once they have looked, and moves on after each input only when they
        # have looked at the state it left (``looked``); one may ask to look at a later time
        self.watchers = list(watchers) if self.ordered else []
        self.begun = not self.watchers  # the manager has made its first decision
        self._looked: dict[str, int] = {}
        self._state_seq = 0
        self._wakes: set[tuple[str, float]] = set()
        # human_action id -> what its report did to the belief (to undo it when it was false)
        self._reports: dict[str, tuple[HumanAction, Any, Any, set[Any], set[Any]]] = {}
        if hasattr(transport, "on_drop"):
            transport.on_drop = lambda topic, data, exc: self._drop(
                f"{topic}: undecodable payload ({len(data)} bytes): {exc}"
            )
        watch = getattr(transport, "watch_liveliness", None)
        if liveliness and watch is not None:
            self._subs.append(watch(f"{P.ALIVE_PREFIX}/*", self._on_alive))
            self.token = transport.declare_token(P.alive_key(P.MANAGER))  # type: ignore[attr-defined]
        else:
            self.token = None
        if resume:
            if store is None:
                raise FlexhrcError("--resume needs --store FILE.db")
            self._replay(store.events())

    # -- the outside world --------------------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        """Everything a panel shows, JSON-able: outcome, agents, suggestions, timeline, KB."""
        busy = {a: c for a, c in self.tm.busy.items()}
        agents = {}
        for name, st in self.agents.items():
            cmd = busy.get(name)
            busy_now = name in self.active_suggestion if st.kind == "human" else bool(cmd)
            status = "lost" if not st.available else ("busy" if busy_now else "idle")
            agents[name] = {
                **st.to_dict(),
                "status": status,
                "command": {"id": cmd.id, "action": str(cmd.action)} if cmd else None,
            }
        timeline = [
            ev
            for ev in log_events(self.events[-400:])
            if ev["type"] in ("action_end", "command", "suggestion", "outcome")
        ][-100:]
        return {
            "cell": self.name,
            "scenario": self.scenario.name,
            "run": self.run_id,
            "fingerprint": self.fingerprint,
            "t": round(self.now, 6),
            "outcome": self.tm.outcome,
            "reason": self.tm.reason,
            "events_stored": len(self.events),
            "agents": agents,
            "suggestions": [
                {k: v for k, v in self.suggestions[sid].items() if k not in ("world", "v")}
                for sid in self.active_suggestion.values()
            ],
            "operators": dict(self.operators),
            "scripted": sorted(self.scripted),
            "timeline": timeline,
            "knowledge": self.kb.to_dict(),
            "dropped": len(self.dropped),
            # the processes refused an agent's name (another holds it): each exits on seeing it
            **({"refused_sessions": dict(self.refused_sessions)} if self.refused_sessions else {}),
            # agents whose token is alive but whose process has not joined (or whose granted
            # process died): each such process sends its ``join`` (again) on seeing its name
            **({"unjoined": unjoined} if (unjoined := self._unjoined()) else {}),
        }

    def human_input(
        self, action: str, agent: str | None = None, start: float | None = None
    ) -> None:
        """A person says what they did (a panel's "done" button): ``pick_up(human, leg2)``;
        ``start``: when they began (else when they said "I'm starting", else when the step
        was put to them: the report always carries a start, so ``replay`` and the timeline
        show how long the person worked)."""
        human = self._human(agent)
        self._panel_inputs += 1
        # on the wall clock the cell's time went on since the last input: the person acts now
        t = round(max(self.now, self._clock()), 6)
        began = self._start_of(human, action) if start is None else float(start)
        self._on_human_message(
            P.message(
                "human_action",
                id=f"panel:{self._panel_inputs}:{len(self.events)}",
                agent=human,
                action=action,
                t=t,
                **({"start": round(min(began, t), 6)} if began is not None else {}),
                run=self.run_id,
            )
        )

    def human_reply(
        self,
        reply: str,
        agent: str | None = None,
        *,
        suggestion: str | None = None,
        element: str | None = None,
        reason: str | None = None,
    ) -> None:
        """A person answers beyond "done" (a panel's buttons): ``decline`` ("not now"),
        ``cannot`` ("I can't do this", with ``reason``), ``start`` ("I'm starting") or
        ``give_back`` (a step they had taken). Without ``suggestion`` it answers the person's
        open request. A stored input ``human_reply`` once its time comes."""
        human = self._human(agent)
        sid = suggestion or self.active_suggestion.get(human)
        if sid is None and element is None and reply != "start":
            raise FlexhrcError(f"{human} has no open request to {reply}")
        self._panel_inputs += 1
        fields: dict[str, Any] = {"suggestion": sid} if sid is not None else {}
        if element is not None:
            fields["element"] = element
        if reason is not None:
            fields["reason"] = reason
        if reply == "start" and sid is not None:
            step = self.suggestion_step.get(sid, (0, 0.0))[0]
            fields["step"] = step
        self._on_human_message(
            P.message(
                "reply",
                id=f"panel:{self._panel_inputs}:{len(self.events)}",
                agent=human,
                reply=reply,
                t=round(max(self.now, self._clock()), 6),
                **fields,
                run=self.run_id,
            )
        )

    def _human(self, agent: str | None) -> str:
        human = agent or next((a for a, s in self.agents.items() if s.kind == "human"), None)
        if human is None:
            raise FlexhrcError("this scenario has no human agent")
        return human

    def _start_of(self, human: str, action: str | None) -> float | None:
        """When ``human`` began ``action``: when they said "I'm starting" it, else when the
        step of their open request was put to them (None: no request names it)."""
        said = self._starts.get(human)
        if said is not None and (said[0] is None or action is None or said[0] == action):
            return said[1]
        sid = self.active_suggestion.get(human)
        if sid is None:
            return None
        msg = self.suggestions[sid]
        step, began = self.suggestion_step.get(sid, (0, float(msg["t"])))
        if step < len(msg["actions"]) and (action is None or msg["actions"][step] == action):
            return began
        return None

    def human_take(self, element: str) -> list[str]:
        """A person says they will do the hyper-arc ``element`` (a panel's "I'll do this"):
        checked first (:class:`~flexhrc.taskmanager.manager.TakeRefused`, nothing stored), then
        stored as the input ``human_take`` and handed to the manager
        (:meth:`~flexhrc.taskmanager.TaskManager.operator_takes`). Returns the actions the
        operators are now asked to do."""
        if not self.started:
            raise FlexhrcError("the cell has not started yet")
        self.tm.check_take(element)
        self._input("human_take", {"element": element})
        ex = self.tm.executions.get(element)
        return [str(a) for a in ex.branch.steps] if ex is not None else []

    def halt_agent(self, name: str, *, by: str = "operator") -> None:
        """Take an arm out of the cooperation by hand: it is told to stop its command at once,
        the command fails (``stopped by the operator``) and the manager plans without it (the
        stored input ``agent_down``), until :meth:`release_agent`."""
        st = self.agents.get(name)
        if st is None:
            raise FlexhrcError(f"unknown agent {name!r}")
        cmd = self.tm.busy.get(name)
        if cmd is not None and st.alive:  # the arm itself stops at once
            stop = P.message(
                "stop",
                id=cmd.id,
                reason=f"stopped by the {by}",
                t=self.now,
                run=self.run_id,
                **self._to(name),
            )
            self.transport.publish(P.cmd_topic(name), stop)
        self._input("agent_down", {"agent": name, "wall": time.time(), "by": by})

    def release_agent(self, name: str, *, by: str = "operator") -> None:
        """Give an arm taken out by :meth:`halt_agent` back to the manager (``agent_up``)."""
        if name not in self.agents:
            raise FlexhrcError(f"unknown agent {name!r}")
        self._input("agent_up", {"agent": name, "wall": time.time(), "by": by})

    def set_operator_profile(self, name: str, profile: str) -> None:
        """From now on operator ``name`` behaves as ``profile`` (the stored input
        ``operator``, as a process announcing its profile makes it): a what-if run forked from
        a store with another person (``flexhrc replay --fork-at K --human PROFILE``). A
        ``passive`` operator no longer gets ``options``; one it had not answered is dropped."""
        st = self.agents.get(name)
        if st is None or st.kind != "human":
            raise FlexhrcError(f"{name!r} is not a human agent of this cell")
        if profile not in PROFILES:
            raise FlexhrcError(f"unknown operator profile {profile!r} ({', '.join(PROFILES)})")
        if self.operators.get(name, "passive") != profile:
            self._input("operator", {"agent": name, "profile": profile})

    def _operator_model_input(self) -> dict[str, Any]:
        """The ``start`` input's ``operator_model``: the content of the model the manager
        times the people's steps by (``--operators``, docs/operators.md) as it is at the start,
        so ``--resume`` and a what-if rebuild the same decisions without the file."""
        from flexhrc.taskmanager.operator_model import OperatorModelSimulator

        sim = self.tm.simulator
        return (
            {"operator_model": sim.model.to_dict()}
            if isinstance(sim, OperatorModelSimulator)
            else {}
        )

    def _take_stored_model(self, doc: Any) -> None:
        """A resumed run started with an operator model: the manager takes the stored one,
        unless a model was given again (``--operators FILE``: the given one decides, as the
        option says)."""
        from flexhrc.taskmanager.operator_model import OperatorModelSimulator, model_from_dict

        if isinstance(self.tm.simulator, OperatorModelSimulator):
            return
        model = model_from_dict(doc, "stored start: operator_model")
        self.tm.simulator = OperatorModelSimulator(self.tm.simulator, model)

    def set_utility(self, block: Any, *, where: str = "utility") -> None:
        """From now on the Task Manager scores branches by the utility ``block`` (the
        scenario key ``utility:``'s form; the stored input ``utility``, so the run resumes
        and replays): a what-if run forked with another utility (``flexhrc replay --fork-at K
        --utility FILE``). A bad block is one :class:`FlexhrcError` naming ``where``."""
        from flexhrc.taskmanager.utility import parse_utility

        utility, problems = parse_utility(block, self.domain)
        if problems:
            message, key = problems[0]
            raise FlexhrcError(f"{where}: {message}" + (f" (key {key})" if key else ""))
        self._input("utility", {"utility": utility.to_dict() if utility is not None else {}})

    def set_realtime(self, realtime: float, *, agent_speed: float | None = None) -> None:
        """Change the pace of the wall clock from now on (a panel's speed control): the cell's
        time goes on from where it is; ``agent_speed`` (if given) is the pace the agents get
        with their next command. Call it on the cell's own thread."""
        if not realtime >= 0 or realtime != realtime or realtime == float("inf"):
            raise FlexhrcError(f"--realtime must be a finite number >= 0, got {realtime}")
        now = max(self.now, self._clock())
        self.realtime = float(realtime)
        if agent_speed is not None:
            self.agent_speed = float(agent_speed)
        if self._clock0 is not None and self.realtime > 0:
            self._clock0 = time.perf_counter() - now / self.realtime

    # -- receiving ----------------------------------------------------------------------------
    def _drop(self, reason: str) -> None:
        self.dropped.append(reason)
        log.warning("dropped: %s", reason)
        self.trace({"t": round(self.now, 6), "type": "dropped", "reason": reason})

    def _on_ack_message(self, data: Any, source: str | None = HERE) -> None:
        try:
            msg = P.parse(data, expect="ack")
        except P.ProtocolError as exc:
            self._drop(f"ack: {exc}")
            return
        cid = msg["id"]
        cmd = self.commands.get(cid)
        if (foreign := self._foreign(str(msg["agent"]), source)) is not None:
            self._drop(f"ack for command {cid}: {foreign}")  # P10
        elif self._other_run(msg):
            self._drop(f"ack for command {cid} of another run ({msg['run']})")
        elif cmd is None:
            self._drop(f"ack for unknown command {cid}")
        elif cid in self.acked or self._queued("ack", cid):
            self._drop(f"duplicate ack for command {cid}")
        elif msg["agent"] not in cmd.agents:
            self._drop(f"ack for command {cid} from {msg['agent']}, not {'+'.join(cmd.agents)}")
        elif cid in self.stopped:
            # the arm finished before it heard the stop: in the cell's time the stop came
            # first, so that end never happened
            log.info("ack for command %d, which was stopped: ignored", cid)
        elif self.tm.busy.get(msg["agent"]) is not cmd:
            self._drop(f"ack for command {cid}, which is no longer running")
        elif (said := self._ack_problem(cmd, msg)) is not None:
            self._drop(said)
        else:
            self._arrive(msg["t"], "ack", _body(msg))

    def _ack_problem(self, cmd: Command, msg: dict[str, Any]) -> str | None:
        """What an ack of a running command says that cannot be: that it ended before the
        manager issued it (P13), or that it moved objects its action does not touch (P12)."""
        issued = self._issued_at.get(cmd.id)
        if issued is not None and msg["t"] < issued - 1e-9:
            return (
                f"ack for command {cmd.id} ends at t = {msg['t']}, before the command was "
                f"issued (t = {issued})"
            )
        return _moves_untouched(f"ack for command {cmd.id}", cmd.action, cmd.agents, msg)

    def _on_human_message(self, data: Any, source: str | None = HERE) -> None:
        try:
            msg = P.parse(data, expect=("human_action", "answer", "reply"))
            st = self.agents.get(msg["agent"])
            if st is None or st.kind != "human":
                raise P.ProtocolError(f"{msg['agent']!r} is not a human agent of this cell")
            if (foreign := self._foreign(str(msg["agent"]), source)) is not None:
                raise P.ProtocolError(f"{msg.get('id')}: {foreign}")  # P19
            if msg["type"] == "reply":
                self._on_reply(msg)
                return
            if msg["type"] == "answer":
                if msg["object"] not in self.kb.objects:
                    raise P.ProtocolError(f"answer about {msg['object']!r}, not an object here")
                if msg["report"] not in self._reports:
                    raise P.ProtocolError(f"answer about {msg['report']!r}, not a report here")
                if self._other_run(msg):
                    raise P.ProtocolError(f"answer of another run ({msg['run']})")
                self._arrive(msg["t"], "operator_answers", _body(msg))
                return
            action = ground(self.domain, msg["action"])
            said = unknown_name(self.domain, self.kb, action) or _moves_untouched(
                f"human_action {msg['id']}", action, (str(msg["agent"]),), msg
            )
            if said is not None:
                raise P.ProtocolError(said)
            if msg["agent"] not in action.agents:
                raise P.ProtocolError(f"{action} is not an action of {msg['agent']}")
        except FlexhrcError as exc:
            self._drop(f"human_action: {exc}")
            return
        replaced = self.superseded.get(str(msg.get("suggestion")))
        if self._other_run(msg):
            self._drop(f"human_action {msg['id']} of another run ({msg['run']})")
        elif not self.started:  # nothing was asked yet: a report of another cell's request
            self._drop(f"human_action {msg['id']} before the cooperation started")
        elif msg["id"] in self.human_ids or self._queued("human_action", msg["id"]):
            self._drop(f"duplicate human_action {msg['id']}")
        elif self._repeated_report(str(msg["agent"]), action):
            self._drop(f"human_action {msg['id']}: {_REPEATED.format(action=action)}")
        elif replaced is not None and self.ordered and float(msg["t"]) > replaced:
            log.info("human_action %s of a replaced request: ignored", msg["id"])
        else:
            self._arrive(msg["t"], "human_action", _body(msg))

    def _on_reply(self, msg: dict[str, Any]) -> None:
        """A person's ``reply`` (checked: its agent is a person of this cell, its process the
        one granted the name): queued at its ``t`` like a report. What it answers is checked
        when its time comes (:meth:`_reply_problem`)."""
        if self._other_run(msg):
            raise P.ProtocolError(f"reply {msg['id']} of another run ({msg['run']})")
        if not self.started:
            raise P.ProtocolError(f"reply {msg['id']} before the cooperation started")
        if msg["id"] in self.reply_ids or self._queued("human_reply", msg["id"]):
            raise P.ProtocolError(f"duplicate reply {msg['id']}")
        if msg.get("suggestion") is None and msg.get("element") is None:
            # it answers the person's open request (a panel's or a pendant's button)
            sid = self.active_suggestion.get(str(msg["agent"]))
            if sid is None and msg["reply"] != "start":
                raise P.ProtocolError(f"reply {msg['id']}: {msg['agent']} has no open request")
            if sid is not None:
                msg = {**msg, "suggestion": sid}
        sid = msg.get("suggestion")
        asked = self.suggestions.get(sid) if isinstance(sid, str) else None
        if sid is not None and (asked is None or asked.get("agent") != msg["agent"]):
            raise P.ProtocolError(f"reply {msg['id']}: {msg['agent']} was sent no request {sid}")
        element = msg.get("element")
        if element is not None and _kind(self.graph, element) != "hyperarc":
            raise P.ProtocolError(f"reply {msg['id']}: {element!r} is no hyper-arc of this task")
        action = msg.get("action")
        if action is not None:
            said = unknown_name(self.domain, self.kb, ground(self.domain, action))
            if said is not None:
                raise P.ProtocolError(said)
        self._arrive(msg["t"], "human_reply", _body(msg))

    def _reply_problem(self, body: dict[str, Any]) -> str | None:
        """Why a reply cannot be taken when its time comes: it answers a request that has
        ended meanwhile (done, replaced, or given to another), or gives back what the person
        does not hold."""
        human, reply, sid = str(body["agent"]), str(body["reply"]), body.get("suggestion")
        if reply == "start":
            return None
        if sid is not None and self.active_suggestion.get(human) != sid:
            return f"{reply} of request {sid}, which {human} no longer has"
        if sid is None:
            ex = self.tm.executions.get(str(body["element"]))
            if reply != "cannot" and (ex is None or human not in ex.agents):
                return f"{reply} of {body['element']}, which {human} is not doing"
        return None

    def _reply(self, body: dict[str, Any]) -> list[Directive]:
        """A person's answer to a request, at its time (see :meth:`human_reply`)."""
        human, reply = str(body["agent"]), str(body["reply"])
        self.reply_ids.add(str(body["id"]))
        sid = body.get("suggestion")
        msg = self.suggestions.get(sid) if isinstance(sid, str) else None
        if isinstance(sid, str):
            self._answer_due.pop(sid, None)
            self._timed_out.discard(sid)
        if reply == "start":
            self._starts[human] = (self._reply_action(body), self.now)
            return []
        element = str(body.get("element") or (msg or {}).get("element"))
        if isinstance(sid, str) and self.active_suggestion.get(human) == sid:
            # the request ends: a report of it still under way never happens (as a stop)
            del self.active_suggestion[human]
            self._last_suggestion[human] = sid
            self._supersede(human)
        self._starts.pop(human, None)
        why = body.get("reason") or ("no answer in time" if body.get("why") == "timeout" else None)
        return self.tm.operator_replies(self.now, human, element, reply, why)

    def _reply_action(self, body: dict[str, Any]) -> str | None:
        """The action a ``start`` reply begins: its ``action``, else its request's step."""
        if body.get("action") is not None:
            return str(body["action"])
        sid = body.get("suggestion")
        msg = self.suggestions.get(sid) if isinstance(sid, str) else None
        if msg is None:
            return None
        step = body.get("step")
        if not isinstance(step, int):
            step = self.suggestion_step.get(str(sid), (0, 0.0))[0]
        return str(msg["actions"][step]) if step < len(msg["actions"]) else None

    def _fire_timeouts(self) -> bool:
        """A request unanswered for ``answer_timeout`` seconds is declined (``why: timeout``,
        a stored input at its deadline). In the discrete-event loop the person is only known
        silent when nothing more can come from them: agents in this process are quiescent,
        or the timeout has passed on the wall clock too (at the cell's pace). Returns whether
        a timeout was queued."""
        if self.answer_timeout is None or self.tm.done:
            return False
        pending = {(b.get("agent"), b.get("suggestion")) for *_, k, b in self.pending}
        pending_agents = {b.get("agent") for *_, k, b in self.pending if k != "ack"}
        fired = False
        for human, sid in sorted(self.active_suggestion.items()):
            due = self._answer_due.get(sid)
            if due is None or sid in self._timed_out or (human, sid) in pending:
                continue
            if self.ordered:
                if human in pending_agents:
                    continue
                quiet = self.quiescent() if self.quiescent is not None else False
                pace = self.realtime if self.realtime > 0 else 1.0
                waited = time.monotonic() - self._asked_wall.get(sid, time.monotonic())
                if not (quiet or waited >= self.answer_timeout / pace):
                    continue
            elif self._clock() < due:
                continue
            self._timed_out.add(sid)
            body = {
                "id": f"timeout:{sid}",
                "agent": human,
                "reply": "decline",
                "suggestion": sid,
                "why": "timeout",
                "reason": f"no answer after {self.answer_timeout:g} s",
            }
            self._arrive(due, "human_reply", body)
            fired = True
        return fired

    def _next_human_step(self, text: str) -> bool:
        """``text`` is the next step of an open execution the person owns (asked of them, or
        what they decided to do)."""
        return any(
            ex.owner == "human"
            and ex.next_index < len(ex.branch.steps)
            and str(ex.branch.steps[ex.next_index]) == text
            for ex in self.tm.executions.values()
        )

    def _repeated_report(self, human: str, action: GroundAction) -> bool:
        """A report of what ``human`` already reported, that no step of a request expects and
        whose effects all hold already: it would change nothing but add one more stored input
        (2000 reports of one finished ``check`` were once all stored: probe P25). A person who
        does a thing again after undoing it (put down, pick up) changes the world: kept."""
        text = str(action)
        if (human, text) not in self._reported and not any(
            k == "human_action"
            and b["agent"] == human
            and str(ground(self.domain, b["action"])) == text
            for *_, k, b in self.pending
        ):
            return False
        if self._next_human_step(text):
            return False
        facts, binding = self.kb.facts, action.binding
        added = (apply_substitution(lit, binding).key() for lit in action.schema.add)
        deleted = (apply_substitution(lit, binding).key() for lit in action.schema.delete)
        return all(f in facts for f in added) and not any(f in facts for f in deleted)

    def _on_percept_message(self, data: Any) -> None:
        """A percept of one object from a perception process: applied when it arrives (the
        knowledge base checks it against what it knows; a contradiction makes the manager wait,
        paper III)."""
        try:
            msg = P.parse(data, expect=("percept", "looked"))
        except P.ProtocolError as exc:
            self._drop(f"percept: {exc}")
            return
        if msg["type"] == "looked":
            self._on_looked(msg)
            return
        rec = self.kb.objects.get(msg["object"])
        if msg["id"] in self.percept_ids:
            self._drop(f"duplicate percept {msg['id']}")
        elif not self.started:
            self._drop(f"percept {msg['id']} before the cooperation started")
        elif rec is None:  # the world knows its objects (P31): a percept does not add one
            self._drop(f"percept {msg['id']}: no object {msg['object']!r} in this cell's world")
        elif not self.kb.compatible(rec.type, msg["object_type"]):
            # not a contradiction to wait on: no look can make a tabletop a leg (P21)
            self._drop(
                f"percept {msg['id']}: {rec.id} is a {rec.type} in this cell's world, "
                f"not a {msg['object_type']}"
            )
        else:  # at the cell's time: a percept never moves the clock
            self._input("percept", _body(msg))

    def _on_looked(self, msg: dict[str, Any]) -> None:
        """A watcher has looked at the state ``upto``; ``at``: it looks again then, by itself
        (the operator nudges a part): the ordered loop handles no answer after that time first."""
        agent = str(msg["agent"])
        if agent not in self.watchers or not self.started:
            return
        self._looked[agent] = max(self._looked.get(agent, 0), int(msg["upto"]))
        at = msg.get("at")
        if at is not None and float(at) > self.now and (agent, float(at)) not in self._wakes:
            self._wakes.add((agent, float(at)))
            self._arrive(float(at), "look", {"agent": agent, "id": f"look@{at}"})
        if not self.begun and all(self._looked.get(w, 0) >= self._state_seq for w in self.watchers):
            self._input("begin", {"watchers": list(self.watchers)})

    def _on_intent_message(self, data: Any, source: str | None = HERE) -> None:
        """An operator's profile (``operator``) or its answer to ``options`` (``intent``)."""
        try:
            msg = P.parse(data, expect=("operator", "intent"))
            st = self.agents.get(msg["agent"])
            if st is None or st.kind != "human":
                raise P.ProtocolError(f"{msg['agent']!r} is not a human agent of this cell")
            if (foreign := self._foreign(str(msg["agent"]), source)) is not None:
                raise P.ProtocolError(foreign)  # P17: a profile only from the operator's process
            if msg["type"] == "operator" and msg["profile"] not in PROFILES:
                raise P.ProtocolError(
                    f"operator: unknown profile {msg['profile']!r} ({', '.join(PROFILES)})"
                )
            if msg["type"] == "intent":
                for a in msg.get("actions") or []:
                    said = unknown_name(self.domain, self.kb, ground(self.domain, a))
                    if said is not None:
                        raise P.ProtocolError(said)
        except FlexhrcError as exc:
            self._drop(f"{data.get('type') if isinstance(data, dict) else 'intent'}: {exc}")
            return
        agent = str(msg["agent"])
        if msg["type"] == "operator":
            scripted = bool(msg.get("scripted", False))
            if self.operators.get(agent) == msg["profile"] and (agent in self.scripted) == scripted:
                pass
            elif not self.started:  # goes into the stored start
                self.operators[agent] = str(msg["profile"])
                if scripted:
                    self.scripted.add(agent)
            else:
                body = {"agent": agent, "profile": msg["profile"]}
                self._input("operator", {**body, "scripted": True} if scripted else body)
            # the acknowledgement: the operator declares its liveliness token only once a
            # ``state`` shows its profile, so the start never misses a profile announced
            self._publish_state(force=True)
            return
        if self._other_run(msg):
            self._drop(f"intent {msg['id']} of another run ({msg['run']})")
        elif msg["id"] in self.intent_ids or self._queued("intent", msg["id"]):
            self._drop(f"duplicate intent {msg['id']}")
        elif self.awaiting.get(agent) != msg["options"]:
            self._drop(f"intent for options {msg['options']}, which {agent} was not asked")
        else:
            self._arrive(msg["t"], "intent", _body(msg))

    def _queued(self, kind: str, ident: Any) -> bool:
        """An input of ``kind`` with the id ``ident`` is already queued (:attr:`pending`)."""
        return any(k == kind and b["id"] == ident for *_, k, b in self.pending)

    def _arrive(self, t: float, kind: str, body: dict[str, Any]) -> None:
        self._arrivals += 1
        self.pending.append((float(t), self._arrivals, kind, body))

    def _on_alive(self, key: str, alive: bool) -> None:
        name = key.split("/", 1)[-1]
        st = self.agents.get(name)
        if st is None:
            if name != P.MANAGER:
                log.info("liveliness of %s, not an agent of this cell: ignored", name)
            return
        self._token_alive[name] = alive
        if not alive:
            self._vacated.add(name)
        if name in self.refused and alive:  # the process of another scenario: not this agent
            return
        st.alive = alive
        if alive:
            st.seen = True
        if not self.started or self.tm.done:  # an ended run takes no input any more
            return
        if not alive and st.available and self._stalled():
            log.info("token of %s gone while the cell was stalled: doubted", name)
            self._doubtful.setdefault(name, time.monotonic() + STALL_GRACE_S)
        elif not alive and st.available:
            self._agent_down(name)
        elif alive and not st.available:
            self._input("agent_up", {"agent": name, "wall": time.time()})
            self._resend(name)  # an operator's open suggestion (reports already seen are dropped)
        elif alive:
            self._resend(name)

    def _agent_down(self, name: str) -> None:
        self._input("agent_down", {"agent": name, "wall": time.time()})
        self._fail_lost()

    def _fail_lost(self) -> None:
        """Acknowledge as failed every running command of an unavailable agent."""
        pending_ids = {b["id"] for *_, k, b in self.pending if k == "ack"}
        while True:
            lost = [
                c
                for a, c in sorted(self.tm.busy.items())
                if not self.agents[a].available and c.id not in pending_ids
            ]
            if not lost or self.tm.done:
                return
            cmd = lost[0]
            agent = next(a for a in cmd.agents if not self.agents[a].available)
            reason = self._down_reason.get(agent, AGENT_LOST)
            body = {"id": cmd.id, "agent": agent, "status": "failed", "reason": reason}
            self._input("ack", body)

    # -- store, feed, send --------------------------------------------------------------------
    def _record(self, kind: str, body: dict[str, Any], *, observe: bool = True) -> None:
        if self.replaying:
            if self._captured is not None:  # the outputs of the last stored input (_replay)
                self._captured.append((kind, body))
            return
        t = self.now  # unrounded, so a resumed clock continues exactly
        if self.store is not None:  # every row names its run (flexhrc.cell.identity)
            seq = self.store.append(kind, {**body, identity.RUN: self.run_id}, t)
        else:
            seq = len(self.events) + 1
        ev = StoredEvent(seq, t, kind, body)
        self.events.append(ev)
        self.trace({**body, "t": t, "type": kind})
        if observe and self.observers:
            for log_ev in self._log_form(ev):
                self._observe(log_ev)

    def _observe(self, ev: dict[str, Any]) -> None:
        for observer in self.observers:
            observer(ev)

    def _log_form(self, ev: StoredEvent) -> list[dict[str, Any]]:
        """A stored event as the events of the cooperation log, as it happens (the manager's
        own events reach the observers from :meth:`_tm_log`)."""
        b, t = ev.body, round(ev.t, 6)
        if ev.kind == "command":
            self._command_start[int(b["id"])] = ev.t
            return [action_start(t, b)]
        if ev.kind in ("ack", "stop"):
            cid = int(b["id"])
            cmd = self.commands.get(cid)
            if cmd is None or cid not in self._command_start:
                return []
            status = "stopped" if ev.kind == "stop" else b["status"]
            start = self._command_start.pop(cid)
            return [
                action_end(
                    t,
                    list(cmd.agents),
                    str(cmd.action),
                    status,
                    start,
                    command=cid,
                    reason=b.get("reason"),
                    element=cmd.element,
                )
            ]
        if ev.kind == "human_action":
            sensed = b.get("sensed")
            done = str(sensed.get("action", b["action"])) if sensed else b["action"]
            start = min(float(b.get("start", ev.t)), ev.t)
            # the action is what the person did (the sensor may say otherwise)
            out = [action_end(t, [b.get("agent")], done, "done", start)]
            if sensed:  # what the wrist sensor made of it
                body = {k: v for k, v in sensed.items() if k not in ("t", "outcome")}
                out.append({"t": t, "type": "human_sensed", **body})
                if sensed.get("outcome") in ("missed", "uncovered"):
                    kind = f"human_sensing_{sensed['outcome']}"
                    out.append({"t": t, "type": kind, "action": sensed["action"]})
            return out
        if ev.kind == "suggestion":
            return [
                {
                    "t": t,
                    "type": "human_told",
                    "element": b["element"],
                    "agents": [b["agent"]],
                    "actions": b["actions"],
                }
            ]
        if ev.kind == "start":
            profiles = list((b.get("operators") or {}).values())
            profile = profiles[0] if profiles else "passive"
            # the cooperation log of `flexhrc run --log` as it always was
            same = {k: v for k, v in b.items() if k != "fingerprint"}
            return [{"profile": profile, **same, "t": t, "type": "start"}]
        if ev.kind in ("fixed", "human_decides", "human_gives_up", "outcome", "summary"):
            return [{**b, "t": t, "type": ev.kind}]
        if ev.kind in ("percept", "inconsistent", "consistent_again", "repaired"):
            return [{**b, "t": t, "type": ev.kind}]  # perception in the loop
        if ev.kind == "operator_answers":
            return [{**b, "t": t, "type": ev.kind}]
        if ev.kind == "human_reply":
            said = {**b, "t": t, "type": "human_reply"}
            if b.get("reply") == "start":
                action = self._reply_action(b)
                if action is not None:  # the person's lane begins here
                    return [said, {"t": t, "type": "action_start", "agents": [b["agent"]],
                                   "action": action}]  # fmt: skip
            return [said]
        return []

    def _tm_log(self, ev: dict[str, Any]) -> None:
        if not self.replaying and self.observers:
            self._observe(ev)
        if ev.get("type") in STORED_LOG_TYPES:
            body = {k: v for k, v in ev.items() if k not in ("t", "type")}
            self._record(str(ev["type"]), body, observe=False)

    def _clock(self) -> float:
        """Cell time from the wall clock, when agents take real time (unordered loop)."""
        if self.ordered or self.realtime <= 0 or self._clock0 is None:
            return self.now
        return (time.perf_counter() - self._clock0) * self.realtime

    def _input(self, kind: str, body: dict[str, Any], t: float | None = None) -> None:
        if t is not None:
            self.now = max(self.now, float(t))
        if not self.replaying:
            self.now = max(self.now, self._clock())
        self._record(kind, body)  # committed before the manager acts on it
        decided, t0 = self.tm.decisions, time.perf_counter()
        directives = self._feed(kind, body)
        if not self.replaying and self.tm.decisions > decided:  # the decision latency
            self.decision_latencies_s.append(time.perf_counter() - t0)
        self._handle(directives)
        self._settle()
        if not self.replaying:
            self._fail_lost()
            self._publish_state()

    def _feed(self, kind: str, body: dict[str, Any]) -> list[Directive]:
        tm, now = self.tm, self.now
        if kind == "start":
            self.started = True
            if "on_failure" in body:  # a resumed run goes on under the policy it began with
                tm.on_failure = check_failure_policy(body["on_failure"], "stored start: on_failure")
            # ... and under the decision policy it began with (no key: paper)
            stored = check_policy(body.get("policy", DEFAULT_POLICY), "stored start: policy")
            if stored != self.policy:
                self.policy = stored
                tm.policy = make_policy(stored, "stored start: policy")
            self.operators.update(body.get("operators") or {})
            self.scripted.update(body.get("scripted") or [])
            if "operator_model" in body:
                self._take_stored_model(body["operator_model"])
            if body.get("watchers"):  # the first decision waits for their first look
                self.begun = False
                return []
            return tm.start(now)
        if kind == "begin":
            self.begun = True
            return tm.start(now)
        if kind == "utility":
            from flexhrc.taskmanager.utility import parse_utility

            utility, _ = parse_utility(body["utility"], self.domain)  # checked when stored
            self.tm.utility = utility  # as the scenario key: an explicit block logs its terms
            return []
        if kind == "operator":
            self.operators[str(body["agent"])] = str(body["profile"])
            if body.get("scripted"):
                self.scripted.add(str(body["agent"]))
            elif body["profile"] == "passive":  # a what-if's new operator answers no options
                self.awaiting.pop(str(body["agent"]), None)
            return []
        if kind == "intent":
            return self._intent(body)
        if kind == "human_take":
            return tm.operator_takes(now, str(body["element"]))
        if kind == "ack":
            cid = int(body["id"])
            self.acked.add(cid)
            if body.get("joints"):  # where the arms are: the robot model plans from there
                set_joint_state = getattr(tm.simulator, "set_joint_state", None)
                if set_joint_state is not None:
                    set_joint_state(body["joints"])
            cmd = self.commands.get(cid)
            if cmd is not None and body["status"] == "done":
                positions = body.get("positions") or {}
                for k, p in positions.items():  # where things are now (a percept of the arm)
                    if k in self.kb.objects and self.kb.position(k) != tuple(p):
                        self.kb.move(k, p)
                self._physical(cmd.action, positions)
            return tm.on_ack(now, Ack(cid, str(body["status"]), body.get("reason")))
        if kind == "human_action":
            self.human_ids.add(str(body["id"]))
            action = ground(self.domain, body["action"])
            learn = getattr(tm.simulator, "observe_human_action", None)
            if learn is not None:  # a learned operator model follows the person (online update)
                learn(body)
            self._reported.add((str(body["agent"]), str(action)))
            missed = body.get("recognised") is False  # the wrist sensor missed it
            if not missed:
                self._physical(action, body.get("positions") or {})
            sid, k = body.get("suggestion"), body.get("step")
            self._starts.pop(str(body["agent"]), None)
            answered = sid if isinstance(sid, str) else self.active_suggestion.get(body["agent"])
            if answered is not None:  # a report answers the request: no timeout any more
                self._answer_due.pop(answered, None)
            if isinstance(sid, str) and isinstance(k, int) and sid in self.suggestions:
                done = self.suggestion_step.get(sid, (0, now))[0]
                self.suggestion_step[sid] = (max(done, k + 1), now)
            if missed:  # a miss is a miss: the manager is not told
                return []
            said = HumanAction(action.name, action.args)
            obj = action.args[1] if len(action.args) > 1 else None
            where = self.kb.position(obj) if obj in self.kb.objects else None
            before = set(self.kb.facts)
            out = tm.on_human_action(now, said)
            after = set(self.kb.facts)
            self._reports[str(body["id"])] = (said, obj, where, after - before, before - after)
            return out
        if kind == "operator_answers":
            return self._answered(body)
        if kind == "human_reply":
            return self._reply(body)
        if kind == "percept":
            self.percept_ids.add(str(body["id"]))
            obj = str(body["object"])
            contradicts = body.get("contradicts")
            known = obj in self.kb.objects
            if contradicts and known:
                # the perception agent checked a reported belief and found it false
                self.kb.inconsistencies.append(
                    Inconsistency(obj, str(contradicts), _percept_of(body))
                )
                self.kb.version += 1
                self._record("inconsistent", {"object": obj, "reason": str(contradicts)})
            else:
                self._apply_percept(obj, body, known)
            if not self.begun:
                return []
            if body.get("moved") and self.kb.consistent:
                return tm.on_percept(now, moved=[obj])
            return tm.replan(now)
        if kind in ("agent_down", "agent_up"):
            st = self.agents[str(body["agent"])]
            # why it is gone, for the acks of its running commands (a panel's stop button)
            by = body.get("by")
            self._down_reason[st.name] = f"stopped by the {by}" if by else AGENT_LOST
            st.available = kind == "agent_up"
            return tm.set_available(now, st.name, st.available)
        raise FlexhrcError(f"unknown input kind {kind!r} in the store")

    def _apply_percept(self, obj: str, body: dict[str, Any], known: bool) -> None:
        """A percept to the knowledge base, at its own time (``t``; else the cell's time it is
        stored at: a replay decides the same): it checks the percept, continuity included, and
        a compatible one clears what the object's earlier percepts contradicted (VI-E)."""
        was = known and any(i.object_id == obj for i in self.kb.inconsistencies)
        t = body.get("t")
        when = float(t) if isinstance(t, int | float) and not isinstance(t, bool) else self.now
        size = body.get("size")
        if self.kb.update_object(obj, str(body["object_type"]), body["pose"], size, t=when):
            if was:
                self._record("consistent_again", {"object": obj, "why": "a compatible percept"})
        else:
            self._record(
                "inconsistent", {"object": obj, "reason": self.kb.inconsistencies[-1].reason}
            )

    # -- operators that act on their own -------------------------------------------------------
    def _answered(self, body: dict[str, Any]) -> list[Directive]:
        """The operator answered whether it did what was reported: yes — the percept was wrong,
        the belief stands; no — the report is undone (the facts its handling changed, where
        the object is: as last perceived) and the manager drops what it started on it."""
        said, obj, where, added, removed = self._reports[str(body["report"])]
        target = str(body["object"])
        percept = next((i.percept for i in self.kb.inconsistencies if i.object_id == target), None)
        if body["answer"] == "yes":
            self.kb.resolve(target, accept=False)
            return self.tm.on_percept(self.now)
        for fact in added:
            self.kb.retract_fact(*fact)
        for fact in removed:
            self.kb.assert_fact(*fact)
        seen = percept["position"] if percept is not None else where
        if obj in self.kb.objects and seen is not None:
            self.kb.move(obj, seen)
        self.kb.resolve(target, accept=False)
        del self._reports[str(body["report"])]
        self._record("repaired", {"object": target, "by": f"operator denied {said}"})
        return self.tm.on_percept(self.now, retracted=[said])

    def _helper(self, human: str) -> SimulatedOperator:
        """What an operator may do, as the in-process operators see it (no decision is taken
        here: the profile and its randomness live in the operator's agent). The robot commands
        issued at this very instant go with it: a ``takeover`` operator gets there first."""
        profile = self.operators.get(human, "passive")
        fresh = frozenset(
            cid for cid, t in self._issued_at.items() if t == self.now and cid not in self.acked
        )
        return SimulatedOperator(human, profile if profile in PROFILES else "passive", fresh=fresh)

    def _operator_busy(self, human: str) -> bool:
        # an intent that has arrived but waits for its time still holds its ``awaiting`` entry
        if human in self.active_suggestion or human in self.awaiting:
            return True
        return any(
            ex.owner == "human" and human in ex.branch.agents for ex in self.tm.executions.values()
        )

    def _offer_options(self) -> None:
        """Send ``options`` to each idle operator that acts on its own and has a newly reachable
        step it may do alone (it decides once per step, :meth:`SimulatedOperator.decide`)."""
        if not self.started or not self.begun or self.tm.done:
            return
        for human, profile in sorted(self.operators.items()):
            st = self.agents.get(human)
            if profile == "passive" and human not in self.scripted:
                continue
            if st is None or not st.available:
                continue
            if self._operator_busy(human):
                continue
            helper = self._helper(human)
            seen = self.decided.setdefault(human, set())
            steps = []
            for step, arcs in helper.options(self.tm).items():
                if step in seen:
                    continue
                steps.append(
                    {
                        "step": step,
                        "arcs": [
                            {
                                "hyperarc": h,
                                "cost": float(cost),
                                "branches": [
                                    [str(a) for a in b]
                                    for b in helper.candidate_branches(self.tm, self.kb, h)
                                ],
                            }
                            for cost, h in arcs
                        ],
                    }
                )
            if not steps:
                continue
            oid = f"o{len(self.options) + 1}"
            msg = {"id": oid, "agent": human, "t": self.now, "steps": steps}
            self.options[oid] = msg
            self.awaiting[human] = oid
            self._record("options", msg)
            self._send_options(human, oid)

    def _send_options(self, human: str, oid: str) -> None:
        st = self.agents[human]
        if self.replaying or not st.alive or not st.available:
            return
        msg = {k: v for k, v in self.options[oid].items() if k != "agent"}
        self._options_sent_at[oid] = time.monotonic()
        self.transport.publish(
            P.options_topic(human),
            P.message(
                "options",
                **msg,
                world=world_of(self.kb),
                run=self.run_id,
                fingerprint=self.fingerprint,
                **self._to(human),
            ),
        )

    def _intent(self, body: dict[str, Any]) -> list[Directive]:
        """An operator's answer to its ``options``, at the time it starts: it takes the branch
        it chose if that is still free, else gives up (someone got there first)."""
        human = str(body["agent"])
        self.intent_ids.add(str(body["id"]))
        if self.awaiting.get(human) == body["options"]:
            del self.awaiting[human]
        self.decided.setdefault(human, set()).update(str(x) for x in body["decided"])
        if not body["act"]:
            return []
        step, hyperarc, actions = str(body["step"]), str(body["hyperarc"]), list(body["actions"])
        helper = self._helper(human)
        arcs = [h for _, h in helper.options(self.tm).get(step, [])]
        free = hyperarc in arcs and any(
            [str(a) for a in b] == actions
            for b in helper.candidate_branches(self.tm, self.kb, hyperarc)
        )
        if not free or human in self.active_suggestion:
            self._record("human_gives_up", {"agent": human, "step": step, "element": hyperarc})
            return []
        if helper.fresh and self._arm_just_given(human, hyperarc, actions):
            # takeover: an arm was given this very step at this instant and has not moved;
            # the operator is there first, as with the panel's "I'll do this" (V-C)
            self._record(
                "human_decides",
                {"agent": human, "element": hyperarc, "step": step, "actions": actions},
            )
            # the step is this operator's: with several people, eq. 21 over all of them could
            # hand it to another one, busy with a request of their own (a deadlock)
            return self.tm.operator_takes(self.now, hyperarc, record=False, agent=human)
        sid = f"s{len(self.suggestions) + 1}"
        self.suggestions[sid] = {
            "v": P.VERSION,
            "type": "suggestion",
            "id": sid,
            "element": hyperarc,
            "actions": actions,
            "t": self.now,
            "agent": human,
            "own": True,
        }
        self.active_suggestion[human] = sid
        self._record(
            "human_decides",
            {"agent": human, "element": hyperarc, "step": step, "actions": actions, "own": sid},
        )
        self._send_suggestion(human, sid)
        return []

    def _arm_just_given(self, human: str, hyperarc: str, actions: list[str]) -> bool:
        """The operator's branch is free only because the arm holding its objects got its
        command this very instant (``takeover``, :class:`SimulatedOperator` ``fresh``)."""
        plain = SimulatedOperator(human)
        return not any(
            [str(a) for a in b] == actions
            for b in plain.candidate_branches(self.tm, self.kb, hyperarc)
        )

    def _settle(self) -> None:
        """After every input (live and while resuming, so both decide alike)."""
        self._refresh_suggestions()
        self._offer_options()

    def _physical(self, action: GroundAction, positions: dict[str, Any]) -> None:
        fixed = apply_physical(self.kb, self.domain, action, positions)
        if fixed is not None:
            self._record(
                "fixed", {"object": fixed, "agents": list(action.agents), "action": str(action)}
            )

    def _handle(self, directives: list[Directive]) -> None:
        for d in directives:
            if isinstance(d, Command):
                self.commands[d.id] = d
                self._issued_at.setdefault(d.id, self.now)
                body = {**d.to_dict(), "t": self.now}
                body.pop("type", None)
                if not self.replaying:
                    self._record("command", body)
                    self.stored_commands.add(d.id)
                elif self._captured is not None:  # in its place among the last input's outputs
                    self._captured.append(("command", body))  # (_record_kept_outputs)
                self._start_joints[d.id] = self._joints_of(d.agents)
                self._predict(d)
                # a joint command goes to its first agent, which drives all of them (as one
                # execution model does); the others are busy with it
                self._send_command(d.agents[0], d)
            elif isinstance(d, Suggest):
                sid = f"s{len(self.suggestions) + 1}"
                human = next(a for a in d.actions[0].agents if self.agents[a].kind == "human")
                self._supersede(human)
                msg = {
                    "v": P.VERSION,
                    "type": "suggestion",
                    "id": sid,
                    "element": d.element,
                    "actions": [str(a) for a in d.actions],
                    "cost": float(d.cost),
                    "t": self.now,
                    "agent": human,
                }
                self.suggestions[sid] = msg
                self.active_suggestion[human] = sid
                if self.answer_timeout is not None:
                    self._answer_due[sid] = self.now + self.answer_timeout
                    self._asked_wall[sid] = time.monotonic()
                self._record("suggestion", {k: v for k, v in msg.items() if k not in ("v", "type")})
                self._send_suggestion(human, sid)
            elif isinstance(d, Stop):
                self.stopped.add(d.command_id)
                if self.ordered:  # an answer already here that ends after the stop: never was
                    self.pending = [
                        x
                        for x in self.pending
                        if not (x[2] == "ack" and x[3]["id"] == d.command_id and x[0] > self.now)
                    ]
                self._record("stop", {"agent": d.agent, "id": d.command_id, "reason": d.reason})
                if not self.replaying and self.agents[d.agent].alive:
                    self.transport.publish(
                        P.cmd_topic(d.agent),
                        P.message(
                            "stop",
                            id=d.command_id,
                            reason=d.reason,
                            t=self.now,
                            run=self.run_id,
                            **self._to(d.agent),
                        ),
                    )

    def _not_possible(self, t: float, body: dict[str, Any]) -> str | None:
        """Why a person's report cannot be taken when its time comes, or None: it is a step of
        a request the manager sent them (even if the world moved on meanwhile: the manager
        then handles what they did), the next step of what they were asked or decided to do,
        or it advances a feasible part of the task now (:meth:`TaskManager.advances`, the
        panel's own check of a "done"). A report that does none of these (``check(human,
        bolt_1)`` before any bolt is screwed: probe P19) would be stored and change the
        belief for an action no one could do. A wearable
        sensor's reading (``sensed``) is kept as it is: what it makes of a motion is the
        sensor's word, and an unmatched reading is how the manager learns of it."""
        if body.get("recognised") is False or "sensed" in body:
            return None
        action = ground(self.domain, body["action"])
        text = str(action)
        sid, k = body.get("suggestion"), body.get("step")
        asked = self.suggestions.get(sid) if isinstance(sid, str) else None
        if (
            asked is not None
            and asked.get("agent") == body["agent"]
            and isinstance(k, int)
            and 0 <= k < len(asked["actions"])
            and asked["actions"][k] == text
        ):
            return None  # the step of a request it was sent: the manager handles what it did
        if self._next_human_step(text):
            return None  # the step asked of it (the common case: no copy made)
        if self.tm.advances(max(self.now, float(t)), HumanAction(action.name, action.args)):
            return None
        return (
            f"{text} is no step {body['agent']} was asked to do and advances no feasible part "
            "of the task now"
        )

    def _held_elsewhere(self, t: float, body: dict[str, Any]) -> bool:
        """A person's reported step works on a part another agent holds by the time it ends
        (the domain's ``on_stop.holding`` fact): the person could not have done it — they give
        up (``human_gives_up``) and their request ends; the manager is told nothing."""
        human = str(body["agent"])
        action = ground(self.domain, body["action"])
        holder = self._helper(human).holder_of(self.kb, self.domain, action)
        if holder is None:
            return False
        self.now = max(self.now, float(t))
        obj = next((a for a in action.args if a in self.kb.objects and a != human), None)
        if self.observers and not self.replaying:
            start = min(float(body.get("start", t)), float(t))
            why = f"{obj} already held by {holder}"
            self._observe(
                action_end(round(self.now, 6), [human], body["action"], "failed", start, reason=why)
            )
        self._record("human_gives_up", {"object": obj, "holder": holder, "agent": human})
        if self.active_suggestion.get(human) == body.get("suggestion"):
            del self.active_suggestion[human]
        self._settle()
        return True

    def _supersede(self, human: str) -> None:
        """A new request replaces what ``human`` was asked before: a step of the old one still
        under way is dropped (the person turns to the new request; its end never happens, as
        with a stopped command)."""
        old = self._last_suggestion.get(human)
        if old is None:
            return
        self.superseded[old] = self.now
        if self.ordered:
            self.pending = [
                x
                for x in self.pending
                if not (
                    x[2] == "human_action" and x[3].get("suggestion") == old and x[0] > self.now
                )
            ]

    def _send_command(self, agent: str, cmd: Command) -> None:
        st = self.agents[agent]
        if self.replaying or not st.alive or not st.available:
            return
        self._sent_at[cmd.id] = time.monotonic()
        self.transport.publish(
            P.cmd_topic(agent),
            P.message(
                "command",
                id=cmd.id,
                agents=list(cmd.agents),
                action=str(cmd.action),
                element=cmd.element,
                t=self._issued_at.get(cmd.id, self.now),
                expected_s=float(cmd.expected_s),
                world=world_of(self.kb),
                realtime=self.agent_speed,
                process=bool(getattr(cmd, "process", False)),
                **self._start_joints.get(cmd.id, {}),
                run=self.run_id,
                fingerprint=self.fingerprint,
                **self._to(agent),
            ),
        )

    def _predict(self, cmd: Command) -> None:
        """Move the manager's robot model through a robot command it sends, as the arm will
        move, so that it plans the next branches from where the arms will be; the arm's ack
        then says where they really ended. Arms that execute on the model itself (one process,
        ``shared_model``) move it already."""
        model = self.tm.simulator
        if self.shared_model or not hasattr(model, "set_joint_state"):
            return
        positions = {k: o.position for k, o in self.kb.objects.items()}
        model.execute(cmd.action, positions, self.kb, self.domain)  # type: ignore[attr-defined]

    def _joints_of(self, arms: Sequence[str]) -> dict[str, Any]:
        """``{"joints": ...}``: where the manager's robot model has ``arms`` (nothing for a
        model without joints)."""
        joint_state = getattr(self.tm.simulator, "joint_state", None)
        joints = {} if joint_state is None else joint_state(arms)
        return {"joints": joints} if joints else {}

    def _send_suggestion(self, human: str, sid: str) -> None:
        st = self.agents[human]
        msg = dict(self.suggestions[sid])
        step, start = self.suggestion_step.get(sid, (0, float(msg["t"])))
        if self.replaying or not st.alive or not st.available or step >= len(msg["actions"]):
            return
        msg.pop("agent", None)
        msg.update(t=start, step=step, world=world_of(self.kb), realtime=self.agent_speed)
        msg.update(run=self.run_id, fingerprint=self.fingerprint, **self._to(human))
        if self._sent_step.get(sid) != step and self.observers:  # the person starts this step
            self._observe(
                {
                    "t": round(max(start, self.now), 6),
                    "type": "action_start",
                    "agents": [human],
                    "action": msg["actions"][step],
                }
            )
        self._sent_step[sid] = step
        self._last_suggestion[human] = sid
        self.transport.publish(P.suggest_topic(human), P.parse(msg, expect="suggestion"))

    def _continue_suggestions(self) -> None:
        """The operator finished a step the manager has handled: send it the next one."""
        for human, sid in sorted(self.active_suggestion.items()):
            step = self.suggestion_step.get(sid, (0, 0.0))[0]
            if step > self._sent_step.get(sid, -1):
                self._send_suggestion(human, sid)

    def _resend(self, agent: str) -> None:
        """An agent is (again) reachable: send what it should be doing (after a resume)."""
        if self.sourced and agent in self._vacated:
            # its name is still granted to a process that died: what this sends would be
            # addressed to that dead session; the new process's join (asked for, see
            # :meth:`_ask_joins`) grants it the name and resends then
            return
        for a, cmd in sorted(self.tm.busy.items()):
            if a == agent == cmd.agents[0] and cmd.id not in self.acked:
                self._send_command(agent, cmd)
        sid = self.active_suggestion.get(agent)
        if sid is not None:
            self._send_suggestion(agent, sid)
        oid = self.awaiting.get(agent)
        if oid is not None:
            self._send_options(agent, oid)

    def _resend_overdue(self) -> None:
        """Send again a command whose answer is long overdue (a message lost on the way, an
        agent that reconnected): agents treat a repeated id as the same command."""
        now = time.monotonic()
        pending_ids = {b["id"] for *_, k, b in self.pending if k == "ack"}
        for agent, cmd in sorted(self.tm.busy.items()):
            sent = self._sent_at.get(cmd.id)
            if agent != cmd.agents[0] or sent is None or cmd.id in pending_ids:
                continue
            if cmd.id in self.acked:
                continue
            # an agent reports a time-out itself after 3x the expected time
            paced = 3.0 * cmd.expected_s / self.agent_speed if self.agent_speed > 0 else 0.0
            wait = 2.0 + paced
            if now - sent > wait:
                log.info("command %d to %s: no answer after %.1f s, resent", cmd.id, agent, wait)
                self.resent += 1
                self._send_command(agent, cmd)
        pending_intent = {b["agent"] for *_, k, b in self.pending if k == "intent"}
        for human, oid in sorted(self.awaiting.items()):
            sent = self._options_sent_at.get(oid)
            if human not in pending_intent and sent is not None and now - sent > 2.0:
                log.info("options %s to %s: no answer after 2 s, resent", oid, human)
                self.resent += 1
                self._send_options(human, oid)

    def _publish_state(self, *, force: bool = False) -> None:
        if not (self.publish_state or force):
            return
        self._state_seq += 1
        try:
            self.transport.publish(
                P.STATE_TOPIC,
                {"v": P.VERSION, "type": "state", **self.snapshot(), "seq": self._state_seq},
            )
        except Exception as exc:  # a panel's view must never stop the cell
            log.warning("state not published: %s", exc)

    # -- identity (flexhrc.cell.identity) -----------------------------------------------------
    @staticmethod
    def _check_single_manager(transport: Transport, name: str) -> None:
        """One manager per cell name: a manager's token already alive refuses this one (the
        first keeps the cell). Over a transport that cannot be asked, nothing is checked."""
        holders = getattr(transport, "liveliness_holders", None)
        if holders is not None and holders(P.alive_key(P.MANAGER)):
            raise FlexhrcError(
                f"--cell {name}: another manager already runs this cell (its liveliness token "
                f"{P.alive_key(P.MANAGER)} is alive); a second one is refused: stop it first "
                "or choose another --cell name (a manager that just died keeps it until its "
                "liveliness lease ends: about 10 s over Zenoh, 1 s over ROS 2)"
            )

    def _other_run(self, msg: dict[str, Any]) -> bool:
        """The message names a run other than this cell's (none named: legacy, accepted)."""
        run = msg.get(identity.RUN)
        return run is not None and run != self.run_id

    def _on_join(self, data: Any, source: str | None = HERE) -> None:
        """An agent joins with its scenario's fingerprint: one of another scenario is refused
        (a log line here; its token is not counted as the agent's; the ``state`` this
        publishes shows it the cell's fingerprint, and it exits with a clear error)."""
        try:
            msg = P.parse(data, expect="join")
            if msg["agent"] not in self.agents:
                raise P.ProtocolError(f"{msg['agent']!r} is not an agent of this cell")
        except FlexhrcError as exc:
            self._drop(f"join: {exc}")
            return
        name = str(msg["agent"])
        if msg["fingerprint"] != self.fingerprint:
            why = (
                f"agent {name} refused: its scenario {msg['scenario']} (fingerprint "
                f"{msg['fingerprint']}) is not this cell's {self.scenario.name} (fingerprint "
                f"{self.fingerprint})"
            )
            if self.refused.get(name) != why:
                self.refused[name] = why
                log.error("%s", why)
                self.trace(
                    {"t": round(self.now, 6), "type": "refused", "agent": name, "reason": why}
                )
            st = self.agents[name]
            if st.alive:
                st.alive = False
                if self.started and st.available:
                    self._agent_down(name)
            # the answer: a snapshot with this cell's fingerprint (a matching agent gets none,
            # so the first state of a cell still comes with its start)
            self._publish_state(force=True)
        else:
            before = (self.sessions.get(name), name in self._vacated)
            if not self._grant(name, source):
                self._publish_state(force=True)  # the answer: the refused process exits (K09)
            elif self.refused.pop(name, None) is not None and self._token_alive.get(name):
                self._on_alive(P.alive_key(name), True)  # this agent's own process: counted now
            elif (
                before != (self.sessions.get(name), False)
                and self._token_alive.get(name)
                and self.started
                and not self.tm.done
            ):
                # a new process (or the same one after its token came back) holds the name
                # now: what the manager resent on its token went nowhere or was never sent
                self._resend(name)

    def _unjoined(self) -> list[str]:
        """Agents whose token is alive but whose process holds no grant: its ``join`` was
        lost (Zenoh drops a message to a session that is not yet fully connected, e.g. a
        resumed manager's), or its granted process died and a new one took the token."""
        if not self.sourced or self.token is None:
            return []
        return [
            n
            for n, alive in sorted(self._token_alive.items())
            if alive and n not in self.refused and (n not in self.sessions or n in self._vacated)
        ]

    def _ask_joins(self) -> None:
        """Ask, at most once a second, the processes of :meth:`_unjoined` agents to join
        (again): a ``state`` naming them in ``unjoined``. Without it a single lost ``join``
        leaves an agent alive but never counted, and the cell waits for ever."""
        now = time.monotonic()
        if now - self._asked_joins_at < 1.0 or not self._unjoined():
            return
        self._asked_joins_at = now
        self._publish_state(force=True)

    # -- one process per agent name (probe K09) and only its messages (P10, P17, P19) --------
    def _listen(self, topic: str, handler: Callable[[Any, str | None], None]) -> Any:
        """Subscribe ``handler(data, source)``: with the sending session's id over a transport
        that names it (:meth:`flexhrc.transport.zenoh.ZenohTransport.subscribe_from`)."""
        if self.sourced:
            return self.transport.subscribe_from(topic, handler)  # type: ignore[attr-defined]
        return self.transport.subscribe(topic, lambda data: handler(data, HERE))

    def _grant(self, name: str, source: str | None) -> bool:
        """The agent name goes to the first session that joins with it and stays with it until
        its token, once seen, is gone (then a restarted process takes it); a join of another
        session meanwhile is refused, whatever the order in which the two processes' liveliness
        queries, tokens and joins arrived on a loaded machine. Returns whether ``source``
        holds the name now."""
        if not self.sourced or source == HERE:
            return True
        held = self.sessions.get(name)
        gone = name in self._vacated  # its token went away since: the holder died
        if source is not None and (held is None or held == source or gone):
            self.sessions[name] = source
            self._vacated.discard(name)
            self.refused_sessions.pop(source, None)
            return True
        why = (
            f"agent {name}: another process already serves this agent in the cell (session "
            f"{held}); a second one is refused"
            if source is not None
            else f"agent {name}: a join without the sender's Zenoh session (source info) is refused"
        )
        key = source or "unknown"
        if self.refused_sessions.get(key) != why:
            self.refused_sessions[key] = why
            log.error("%s (session %s)", why, key)
            self.trace({"t": round(self.now, 6), "type": "refused", "agent": name, "reason": why})
        return False

    def played_here(self, name: str) -> None:
        """This process plays agent ``name`` itself (the panel's operator, whose token it
        declares on the manager's own session): the name is this session's, no join needed."""
        own = getattr(self.transport, "session_id", None)
        if self.sourced and isinstance(own, str):
            self.sessions[name] = own

    def _foreign(self, agent: str, source: str | None) -> str | None:
        """Why a message speaking for ``agent`` from session ``source`` is not its granted
        process's (None: it is, or this transport cannot tell)."""
        if not self.sourced or source == HERE:
            return None
        held = self.sessions.get(agent)
        if held is not None and source == held:
            return None
        sender = f"session {source}" if source is not None else "a session that names none"
        if held is None:
            return f"from {sender}, but no process has joined as {agent}"
        return f"from {sender}, not {agent}'s process (session {held}): spoofed or refused"

    def _to(self, agent: str) -> dict[str, Any]:
        """``{"session": ...}``: the one process of ``agent`` a message is for (nothing when
        this transport names no sessions); any other process of that name leaves it alone."""
        held = self.sessions.get(agent)
        return {"session": held} if held is not None else {}

    def _own_run(self, events: list[StoredEvent]) -> list[StoredEvent]:
        """The stored events of the run to resume: the store must be of this scenario, seed
        and pace (:func:`identity.check_resume`) and hold one run; the run id is taken from
        it. Returns the events without their ``run`` (the cell's own records leave it out)."""
        where = f"{self.store.option} {self.store.path}" if self.store is not None else "store"
        start = events[0].body
        identity.check_resume(
            start,
            where=where,
            scenario=str(self.scenario.name),
            fingerprint=self.fingerprint,
            seed=self.seed,
            realtime=self.realtime,
        )
        self.run_id = identity.run_of(start)
        out = []
        for ev in events:
            run = ev.body.get(identity.RUN)
            if run is not None and run != self.run_id:
                raise FlexhrcError(
                    f"{where}: event {ev.seq} ({ev.kind}) is of run {run}, not of the stored "
                    f"run {self.run_id}: the store mixes two runs"
                )
            body = {k: v for k, v in ev.body.items() if k != identity.RUN}
            out.append(StoredEvent(ev.seq, ev.t, ev.kind, body))
        return out

    # -- resume -------------------------------------------------------------------------------
    def _replay(self, events: list[StoredEvent]) -> None:
        source = self.store.path if self.store else "store"
        if not events:  # (EventStore refuses an empty store first, with a hint)
            raise FlexhrcError(f"{source}: nothing to resume (the store holds no events)")
        if events[0].kind != "start":
            raise FlexhrcError(f"{source}: nothing to resume (no start event)")
        events = self._own_run(events)
        check_events(events, source)  # a corrupted row: one clear error naming it, no replay
        last = max(i for i, ev in enumerate(events) if ev.is_input)
        self.replaying = True
        try:
            for i, ev in enumerate(events):
                self.events.append(ev)
                if ev.kind == "command":
                    self.stored_commands.add(int(ev.body["id"]))
                if ev.is_input:
                    self.now = max(self.now, ev.t)
                    if i == last:
                        self._captured = []
                    try:
                        self._handle(self._feed(ev.kind, ev.body))
                        self._settle()
                    except (FlexhrcError, KeyError, TypeError, ValueError, AttributeError) as exc:
                        raise FormatError(
                            f"event {ev.seq} ({ev.kind}): cannot be replayed "
                            f"({type(exc).__name__}: {exc})",
                            source,
                        ) from None
        finally:
            self.replaying = False
        self.resumed = True
        self._record_kept_outputs(events[last + 1 :])
        self._stored_end(self.events)
        self._refresh_suggestions()
        # outputs of the last input that the crash kept from the store
        for cmd in sorted(self.tm.busy.values(), key=lambda c: c.id):
            if cmd.id not in self.stored_commands:
                body = {**cmd.to_dict(), "t": self.now}
                body.pop("type", None)
                self._record("command", body)
                self.stored_commands.add(cmd.id)

    def _record_kept_outputs(self, stored: list[StoredEvent]) -> None:
        """What the manager made of the last stored input — its records (``decision``,
        ``solved``, ``fixed``, ``outcome`` ...) and outputs — that the crash kept from the store:
        the replay made them again, in the same order; those past the stored ones are recorded
        now, so the store holds the run as the uninterrupted one would (a resume after the
        ``start`` lost no decision, after the last ack no ``solved``)."""
        made, self._captured = self._captured or [], None
        kinds = [ev.kind for ev in stored]
        if [k for k, _ in made[: len(kinds)]] != kinds:
            return  # the loop's own records (an end it decided): the outputs were all stored
        for kind, body in made[len(kinds) :]:
            self._record(kind, body, observe=kind not in STORED_LOG_TYPES)
            if kind == "command":
                self.stored_commands.add(int(body["id"]))

    def _stored_end(self, events: list[StoredEvent]) -> None:
        """A stored ``outcome`` the loop decided itself (failed: stuck or out of time,
        interrupted) is no input, so the replay does not reach it: the run ended all the same,
        and a resume must not run its end again (probe ST32: each resume appended another
        outcome). The closing summary a crash kept from the store is written now."""
        end = next((ev for ev in reversed(events) if ev.kind == "outcome"), None)
        if end is None:
            return
        if not self.tm.done:
            self.tm.outcome = str(end.body.get("outcome"))
            self.tm.reason = end.body.get("reason")
        if not any(ev.kind == "summary" for ev in events):
            self._record("summary", self.summary())

    def _refresh_suggestions(self) -> None:
        runs = {
            a: ex
            for ex in self.tm.executions.values()
            if ex.owner == "human"
            for a in ex.branch.agents
        }
        for human, sid in list(self.active_suggestion.items()):
            ex, msg = runs.get(human), self.suggestions[sid]
            done = self.suggestion_step.get(sid, (0, 0.0))[0]
            if not msg.get("own"):
                if ex is None:
                    del self.active_suggestion[human]
                continue
            if ex is None:
                if done > 0:
                    del self.active_suggestion[human]  # it advanced nothing the manager knows
                continue
            # the manager's grounding of the rest of the hyper-arc, as the operator follows it
            rest = [str(a) for a in ex.branch.steps[ex.next_index :]]
            if rest == msg["actions"][done:]:
                continue
            if not rest:
                del self.active_suggestion[human]
                continue
            nid = f"s{len(self.suggestions) + 1}"
            self.suggestions[nid] = {**msg, "id": nid, "actions": rest, "t": self.now}
            self.active_suggestion[human] = nid

    # -- the loop -----------------------------------------------------------------------------
    def awaited(self) -> list[str]:
        """Agents whose answer the discrete-event loop waits for before it moves on."""
        pending_cmd = {b["id"] for *_, k, b in self.pending if k == "ack"}
        pending_human = {b["agent"] for *_, k, b in self.pending if k == "human_action"}
        pending_human |= {
            b["agent"] for *_, k, b in self.pending if k == "human_reply" and b["reply"] != "start"
        }
        pending_human |= {h for h, sid in self.active_suggestion.items() if sid in self._timed_out}
        out = [
            a
            for a, c in sorted(self.tm.busy.items())
            if c.id not in pending_cmd and self.agents[a].available
        ]
        for ex in self.tm.executions.values():
            if ex.owner != "human":
                continue
            for a in ex.branch.agents:
                st = self.agents.get(a)
                waits = st and st.kind == "human" and st.available and a not in pending_human
                if waits and not self._nothing_to_do(a):  # asked nothing, or reported it all
                    out.append(a)
        pending_intent = {b["agent"] for *_, k, b in self.pending if k == "intent"}
        for human, sid in sorted(self.active_suggestion.items()):
            msg = self.suggestions[sid]
            step = self.suggestion_step.get(sid, (0, 0.0))[0]
            mine = msg.get("own") and step < len(msg["actions"]) and self.agents[human].available
            if mine and human not in pending_human and human not in out:
                out.append(human)  # doing its own plan, before the manager knows of it
        for human in sorted(self.awaiting):
            if self.agents[human].available and human not in pending_intent:
                out.append(human)  # deciding whether to act on its own
        if self.started and not self.tm.done:
            out += [w for w in self.watchers if self._looked.get(w, 0) < self._state_seq]
        return out

    def _nothing_to_do(self, human: str) -> bool:
        """The manager waits for the operator, who was asked nothing (a report of an action it
        did not do) or has reported every step it was given (a report the wrist sensor missed):
        in the ordered loop nothing more will come from it."""
        sid = self.active_suggestion.get(human)
        if sid is None:
            return human not in self.awaiting
        if self.suggestions[sid].get("own"):
            return False
        return self.suggestion_step.get(sid, (0, 0.0))[0] >= len(self.suggestions[sid]["actions"])

    def request_stop(self, reason: str = "interrupted") -> None:
        """End the cooperation at the next turn of the loop with the outcome ``interrupted``
        (safe from a signal handler: it only sets a flag; the loop writes the final events)."""
        self._stop_reason = reason

    def _end(self, outcome: str, reason: str) -> None:
        """The loop ends the cooperation itself (interrupted, stuck, out of time)."""
        self.tm.outcome, self.tm.reason = outcome, reason
        self._record("outcome", {"outcome": outcome, "reason": reason})

    def _missing(self) -> list[str]:
        # over a transport that names sessions, an agent counts once its process has joined
        # too: the manager then knows whose answers to take (and an operator's profile, which
        # its process announces after its join, before its token)
        joined = not self.sourced or self.token is None
        return [
            n for n, st in self.agents.items() if not st.alive or not (joined or n in self.sessions)
        ]

    def wait_for_agents(
        self,
        timeout: float,
        progress: Callable[[str], None] | None = None,
        pump: Callable[[float], None] | None = None,
    ) -> None:
        """Block until every agent of the scenario is alive and, over a transport that names
        sessions, its process has joined (external agents); ``pump(timeout)`` lets the
        transport deliver (and agents in this process act), else the transport is waited on."""
        deadline = time.monotonic() + timeout
        said: set[str] = set()
        while self._missing():
            if time.monotonic() > deadline:
                silent = [n for n in self._missing() if self.agents[n].alive]
                absent = [n for n in self._missing() if not self.agents[n].alive]
                why: list[str] = []
                if absent:
                    why.append(
                        f"no agent process for {', '.join(absent)} after {timeout:g} s; "
                        + self.agents_hint
                    )
                if silent:  # its token arrived, its ``join`` never did
                    why.append(
                        f"the process of {', '.join(silent)} is alive but never joined the "
                        f"cell after {timeout:g} s (its `join` did not arrive: a Zenoh access "
                        "control that denies it? `flexhrc certs DIR` writes configs that allow "
                        'it; docs/cell.md, "Securing a cell")'
                    )
                raise FlexhrcError("; ".join(why))
            for n in self._missing():
                if progress and n not in said:
                    progress(f"waiting for agent {n} ...")
                    said.add(n)
            self._ask_joins()
            if pump is not None:
                pump(0.1)
            else:
                self.transport.wait(0.1)  # type: ignore[attr-defined]
                self.transport.flush()

    def step(self) -> bool:
        """Handle one pending answer if the loop may; returns whether it did."""
        if not self.pending or self.tm.done:
            return False
        if self.ordered:
            if self.awaited():
                return False
            # earliest end first; a tie goes by what the answer is about (the command's id,
            # the operator and its report), never by which process happened to answer first
            self.pending.sort(key=_answer_order)
            t, _, kind, body = self.pending[0]
            if self.max_time_s is not None and t > self.max_time_s:
                self._end("failed", f"time budget {self.max_time_s} s exceeded")
                return False
            self.pending.pop(0)
            if self.realtime > 0:
                lag = (t - self.now) / self.realtime - (time.perf_counter() - self._last_wall)
                if lag > 0:
                    time.sleep(min(lag, 5.0))
                    self._slept += min(lag, 5.0)
        else:
            self.pending.sort(key=lambda x: x[1])  # arrival order
            # an operator's intent is due when the person starts (after thinking)
            clock = self._clock()
            due = [i for i, x in enumerate(self.pending) if x[2] != "intent" or x[0] <= clock]
            if not due:
                return False
            t, _, kind, body = self.pending.pop(due[0])
        self._last_wall = time.perf_counter()
        if kind == "look":  # a watcher looks by itself now: no input, a state to look at
            self.now = max(self.now, t)
            self._publish_state()
            return True
        if kind == "human_action" and self._repeated_report(
            str(body["agent"]), ground(self.domain, body["action"])
        ):  # its twin, handled just before it, did what it says (P25)
            self._drop(f"human_action {body['id']}: {_REPEATED.format(action=body['action'])}")
            return True
        if kind == "human_action" and (said := self._not_possible(t, body)) is not None:
            self._drop(f"human_action {body['id']}: {said}")  # P19
            return True
        if kind == "human_action" and self._held_elsewhere(t, body):
            return True
        if kind == "human_reply" and (said := self._reply_problem(body)) is not None:
            self._drop(f"reply {body['id']}: {said}")
            return True
        if kind == "human_action" and "start" not in body:
            # a report without its start (a panel's "done"): when the person said they started
            began = self._starts.get(str(body["agent"]))
            if began is not None and began[0] in (None, body["action"]) and began[1] <= t:
                body = {**body, "start": round(began[1], 6)}
        self._input(kind, body, t)
        self._refresh_suggestions()
        self._continue_suggestions()
        return True

    def run(
        self,
        *,
        pump: Callable[[float], None],
        agents_timeout: float = 30.0,
        max_wall_s: float = 3600.0,
        progress: Callable[[str], None] | None = None,
    ) -> dict[str, Any]:
        """Run the cooperation to its end; ``pump(timeout)`` lets the transport deliver."""
        self._last_wall = time.perf_counter()
        if not self.resumed:
            self.wait_for_agents(agents_timeout, progress, pump)
        self._clock0 = time.perf_counter() - (self.now / self.realtime if self.realtime else 0)
        if not self.resumed:
            self._input(
                "start",
                {
                    "agents": list(self.domain.agents),
                    "humans": [n for n, st in self.agents.items() if st.kind == "human"],
                    "scenario": self.scenario.name,
                    "fingerprint": self.fingerprint,
                    "seed": self.seed,
                    "realtime": self.realtime,
                    "simulator": simulator_name(self.tm.simulator),
                    "on_failure": self.tm.on_failure,
                    **({"policy": self.policy} if self.policy != DEFAULT_POLICY else {}),
                    "operators": dict(self.operators),
                    **self._operator_model_input(),
                    **({"watchers": list(self.watchers)} if self.watchers else {}),
                    **({"scripted": sorted(self.scripted)} if self.scripted else {}),
                },
            )
        elif self.tm.done:  # the stored cooperation had already ended: nothing to add
            if progress:
                progress(f"the stored cooperation already ended: {self.tm.outcome}")
            self._tell_the_end(pump, agents_timeout)
            return self.summary()
        else:
            self.started = True
            if progress:
                progress(f"resumed from {len(self.events)} stored events at t = {self.now:.2f} s")
            for name, st in self.agents.items():
                if st.alive and st.available:  # the others resend when their token arrives
                    self._resend(name)
            self._fail_lost()
        resumed_at = time.monotonic() if self.resumed else None
        deadline = time.monotonic() + max_wall_s
        idle_since: float | None = None
        while not self.tm.done:
            if self._stop_reason is not None:
                self._end("interrupted", self._stop_reason)
                break
            if resumed_at is not None and time.monotonic() - resumed_at > agents_timeout:
                # an agent that died while the manager was down never shows its token again
                resumed_at = None
                for name, st in self.agents.items():
                    if not st.seen and st.available:
                        if progress:
                            progress(f"agent {name} did not come back after {agents_timeout:g} s")
                        self._agent_down(name)
            if self.step():
                idle_since = None
                continue
            if self._fire_timeouts():
                continue
            if not self.pending and self.quiescent is not None and self.quiescent():
                self._end("failed", stall_reason(self.tm))
                break
            if not self.pending and not self.awaited():
                # nothing running, nothing to come: stuck, unless a lost agent may come back
                if any(not st.available for st in self.agents.values()):
                    idle_since = None
                else:
                    idle_since = idle_since or time.monotonic()
                if idle_since is not None and time.monotonic() - idle_since >= self.idle_s:
                    self._end("failed", stall_reason(self.tm))
                    break
            self._resend_overdue()
            self._ask_joins()
            if time.monotonic() > deadline:
                self._end("failed", f"wall time {max_wall_s} s exceeded")
                break
            self._pump(pump)
        summary = self.summary()
        self._record("summary", summary)
        self._say_end()
        self._publish_state()
        self._see_them_leave(pump)
        return summary

    def _see_them_leave(self, pump: Callable[[float], None]) -> None:
        """The end is one message, and a message sent just before its sender closes can be
        lost on the way (a DDS writer deleted before its readers acknowledged the sample): an
        agent process that missed it would wait for ever. So, over a transport with liveliness,
        the manager stays until every agent's token is gone — each leaves at the end — and says
        the end again every :data:`END_REPEAT_S`, for :data:`END_WAIT_S` at most (an agent that
        stays, e.g. one of another run, must not keep the manager)."""
        if self.token is None:  # one process: every agent has heard it
            return
        deadline = time.monotonic() + END_WAIT_S
        said = time.monotonic()
        while any(st.alive for st in self.agents.values()) and time.monotonic() < deadline:
            pump(0.05)
            if time.monotonic() - said >= END_REPEAT_S:
                said = time.monotonic()
                self._say_end()

    def _say_end(self) -> None:
        """The run's end, on the state topic (every agent process leaves when it hears it)."""
        self.transport.publish(
            P.STATE_TOPIC, P.message("end", outcome=self.tm.outcome, run=self.run_id)
        )

    def _pump(self, pump: Callable[[float], None]) -> None:
        """Let the transport deliver, and notice a stalled manager (probe K06).

        A process that did not run for longer than the transport's lease (SIGSTOP, a paused
        VM, a starved machine) finds every agent's liveliness token gone when it wakes — its
        own session lapsed, not the agents — and the acks they sent meanwhile lost with it.
        Declaring them lost would fail commands that were done. So a token that goes while
        the loop did not run for :data:`STALL_S`, or within :data:`STALL_GRACE_S` after, is
        doubted: the agent counts as lost only if its token is not back by then; when it is,
        its commands are sent again and it answers the done ones from its memory."""
        pump(0.05)
        now = time.monotonic()
        if now - self._turn_end - self._slept > STALL_S:
            self._stalled_until = now + STALL_GRACE_S
            log.info(  # (a long plan on a loaded machine too: then it only delays a loss)
                "the cell did not run for %.1f s: a liveliness token lost now is doubted for "
                "%.0f s",
                now - self._turn_end - self._slept,
                STALL_GRACE_S,
            )
        self._turn_end, self._slept = now, 0.0
        for name, until in sorted(self._doubtful.items()):
            if self.agents[name].alive:
                del self._doubtful[name]
            elif now > until:
                del self._doubtful[name]
                if self.agents[name].available and not self.tm.done:
                    self._agent_down(name)

    def _stalled(self) -> bool:
        now = time.monotonic()
        return now - self._turn_end - self._slept > STALL_S or now < self._stalled_until

    def _tell_the_end(self, pump: Callable[[float], None], timeout: float) -> None:
        """The stored run had ended (the manager died after its end, before the agents heard
        of it): agent processes that kept running learn it once they are back, so wait a
        little for them (they re-dial within a second) — and not longer, for none may be left —
        then say it as at the end of a run (:meth:`_see_them_leave`)."""
        deadline = time.monotonic() + min(timeout, END_WAIT_S)
        while self.token is not None and self._missing() and time.monotonic() < deadline:
            pump(0.05)
        self._say_end()
        self._see_them_leave(pump)

    def summary(self) -> dict[str, Any]:
        """The keys of ``flexhrc run --json`` (counted from the stored events), plus the cell's
        (``cell``: name, events, resumed, dropped, agents) and the final ``knowledge`` base."""
        from flexhrc.taskmanager.replay import summarise_log

        log_form = log_events([e for e in self.events if e.kind != "summary"])
        data = summarise_log(log_form)
        tm = self.tm.summary()
        data["outcome"], data["reason"] = tm["outcome"], tm["reason"]
        data["simulator"] = simulator_name(self.tm.simulator)
        data["on_failure"] = self.tm.on_failure
        if self.policy != DEFAULT_POLICY:  # the default keeps the JSON as it was
            data["policy"] = self.policy
            data["advice_s"] = _latency(self.tm.advice_s)
        data["decisions"] = tm["decisions"]
        data["branches_simulated"] = tm["branches_simulated"]
        data["timing"].update(tm["timing"])
        data["compute_recorded"] = True  # this manager's own compute, not a log's
        # how each action the manager simulated was simulated (kinematic | analytic | none)
        data["simulated"] = dict(getattr(self.tm.simulator, "simulated", None) or {})
        data["scenario"] = str(self.scenario.name)
        data["wall_s"] = time.perf_counter() - self._wall0
        data["cell"] = {
            "name": self.name,
            "events": len(self.events),
            "resumed": self.resumed,
            "dropped": len(self.dropped),
            "resent": self.resent,
            "agents": {n: st.to_dict() for n, st in self.agents.items()},
        }
        data["knowledge"] = self.kb.to_dict()
        return data

    def close(self) -> None:
        for sub in self._subs:
            sub.cancel()
        if self.token is not None:
            self.token.undeclare()


def latency_figures(samples: Sequence[float]) -> dict[str, Any]:
    """The decision latency of a run from :attr:`Cell.decision_latencies_s`: how many inputs
    made a decision (``n``) and the median, 95th percentile (nearest rank) and largest wall
    seconds the Task Manager took to answer one; None for each figure when nothing was
    decided."""
    xs = sorted(samples)
    if not xs:
        return {"n": 0, "median_s": None, "p95_s": None, "max_s": None}
    mid = len(xs) // 2
    median = xs[mid] if len(xs) % 2 else (xs[mid - 1] + xs[mid]) / 2
    p95 = xs[max(0, -(-95 * len(xs) // 100) - 1)]
    return {"n": len(xs), "median_s": median, "p95_s": p95, "max_s": xs[-1]}


def _answer_order(item: tuple[float, int, str, dict[str, Any]]) -> tuple[Any, ...]:
    t, _, kind, body = item
    if kind == "ack":
        return (t, 0, int(body["id"]), "")
    return (t, 1, 0, f"{body.get('agent')}:{body.get('id')}")


def _kind(graph: Any, name: str) -> str | None:
    try:
        return str(graph.kind(name))
    except KeyError:
        return None


def answer_timeout_of(scenario: Any, given: float | None) -> float | None:
    """How long a person may leave a request unanswered before it counts as declined:
    ``given`` (``--answer-timeout``), else the scenario's ``answer_timeout`` key, else never."""
    value = given if given is not None else getattr(scenario, "answer_timeout", None)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < 1e6:
        raise FlexhrcError(f"--answer-timeout must be a number of seconds > 0, got {value!r}")
    return float(value)


def failure_policy(scenario: Any, given: str | None) -> str:
    """The failure policy of a run: ``given`` (``--on-failure``), else the scenario's
    ``on_failure`` key, else ``retry`` (:data:`~flexhrc.taskmanager.manager.FAILURE_POLICIES`)."""
    if given is not None:
        return check_failure_policy(given, "--on-failure")
    return check_failure_policy(getattr(scenario, "on_failure", None) or FAILURE_POLICIES[0])


def decision_policy(scenario: Any, given: str | None) -> str:
    """The decision policy of a run: ``given`` (``--policy``), else the scenario's ``policy``
    key, else ``paper`` (:mod:`flexhrc.taskmanager.policy`)."""
    if given is not None:
        return check_policy(given, "--policy")
    return check_policy(getattr(scenario, "policy", None) or DEFAULT_POLICY, "policy")


def _latency(samples: list[float]) -> dict[str, float | int]:
    """How long the advisor took at its decisions (seconds): how many, the first (it prepares
    the advisor: a planner builds its model), and the median and p95 of the others."""
    if not samples:
        return {"decisions": 0, "first_s": 0.0, "median_s": 0.0, "p95_s": 0.0}
    rest = sorted(samples[1:]) or [samples[0]]
    p95 = rest[min(len(rest) - 1, round(0.95 * (len(rest) - 1)))]
    return {
        "decisions": len(samples),
        "first_s": round(samples[0], 6),
        "median_s": round(rest[len(rest) // 2], 6),
        "p95_s": round(p95, 6),
    }


def _percept_of(body: dict[str, Any]) -> dict[str, Any]:
    """A percept message as the knowledge base keeps one (:class:`Inconsistency`)."""
    pose = [float(v) for v in body["pose"][:3]]
    size = body.get("size")
    return {
        "type": str(body["object_type"]),
        "position": (pose[0], pose[1], pose[2]),
        "size": dict(size) if isinstance(size, dict) else {},
        "attrs": {},
    }


_REPEATED = (
    "{action} was reported before and would change nothing now (its effects hold, no step "
    "expects it): a repeated report"
)


def _moves_untouched(
    what: str, action: GroundAction, agents: Sequence[str], msg: dict[str, Any]
) -> str | None:
    """An answer's ``positions`` name only what its action touches — its agents and its
    arguments — else why not: an ack of ``approach(left, leg1)`` cannot move the tabletop
    (probe 2026-12-02, P12)."""
    touched = {*agents, *action.agents, *action.args}
    extra = sorted(set(msg.get("positions") or {}) - touched)
    if extra:
        return f"{what} moves {', '.join(extra)}, which {action} does not touch"
    return None


def _body(msg: dict[str, Any]) -> dict[str, Any]:
    """A received message as the input it is (its ``run`` was checked; the store adds it to
    every row)."""
    return {k: v for k, v in msg.items() if k not in ("v", "type", identity.RUN)}
