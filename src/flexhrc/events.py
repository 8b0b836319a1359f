"""The one catalogue of flexhrc's events, messages and vocabularies.

Three streams carry JSON objects tagged by ``"type"`` (the store by ``kind``), and each tag
names one schema here:

* **log events** (:data:`LOG_EVENTS`): what a cooperation writes to ``flexhrc run --log``
  (one object per line, ``"t"`` and ``"type"`` first), what the cell traces and keeps in its
  store, what the panel keeps. ``flexhrc replay`` accepts the :data:`REPLAY_TYPES`, the trace
  of ``run``/``demo`` prints the :data:`TRACE_TYPES`.
* **protocol messages** (:data:`MESSAGES`): the cell protocol of ``docs/protocol.md``
  (``"v": 1`` and ``"type"``); :func:`flexhrc.cell.protocol.parse` checks a message against its
  schema here.
* **store kinds** (:data:`STORE_KINDS`): the ``kind`` column of the cell's event store, an
  input of the Task Manager, an output it sent, or one of its records.

A schema is declared once, as data (:class:`EventSchema`: a ``Literal`` type tag, its
:class:`Field` s and the rules that span fields), and everything else is derived from it: the
validators (:meth:`EventSchema.problem`, :meth:`Event.from_dict`), the sets of types each consumer
reads, and the table of ``docs/protocol.md`` (:func:`catalogue_markdown`). Records keep the
JSON the emitters have always written — the same keys in the same order — so a log or a store
written before this catalogue replays unchanged: :class:`Event` is a validated, immutable view
of one record, and ``Event.from_dict(d).to_dict() == d`` key for key.

The vocabularies that several layers check — an operator's :class:`Profile`, a run's
:class:`Outcome`, how an action ends (:class:`AckStatus`), the :class:`SimulatorName` and the
online graph's events (:class:`GraphEvent`) — are :class:`~enum.StrEnum` s, so a member *is*
its string on disk.

This module sits at the bottom of the layering: it imports only the standard library and
:mod:`flexhrc.errors`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any, Literal

from flexhrc.errors import FlexhrcError


class EventError(FlexhrcError):
    """A record that does not follow its schema, or whose type the catalogue does not know."""


# -- vocabularies ------------------------------------------------------------------------------
class Profile(StrEnum):
    """How a simulated operator behaves (section VI of the paper)."""

    PASSIVE = "passive"
    TAKEOVER = "takeover"
    COOPERATIVE = "cooperative"
    RANDOM = "random"
    #: declines a share of suggestions and cannot do some actions (issue 22)
    RELUCTANT = "reluctant"


class Outcome(StrEnum):
    """How a cooperation ended (the ``outcome`` event, the ``end`` message)."""

    SOLVED = "solved"
    FAILED = "failed"
    INTERRUPTED = "interrupted"


class AckStatus(StrEnum):
    """How an action ended. An agent acknowledges with the first three (:data:`ACK_STATUSES`);
    ``stopped`` is written only by the loop, in an ``action_end`` event, for a command it
    stopped before its agent answered."""

    DONE = "done"
    FAILED = "failed"
    TIMED_OUT = "timed_out"
    STOPPED = "stopped"


class SimulatorName(StrEnum):
    """The simulators a scenario or a command line may name."""

    ANALYTIC = "analytic"
    KINEMATIC = "kinematic"


class FailurePolicy(StrEnum):
    """What a failed or timed-out robot action does to its hyper-arc (``--on-failure``, the
    scenario key ``on_failure``; the first is the default): ``retry`` excludes that grounding
    only, ``paper`` marks the hyper-arc infeasible (paper 000, V-A)."""

    RETRY = "retry"
    PAPER = "paper"


class DecisionPolicy(StrEnum):
    """How the Task Manager picks what to start at a decision (``--policy``, the scenario key
    ``policy``; the first is the default): ``paper`` is the paper's greedy choice (cheapest
    feasible hyper-arc, best branch by eq. 21); ``lookahead`` follows a CP-SAT schedule of the
    remaining task (:mod:`flexhrc.planning`), re-solved at each decision."""

    PAPER = "paper"
    LOOKAHEAD = "lookahead"


class GraphEvent(StrEnum):
    """What the online AND/OR graph is told about an element (``representation.online``)."""

    MET = "met"
    SOLVED = "solved"
    INFEASIBLE = "infeasible"


PROFILES: tuple[str, ...] = tuple(p.value for p in Profile)
OUTCOMES: tuple[str, ...] = tuple(o.value for o in Outcome)
#: What an agent may answer in an ``ack`` message.
ACK_STATUSES: tuple[str, ...] = tuple(s.value for s in AckStatus if s is not AckStatus.STOPPED)
#: How an action may end in an ``action_end`` event.
ACTION_STATUSES: tuple[str, ...] = tuple(s.value for s in AckStatus)
SIMULATORS: tuple[str, ...] = tuple(s.value for s in SimulatorName)
FAILURE_POLICIES: tuple[str, ...] = tuple(p.value for p in FailurePolicy)
DECISION_POLICIES: tuple[str, ...] = tuple(p.value for p in DecisionPolicy)
GRAPH_EVENTS: tuple[str, ...] = tuple(e.value for e in GraphEvent)

# -- type tags -----------------------------------------------------------------------------------
# fmt: off
LogEventType = Literal[
    "start", "query", "decision", "waiting", "infeasible", "suggestion", "command", "ack",
    "ack_ignored", "action_failed", "abort", "stop", "solved", "human_action",
    "human_action_unmatched", "recognised", "action_start", "action_end", "human_told",
    "human_decides", "human_gives_up", "human_sensed", "human_sensing_missed", "outcome",
    "summary", "process_activated", "process_ended", "process_failed", "precondition_failed",
    "fixed", "obsolete", "percept", "inconsistent", "consistent_again", "repair", "repaired",
    "operator_answers", "operator_nudges", "operator_nudge_skipped", "false_report",
    "human_report_ignored", "human_report_unusable", "human_sensing_uncovered",
    # the manager's, the cell's and the panel's own records (not in a cooperation log)
    "agent_available", "agent_unavailable", "taken", "agent_up", "agent_down", "human_take",
    "operator", "intent", "options", "dropped", "refused", "operator_stop", "operator_resume",
    "operator_takes", "human_declined", "human_reply",
]
MessageType = Literal[
    "command", "stop", "ack", "suggestion", "human_action", "percept", "answer", "looked",
    "options", "operator", "intent", "state", "end", "join", "follow", "follow_stop", "reply",
]
StoreKind = Literal[
    "start", "ack", "human_action", "percept", "agent_up", "agent_down", "operator", "intent",
    "human_take", "command", "suggestion", "stop", "options", "decision", "outcome", "abort",
    "action_failed", "infeasible", "recognised", "solved", "human_action_unmatched",
    "ack_ignored", "agent_available", "agent_unavailable", "human_decides", "human_gives_up",
    "fixed", "summary", "begin", "operator_answers", "waiting", "inconsistent",
    "consistent_again", "repaired", "human_reply", "human_declined", "utility",
]
# fmt: on
StoreRole = Literal["input", "output", "record"]


# -- bounds --------------------------------------------------------------------------------------
#: How far a position may lie from the cell's origin, per axis, in metres — a position a
#: message carries, one of a scenario or of a ``behave`` task world. A cell is a table and the
#: arms and people around it, a few metres across; a position beyond this is a broken sensor, a
#: typo or a hostile message, and a finite but absurd one (1e300 m) once made an operator
#: "walk" for 1e299 s so that the cell never ended (probe 2026-12-02, P28/P29/R2P5, B21).
WORKSPACE_M = 10.0
#: The latest time on the cell's clock a message may carry, in seconds. A cooperation lasts
#: minutes to hours; a time past 1e6 s (11.6 days) is a broken clock, and one of 1e300 s became
#: the run's makespan (probe 2026-12-02, P20/P30).
MAX_TIME_S = 1e6
#: How far a pose's quaternion may be from unit length: a rotation is a unit quaternion, and
#: a zero one (probe P23) is no rotation at all; rounding to 5 decimals stays well inside.
QUATERNION_TOLERANCE = 1e-3


def position_problem(p: Any, what: str = "a position") -> str | None:
    """``None`` when ``p`` is ``[x, y, z]``, finite and within :data:`WORKSPACE_M` of the
    origin on every axis, else why not (one line naming ``what``). The one check of a position
    that crosses the cell's boundary: protocol messages, the ROS 2 bridge's poses."""
    if type(p) is list and len(p) == 3:  # the common case, checked cheaply (every message)
        x, y, z = p
        if type(x) is float and type(y) is float and type(z) is float:
            w = WORKSPACE_M  # (NaN fails every comparison: it takes the slow path)
            if -w <= x <= w and -w <= y <= w and -w <= z <= w:
                return None
    if not isinstance(p, list | tuple) or len(p) != 3 or not all(finite_number(x) for x in p):
        return f"{what} must be [x, y, z] finite numbers, got {p!r:.60}"
    if not all(abs(x) <= WORKSPACE_M for x in p):
        return (
            f"{what} [x, y, z] = {list(p)!r:.60} lies outside the workspace "
            f"(|x|, |y|, |z| <= {WORKSPACE_M:g} m)"
        )
    return None


# -- schemas -------------------------------------------------------------------------------------
NUM: tuple[type, ...] = (int, float)
NONE = type(None)
#: A rule over a whole record: ``None`` when it holds, else the problem in one line.
Rule = Callable[[Mapping[str, Any]], "str | None"]


def finite_number(v: Any) -> bool:
    """A JSON number that is a finite float (an int too large for a float is not)."""
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    # an int of 400 digits is valid JSON, and math.isfinite() of it overflows
    return abs(v) <= sys.float_info.max if isinstance(v, int) else math.isfinite(v)


def _names(v: Any) -> bool:
    """A non-empty list of non-empty names."""
    return isinstance(v, list) and bool(v) and all(isinstance(a, str) and a for a in v)


def _strings(v: Any) -> bool:
    """A non-empty list of strings."""
    return isinstance(v, list) and bool(v) and all(isinstance(a, str) for a in v)


@dataclass(frozen=True)
class Field:
    """One field of a schema.

    ``types`` are the JSON types it may hold (``bool`` only when named; a float must be finite);
    ``minimum`` and ``maximum`` bound a number; ``check`` is a further test of the value. When
    ``message`` is given it is the whole problem for a missing or wrong value (``{type}``,
    ``{value!r}`` and the record's ``{t}`` are filled in), else the protocol's generic wording.
    """

    types: tuple[type, ...]
    required: bool = False
    minimum: float | None = None
    check: Callable[[Any], bool] | None = None
    message: str | None = None
    doc: str = ""
    maximum: float | None = None

    def problem(self, kind: str, name: str, data: Mapping[str, Any]) -> str | None:
        if name not in data:
            if not self.required:
                return None
            return self._say(kind, None, data) or f"{kind}: missing field {name!r}"
        value = data[name]
        if (isinstance(value, bool) and bool not in self.types) or not isinstance(
            value, self.types
        ):
            want = " or ".join("null" if t is NONE else t.__name__ for t in self.types)
            return (
                self._say(kind, value, data)
                or f"{kind}: field {name!r} must be {want}, not {value!r:.40}"
            )
        if isinstance(value, int | float) and not isinstance(value, bool):  # a number
            if not finite_number(value):
                return self._say(kind, value, data) or f"{kind}: field {name!r} must be finite"
            if self.minimum is not None and value < self.minimum:
                return (
                    self._say(kind, value, data)
                    or f"{kind}: field {name!r} must be >= 0, not {value!r:.40}"
                )
            if self.maximum is not None and value > self.maximum:
                return f"{kind}: field {name!r} must be <= {self.maximum:g}, not {value!r:.40}"
        if self.check is not None and not self.check(value):
            return self._say(kind, value, data) or f"{kind}: field {name!r} is not valid"
        return None

    def _say(self, kind: str, value: Any, data: Mapping[str, Any]) -> str | None:
        if self.message is None:
            return None
        return self.message.format(type=kind, value=value, t=data.get("t"))

    def describe(self) -> str:
        names = ["null" if t is NONE else t.__name__ for t in self.types]
        if "float" in names:  # a JSON number
            names = ["number" if n == "float" else n for n in names if n != "int"]
        bound = " >= 0" if self.minimum is not None else ""
        if self.maximum is not None:  # 1e+06 as 1e6
            bound = f" in [0, {f'{self.maximum:g}'.replace('e+0', 'e').replace('e+', 'e')}]"
        want = " or ".join(names) + bound
        return want if self.required else f"({want})?" if " " in want else f"{want}?"


@dataclass(frozen=True)
class EventSchema:
    """The schema of one type of record (see the module docstring).

    ``replay``: ``flexhrc replay`` accepts it in a log; ``trace``: the trace of ``run``/``demo``
    prints it; ``stored``: a Task Manager record that the cell keeps in its store.
    """

    type: str
    doc: str
    fields: Mapping[str, Field] = field(default_factory=dict)
    rules: tuple[Rule, ...] = ()
    replay: bool = False
    trace: bool = False
    stored: bool = False

    def problem(self, data: Mapping[str, Any]) -> str | None:
        """The first way ``data`` breaks this schema, in one line, or ``None``."""
        for name, f in self.fields.items():
            said = f.problem(self.type, name, data)
            if said is not None:
                return said
        for rule in self.rules:
            said = rule(data)
            if said is not None:
                return said
        return None

    def check(self, data: Mapping[str, Any]) -> None:
        """Raise :class:`EventError` if ``data`` breaks this schema."""
        said = self.problem(data)
        if said is not None:
            raise EventError(said)


@dataclass(frozen=True)
class StoreKindSpec:
    """A ``kind`` of the cell's store and its role: an ``input`` of the Task Manager (replayed
    into a fresh one on resume), an ``output`` it sent, or a ``record`` kept for replay."""

    kind: str
    role: StoreRole
    doc: str


# -- log events ------------------------------------------------------------------------------
T = Field(NUM, True, 0, message="{type}: 't' must be a finite time >= 0, got {value!r:.40}")
S = (str,)
OPT_S = (str, NONE)
NAME = Field(S)
OPT_NAME = Field(OPT_S)
AGENTS = Field(
    (list,), True, check=_names, message="{type}: 'agents' must be a list of agent names"
)


def _log(
    kind: LogEventType,
    doc: str,
    flags: str = "replay",
    rules: tuple[Rule, ...] = (),
    **fields: Field,
) -> EventSchema:
    """A log event; ``flags`` are the words ``replay``, ``trace`` and ``store``."""
    on = set(flags.split())
    return EventSchema(
        kind,
        doc,
        MappingProxyType({"t": T, **fields}),
        rules,
        replay="replay" in on,
        trace="trace" in on,
        stored="store" in on,
    )


def _decision_chosen(ev: Mapping[str, Any]) -> str | None:
    chosen, branches = ev.get("chosen"), ev["branches"]
    if chosen is not None and (
        isinstance(chosen, bool) or not isinstance(chosen, int) or not 0 <= chosen < len(branches)
    ):
        return f"decision: 'chosen' is not one of its {len(branches)} branches"
    return None


def _summary_timing(ev: Mapping[str, Any]) -> str | None:
    for key, v in ev["timing"].items():
        if not finite_number(v) or v < 0:
            return f"summary: timing {key!r} must be a finite time >= 0"
    return None


_START = "action_end: 'start' must be a finite time between 0 and t = {t}, got {value!r}"


def _action_end_start(ev: Mapping[str, Any]) -> str | None:
    if not ev["start"] <= ev["t"] + 1e-9:
        return _START.format(t=ev["t"], value=ev["start"])
    return None


def _action(kind: str) -> Field:
    return Field(S, True, check=bool, message=f"{kind}: 'action' must be a string")


def _one_of(kind: str, key: str, values: tuple[str, ...], *, required: bool = True) -> Field:
    said = f"{kind}: {key!r} must be one of {', '.join(values)}, got {{value!r}}"
    return Field(S, required, check=lambda v: v in values, message=said)


# fmt: off
_LOG_SCHEMAS = [
    _log("start", "a run begins", agents=AGENTS,
         humans=Field((list,), check=lambda v: all(isinstance(a, str) and a for a in v),
                      message="start: 'humans' must be a list of agent names"),
         simulator=OPT_NAME,
         on_failure=_one_of("start", "on_failure", FAILURE_POLICIES, required=False),
         policy=_one_of("start", "policy", DECISION_POLICIES, required=False),
         profile=Field(S, True, message="start: 'profile' must be a string")),
    _log("query", "the Task Manager asked the representation", report=Field((dict,))),
    _log("decision", "a hyper-arc's branches simulated, one chosen", "replay trace store",
         (_decision_chosen,), element=NAME, cost=Field((*NUM, NONE)),
         branches=Field((list,), True, check=lambda v: all(isinstance(b, dict) for b in v),
                        message="decision: 'branches' must be a list of branches")),
    _log("waiting", "nothing can be decided now", "replay trace store", reason=OPT_NAME),
    _log("infeasible", "a hyper-arc can never be done", "replay trace store",
         element=NAME, reason=OPT_NAME),
    _log("suggestion", "a person is asked to do a step", "replay trace",
         element=NAME, actions=Field((list,))),
    _log("command", "a robot command is sent", "replay trace",
         id=Field((int,), True, message="command: 'id' must be a whole number"),
         action=NAME, element=OPT_NAME),
    _log("ack", "an agent acknowledged a command", status=NAME, reason=OPT_NAME),
    _log("ack_ignored", "an acknowledgement of no running command", "replay store"),
    _log("action_failed", "an action failed: its hyper-arc is retried or given up",
         "replay trace store", element=NAME, reason=OPT_NAME),
    _log("abort", "a running hyper-arc is abandoned", "replay trace store",
         element=NAME, reason=OPT_NAME),
    _log("stop", "an agent is told to stop a command", "replay trace", reason=OPT_NAME),
    _log("solved", "a hyper-arc is done", "replay store",
         agents=Field((list,), check=lambda v: all(isinstance(a, str) and a for a in v),
                      message="solved: 'agents' must be a list of agent names"),
         element=Field(S, True, message="solved: 'element' must be a hyper-arc name")),
    _log("human_action", "a person's action reached the Task Manager", action=NAME),
    _log("human_action_unmatched", "a person's action that no hyper-arc expects",
         "replay trace store", action=NAME),
    _log("recognised", "a person's action recognised as a step of a hyper-arc",
         "replay trace store", action=NAME, element=NAME),
    _log("action_start", "an action begins", agents=AGENTS, action=_action("action_start"),
         command=Field((int, NONE)), element=OPT_NAME),
    _log("action_end", "an action ends", "replay", (_action_end_start,), agents=AGENTS,
         action=_action("action_end"), command=Field((int, NONE)), element=OPT_NAME,
         status=_one_of("action_end", "status", ACTION_STATUSES),
         start=Field(NUM, True, 0, message=_START, doc="when it began, <= t")),
    _log("human_told", "a suggestion shown to a person"),
    _log("human_decides", "a person decided what to do", "replay trace store",
         agent=NAME, element=NAME),
    _log("human_gives_up", "a person leaves a step", "replay trace store", agent=NAME),
    _log("human_sensed", "a person's action was sensed", "replay trace"),
    _log("human_sensing_missed", "a person's action went unsensed", "replay trace"),
    _log("outcome", "how the run ended", "replay trace store",
         outcome=_one_of("outcome", "outcome", OUTCOMES),
         reason=Field(OPT_S, message="outcome: 'reason' must be a string or null")),
    _log("summary", "the run's figures (Table I), last", "replay", (_summary_timing,),
         timing=Field((dict,), True, message="summary: 'timing' must be a mapping of times")),
    _log("process_activated", "a node's processes start (section V)", "replay trace"),
    _log("process_ended", "a process ended", "replay trace"),
    _log("process_failed", "a process failed"),
    _log("precondition_failed", "an action's precondition is false at dispatch", "replay trace"),
    _log("fixed", "an object is fixed in place by an action", object=NAME, agents=AGENTS),
    _log("obsolete", "an action's effect is already true: the step is skipped"),
    _log("percept", "the perceived scene changed (or a stored percept message)"),
    _log("inconsistent", "the knowledge base disagrees with a percept", "replay trace store"),
    _log("consistent_again", "the knowledge base agrees again", "replay trace store"),
    _log("repair", "a repair of the knowledge base begins", "replay trace"),
    _log("repaired", "the knowledge base is repaired", "replay trace store"),
    _log("operator_answers", "the operator answered a question", "replay trace"),
    _log("operator_nudges", "the operator is nudged", "replay trace"),
    _log("operator_nudge_skipped", "a nudge was not needed"),
    _log("false_report", "a person's report contradicts the scene", "replay trace"),
    _log("human_report_ignored", "a person's report was ignored"),
    _log("human_report_unusable", "a person's report could not be used"),
    _log("human_sensing_uncovered", "no sensing covers a person's action"),
    # the manager's, the cell's and the panel's own records: `flexhrc replay` refuses them
    _log("agent_available", "the manager may plan with an agent again", "store", agent=NAME),
    _log("agent_unavailable", "the manager may no longer plan with an agent", "store",
         agent=NAME),
    _log("taken", "the operator took a hyper-arc on its own (manager)", "", element=NAME),
    _log("agent_up", "an agent's liveliness token appeared (cell)", ""),
    _log("agent_down", "an agent's liveliness token vanished (cell)", ""),
    _log("human_take", "the operator takes a hyper-arc (cell)", ""),
    _log("operator", "an operator announced its profile (cell)", ""),
    _log("intent", "an operator's answer to its options (cell)", ""),
    _log("options", "what an operator may do on its own (cell)", ""),
    _log("dropped", "a malformed message was dropped (cell trace)", ""),
    _log("refused", "an agent's process of another scenario was refused (cell trace)", "",
         agent=NAME, reason=NAME),
    _log("operator_stop", "the panel's operator stopped an arm", ""),
    _log("operator_resume", "the panel's operator resumed an arm", ""),
    _log("operator_takes", "the panel's operator takes a hyper-arc", ""),
    _log("human_declined", "a person said not now, can't, gave a step back or did not answer",
         "replay trace store", agent=NAME, element=NAME,
         reply=_one_of("human_declined", "reply", ("decline", "cannot", "give_back"))),
    # in the cooperation log too (the person's answers, read by `flexhrc learn`): replayable
    _log("human_reply", "a person's answer to a request (cell input)", "replay"),
]
# fmt: on
#: Every log event type, by its tag.
LOG_EVENTS: Mapping[str, EventSchema] = MappingProxyType({s.type: s for s in _LOG_SCHEMAS})
#: The types ``flexhrc replay`` accepts in a cooperation log.
REPLAY_TYPES = frozenset(t for t, s in LOG_EVENTS.items() if s.replay)
#: The types the trace of ``run``/``demo`` prints.
TRACE_TYPES = frozenset(t for t, s in LOG_EVENTS.items() if s.trace)
#: The Task Manager's records the cell keeps in its store.
STORED_LOG_TYPES = frozenset(t for t, s in LOG_EVENTS.items() if s.stored)


# -- protocol messages -------------------------------------------------------------------------
def _nonneg(types: tuple[type, ...], required: bool = False, doc: str = "") -> Field:
    return Field(types, required, minimum=0, doc=doc)


def _listed(kind: str, key: str) -> Rule:
    def rule(m: Mapping[str, Any]) -> str | None:
        if not _strings(m[key]):
            return f"{kind}: {key!r} must be a non-empty list of strings"
        return None

    return rule


def _ack_status(m: Mapping[str, Any]) -> str | None:
    if m["status"] not in ACK_STATUSES:
        return f"ack: status must be one of {', '.join(ACK_STATUSES)}"
    return None


def _position_problem(kind: str, positions: Mapping[Any, Any], what: str) -> str | None:
    """The first of ``positions`` (object -> ``[x, y, z]``) that is not a position, said."""
    for obj, p in positions.items():
        if position_problem(p) is not None:  # (the name is formatted only then)
            return f"{kind}: {position_problem(p, f'{what} of {obj!r}')}"
    return None


def _positions(kind: str) -> Rule:
    def rule(m: Mapping[str, Any]) -> str | None:
        return _position_problem(kind, m.get("positions", {}), "position")

    return rule


def _all_facts(facts: list[Any]) -> bool:
    """Every item is a non-empty list of non-empty strings (loops, not generators: every
    command's world has tens)."""
    for f in facts:
        if type(f) is not list or not f:
            return False
        for x in f:
            if type(x) is not str or not x:
                return False
    return True


def _world(kind: str) -> Rule:
    """``world``: ``positions`` (object -> ``[x, y, z]`` in the workspace) and ``facts`` (lists
    of names): what an agent acts in, so a value it cannot use never reaches it (P32, P33)."""

    def rule(m: Mapping[str, Any]) -> str | None:
        world = m.get("world")
        if world is None:
            return None
        positions = world.get("positions", {})
        if not isinstance(positions, dict):
            return f"{kind}: world 'positions' must be an object of [x, y, z] positions"
        said = _position_problem(kind, positions, "world position")
        if said is not None:
            return said
        facts = world.get("facts", [])
        if not isinstance(facts, list) or not _all_facts(facts):
            return f"{kind}: world 'facts' must be a list of facts, each a list of names"
        return None

    return rule


def _joints(kind: str) -> Rule:
    def rule(m: Mapping[str, Any]) -> str | None:
        for arm, q in m.get("joints", {}).items():
            if not isinstance(q, list) or not q or not all(finite_number(x) for x in q):
                return f"{kind}: joints of {arm!r} must be a list of finite numbers"
        return None

    return rule


def _intent(m: Mapping[str, Any]) -> str | None:
    if not all(isinstance(x, str) for x in m["decided"]):
        return "intent: 'decided' must be a list of step names"
    if m["act"]:
        for key in ("step", "hyperarc", "actions"):
            if key not in m:
                return f"intent: an intent to act needs {key!r}"
        if not _strings(m["actions"]):
            return "intent: 'actions' must be a non-empty list of strings"
    return None


def _options_steps(m: Mapping[str, Any]) -> str | None:
    def arc_ok(a: Any) -> bool:
        return (
            isinstance(a, dict)
            and isinstance(a.get("hyperarc"), str)
            and isinstance(a.get("cost"), NUM)
            and isinstance(a.get("branches"), list)
            and all(_strings(b) for b in a["branches"])
        )

    for st in m["steps"]:
        if not (
            isinstance(st, dict)
            and isinstance(st.get("step"), str)
            and isinstance(st.get("arcs"), list)
            and all(arc_ok(a) for a in st["arcs"])
        ):
            return "options: each step must be {step, arcs: [{hyperarc, cost, branches}]}"
    return None


def _percept_shape(m: Mapping[str, Any]) -> str | None:
    pose = m["pose"]
    if len(pose) not in (3, 7) or not all(finite_number(x) for x in pose):
        return "percept: 'pose' must be [x, y, z] (+ a quaternion), finite"
    said = position_problem(pose[:3], "'pose' position")
    if said is not None:
        return f"percept: {said}"
    if len(pose) == 7 and abs(math.hypot(*pose[3:]) - 1.0) > QUATERNION_TOLERANCE:
        return f"percept: 'pose' quaternion {pose[3:]} is not a rotation (not of unit length)"
    size = m.get("size")
    values = list(size.values()) if isinstance(size, dict) else (size or [])
    if not all(finite_number(x) and 0 <= x <= 2 * WORKSPACE_M for x in values):
        return f"percept: 'size' values must be finite numbers from 0 to {2 * WORKSPACE_M:g} m"
    return None


def _starts_before_it_ends(m: Mapping[str, Any]) -> str | None:
    if "start" in m and m["start"] > m["t"] + 1e-9:
        return f"human_action: 'start' {m['start']} is after its end t = {m['t']}"
    return None


def _yes_no(m: Mapping[str, Any]) -> str | None:
    return None if m["answer"] in ("yes", "no") else "answer: 'answer' must be 'yes' or 'no'"


#: What a person may answer beyond "done" (the ``reply`` message).
REPLIES: tuple[str, ...] = ("decline", "cannot", "start", "give_back")


def _reply_names(m: Mapping[str, Any]) -> str | None:
    if m["reply"] not in REPLIES:
        return f"reply: 'reply' must be one of {', '.join(REPLIES)}, got {m['reply']!r}"
    return None


def _msg(kind: MessageType, doc: str, rules: tuple[Rule, ...] = (), **fields: Field) -> EventSchema:
    return EventSchema(kind, doc, MappingProxyType(fields), rules)


def _time(required: bool = False, doc: str = "") -> Field:
    """A time (or a duration) on the cell's clock: finite, >= 0, at most :data:`MAX_TIME_S`."""
    return Field(NUM, required, minimum=0, maximum=MAX_TIME_S, doc=doc)


ID, INT_ID, TIME, OPT_TIME = Field(S, True), Field((int,), True), _time(True), _time()
# run identity (flexhrc.cell.identity): optional, so a message of an older peer is legacy
RUN = Field(S, check=bool, doc="the run it belongs to (from `start`; absent: legacy)")
FINGERPRINT = Field(S, check=bool, doc="the sender's scenario fingerprint")
# the one agent process the manager granted the agent's name (its Zenoh session id): any other
# process of that name leaves the message alone (probe K09)
SESSION = Field(S, check=bool, doc="the Zenoh session of the agent process it is for")
# fmt: off
_MESSAGE_SCHEMAS = [
    _msg("command", "manager → `cmd/<agent>`: do this action",
         (_listed("command", "agents"), _joints("command"), _world("command")),
         id=INT_ID, agents=Field((list,), True), action=Field(S, True), element=OPT_NAME,
         t=TIME, expected_s=OPT_TIME, world=Field((dict,)), realtime=OPT_TIME,
         process=Field((bool,)),
         joints=Field((dict,), doc="where the manager's robot model has the command's arms "
                      "(rad, {arm: [q]}); the agent starts from there"),
         run=RUN, fingerprint=FINGERPRINT, session=SESSION),
    _msg("stop", "manager → `cmd/<agent>`: stop that command",
         id=INT_ID, reason=OPT_NAME, t=OPT_TIME, run=RUN, session=SESSION),
    _msg("ack", "robot → `ack`: how a command ended",
         (_ack_status, _positions("ack"), _joints("ack")),
         id=INT_ID, agent=Field(S, True), status=Field(S, True), reason=OPT_NAME, t=TIME,
         duration=OPT_TIME, positions=Field((dict,)),
         joints=Field((dict,), doc="where the command left the arms it moved (rad, "
                      "{arm: [q]}); the manager's robot model takes them"),
         run=RUN),
    _msg("suggestion", "manager → `suggest/<human>`: please do this step",
         (_listed("suggestion", "actions"), _world("suggestion")),
         id=ID, element=Field(S, True), actions=Field((list,), True), cost=Field(NUM), t=TIME,
         world=Field((dict,)), realtime=OPT_TIME, step=_nonneg((int,)),
         own=Field((bool,), doc="the operator's own plan (its intent), not the manager's ask"),
         run=RUN, fingerprint=FINGERPRINT, session=SESSION),
    _msg("human_action", "human → `human`: a person did this",
         (_positions("human_action"), _starts_before_it_ends),
         id=ID, agent=Field(S, True), action=Field(S, True), suggestion=OPT_NAME,
         step=_nonneg((int,)), start=OPT_TIME, t=TIME, positions=Field((dict,)),
         recognised=Field((bool,), doc="false: a wearable sensor missed it (the manager is "
                          "not told)"),
         sensed=Field((dict,), doc="the wearable sensor's figures"), run=RUN),
    _msg("percept", "perception → `percept`: an object seen", (_percept_shape,),
         id=ID, object=Field(S, True), object_type=Field(S, True), pose=Field((list,), True),
         size=Field((dict, list, NONE)), t=OPT_TIME,
         why=Field(S, doc="what the look followed"),
         moved=Field((bool,), doc="re-anchored away from the belief"),
         contradicts=Field(OPT_S, doc="the reported belief it contradicts, and why")),
    # the operator's answer to a repair question about a report (human_action id)
    _msg("answer", "human → `human`: did you do what was reported?", (_yes_no,),
         id=ID, agent=Field(S, True), report=Field(S, True), object=Field(S, True),
         question=Field(S, True), answer=Field(S, True), t=TIME, run=RUN),
    # a perception agent the ordered loop waits for: it looked at the state numbered ``upto``
    _msg("looked", "perception → `percept`: a watcher has looked",
         agent=Field(S, True), upto=_nonneg((int,), True), t=TIME,
         at=_time(doc="when it looks again by itself")),
    # an operator that acts on its own: what it may do (steps -> hyper-arcs -> ground branches)
    _msg("options", "manager → `options/<human>`: what the operator may do on its own",
         (_options_steps, _world("options")), id=ID, t=TIME, steps=Field((list,), True),
         world=Field((dict,)), run=RUN, fingerprint=FINGERPRINT, session=SESSION),
    # ``scripted``: it takes exactly the steps it was told to (a test or demo script), whatever
    # its profile says, so it is offered ``options`` even when ``passive``
    _msg("operator", "human → `intent`: its profile",
         agent=Field(S, True), profile=Field(S, True), scripted=Field((bool,))),
    _msg("intent", "human → `intent`: its answer to options", (_intent,),
         id=ID, agent=Field(S, True), options=Field(S, True), act=Field((bool,), True),
         decided=Field((list,), True), t=TIME, step=NAME, hyperarc=NAME,
         actions=Field((list,)), delay=OPT_TIME, run=RUN),
    _msg("state", "manager → `state`: the cell snapshot"),
    _msg("end", "manager → `state`: the cooperation ended", outcome=Field(S, True), run=RUN),
    # an agent joins: the manager refuses one of another scenario (and answers it with a ``state``
    # with the cell's ``fingerprint``, which the agent compares with its own)
    _msg("join", "agent → `join`: who it is and its scenario's fingerprint",
         agent=Field(S, True), role=Field(S, True, doc="robot or human"),
         scenario=Field(S, True),
         fingerprint=Field(S, True, check=bool)),
    # between the arm nodes of one robot over ROS 2 (docs/ros2.md): a joint command reaches its
    # first arm only, which sends each other arm its part of the motion
    _msg("follow", "leading arm → `arm/<arm>/follow`: this arm's part of a joint command",
         id=INT_ID, leader=Field(S, True),
         times=Field((list,), True, doc="seconds from the command's start, increasing"),
         joints=Field((list,), True, doc="one row of joint positions (rad) per time"),
         realtime=OPT_TIME),
    _msg("follow_stop", "an arm → `arm/<arm>/follow`: stop your part of that joint command, "
         "or the joint command you lead", id=INT_ID, by=OPT_NAME),
    # an operator's answer to a request beyond "done" (docs/protocol.md, "Operator answers")
    _msg("reply", "human → `human`: not now, I can't, I'm starting, I give it back",
         (_reply_names,), id=ID, agent=Field(S, True),
         reply=Field(S, True, doc="decline, cannot, start or give_back"),
         suggestion=OPT_NAME, step=_nonneg((int,)), element=OPT_NAME, action=OPT_NAME,
         reason=OPT_NAME, t=TIME, run=RUN),
]
# fmt: on
#: Every protocol message type, by its tag.
MESSAGES: Mapping[str, EventSchema] = MappingProxyType({s.type: s for s in _MESSAGE_SCHEMAS})


# -- store kinds ---------------------------------------------------------------------------------
#: The Task Manager's inputs (replayed into a fresh one on resume), by kind.
_INPUTS = {
    "start": "the run begins (run id, agents, humans, scenario, its fingerprint, seed, realtime, "
    "the --operators model as `operator_model`, ...); every row carries the run id as `run`",
    "ack": "an ack message",
    "human_action": "a human_action message",
    "percept": "a percept message",
    "agent_up": "an agent came up (or was resumed)",
    "agent_down": "an agent went down (or was stopped)",
    "operator": "an operator message",
    "intent": "an intent message",
    "human_take": "the operator takes a hyper-arc",
    "begin": "the watchers have looked: the first decision",
    "operator_answers": "an answer message (a repair question)",
    "human_reply": "a reply message (decline, cannot, start, give_back) "
    "or an unanswered suggestion's timeout (`why: timeout`)",
    "utility": "a what-if's new branch utility from this event on (`flexhrc replay --fork-at K "
    "--utility FILE`): `utility`, the block as the scenario key `utility:` takes it",
}
#: What the Task Manager sent, by kind.
_OUTPUTS = {
    "command": "a command message sent",
    "suggestion": "a suggestion message sent",
    "stop": "a stop message sent",
    "options": "an options message sent",
}
_STORE_SPECS = [
    *(StoreKindSpec(kind, "input", doc) for kind, doc in _INPUTS.items()),
    *(StoreKindSpec(kind, "output", doc) for kind, doc in _OUTPUTS.items()),
    *(
        StoreKindSpec(kind, "record", LOG_EVENTS[kind].doc)
        for kind in [*sorted(STORED_LOG_TYPES), "fixed", "summary"]
    ),
]
#: Every kind of the cell's store, by name.
STORE_KINDS: Mapping[str, StoreKindSpec] = MappingProxyType({s.kind: s for s in _STORE_SPECS})
INPUT_KINDS = frozenset(k for k, s in STORE_KINDS.items() if s.role == "input")
OUTPUT_KINDS = frozenset(k for k, s in STORE_KINDS.items() if s.role == "output")
RECORD_KINDS = frozenset(k for k, s in STORE_KINDS.items() if s.role == "record")


# -- records -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Event:
    """One validated record: its ``type`` tag and its fields, in the order they were written
    (``type`` included), so that ``to_dict`` gives back the same JSON."""

    type: str
    data: Mapping[str, Any]

    @classmethod
    def from_dict(
        cls, data: Mapping[str, Any], catalogue: Mapping[str, EventSchema] | None = None
    ) -> Event:
        """Check ``data`` against its schema in ``catalogue`` (the log events unless given);
        raises :class:`EventError` naming an unknown type or the first broken field."""
        checked = _checked(data, catalogue)
        return cls(str(checked["type"]), MappingProxyType(dict(checked)))

    def to_dict(self) -> dict[str, Any]:
        return dict(self.data)

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    def get(self, key: str, default: Any = None) -> Any:
        return self.data.get(key, default)


def schema_of(kind: Any, catalogue: Mapping[str, EventSchema] | None = None) -> EventSchema:
    """The schema of ``kind``; :class:`EventError` for a type the catalogue does not know."""
    cat = LOG_EVENTS if catalogue is None else catalogue
    if not isinstance(kind, str) or kind not in cat:
        what = "message" if cat is MESSAGES else "event"
        raise EventError(
            f"unknown {what} type {kind!r}: not in the catalogue of flexhrc.events "
            "(docs/protocol.md)"
        )
    return cat[kind]


def _checked(
    data: Mapping[str, Any], catalogue: Mapping[str, EventSchema] | None
) -> Mapping[str, Any]:
    if not isinstance(data, Mapping):
        raise EventError(f"a record must be a JSON object, not {type(data).__name__}")
    schema_of(data.get("type"), catalogue).check(data)
    return data


def catalogue_markdown() -> str:
    """The tables of ``docs/protocol.md`` ("The catalogue"), written from the schemas."""

    def fields(s: EventSchema) -> str:
        shown = [f"`{n}` {f.describe()}" for n, f in s.fields.items() if f is not T]
        return ", ".join(shown) or "—"

    def rows(schemas: Iterable[EventSchema], flags: bool) -> list[str]:
        out = []
        for s in schemas:
            if flags:
                marks = " ".join(
                    m
                    for m, on in (("replay", s.replay), ("trace", s.trace), ("store", s.stored))
                    if on
                )
                out.append(f"| `{s.type}` | {s.doc} | {fields(s)} | {marks or '—'} |")
            else:
                out.append(f"| `{s.type}` | {s.doc} | {fields(s)} |")
        return out

    lines = [
        'Protocol messages (every one also carries `"v": 1` and `"type"`; `?` marks an '
        "optional field):",
        "",
        "| type | from → topic: what | fields |",
        "|---|---|---|",
        *rows(MESSAGES.values(), False),
        "",
        'Log events (every one also carries `"t"`, a finite time >= 0, and `"type"`; a field '
        "not listed is kept but not checked; *replay*: `flexhrc replay` accepts it, *trace*: the "
        "trace of `run`/`demo` prints it, *store*: a Task Manager record the cell stores):",
        "",
        "| type | what | checked fields | in |",
        "|---|---|---|---|",
        *rows(LOG_EVENTS.values(), True),
        "",
        "Store kinds (the `kind` column of the cell's store):",
        "",
        "| kind | role | what |",
        "|---|---|---|",
        *(f"| `{s.kind}` | {s.role} | {s.doc} |" for s in STORE_KINDS.values()),
        "",
        "Vocabularies: "
        + "; ".join(
            f"`{e.__name__}` {', '.join(f'`{m.value}`' for m in e)}"
            for e in (Profile, Outcome, AckStatus, SimulatorName, GraphEvent)
        )
        + ".",
    ]
    return "\n".join(lines) + "\n"


__all__ = [
    "ACK_STATUSES",
    "ACTION_STATUSES",
    "GRAPH_EVENTS",
    "INPUT_KINDS",
    "LOG_EVENTS",
    "MAX_TIME_S",
    "MESSAGES",
    "OUTCOMES",
    "OUTPUT_KINDS",
    "PROFILES",
    "QUATERNION_TOLERANCE",
    "RECORD_KINDS",
    "REPLAY_TYPES",
    "SIMULATORS",
    "STORED_LOG_TYPES",
    "STORE_KINDS",
    "TRACE_TYPES",
    "WORKSPACE_M",
    "AckStatus",
    "Event",
    "EventError",
    "EventSchema",
    "Field",
    "GraphEvent",
    "LogEventType",
    "MessageType",
    "Outcome",
    "Profile",
    "SimulatorName",
    "StoreKind",
    "StoreKindSpec",
    "catalogue_markdown",
    "position_problem",
    "schema_of",
]
