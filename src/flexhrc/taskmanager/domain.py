"""Agents and action schemas (paper 000, eq. 20).

An action schema ``a = <param(a), pre(a), eff+(a), eff-(a)>`` has typed parameters,
precondition literals and add/delete effects, plus ``agents(a)``: who may perform it —

* ``single``: one named agent (``agents: human``);
* ``choice``: one of several agents; the choice is the value of an agent parameter
  (``agents: {choice: ?arm}``, ``?arm`` typed ``arm``) so every action of one hyper-arc that
  uses ``?arm`` is done by the same arm;
* ``joint``: several agents at once (``agents: {joint: [left, right]}``).

Hyper-arcs list their actions as invocations such as ``transport(?arm, ?leg, bolt_2)``; the
arguments bind the schema's parameters in order. A domain is loaded from YAML::

    agents:
      human: {kind: human, types: [human]}
      left:  {kind: robot, types: [arm], base: [0.0, 0.25, 0.0]}
    actions:
      grasp:
        parameters: {?arm: arm, ?obj: leg}
        agents: {choice: ?arm}
        pre: [on_table(?obj)]
        add: [holding(?arm, ?obj)]
        delete: [on_table(?obj)]
        kind: grasp              # optional: its action kind (default: the action's name)
        duration: 1.0            # optional: seconds (the analytic simulator's nominal time)
        moves_to: ?obj           # optional: the hand goes to this parameter's object/place
        target: ?obj             # optional: what the kind's motion aims at ([?obj, ?to])
    processes:                   # node processes P(n) (eq. 5), named in a node's processes
      hold:
        parameters: {?top: tabletop}
        agents: {joint: [left, right]}
        kind: hold               # its behaviour: the controller keeps the held pose
        priority: 1              # which process wins an arm (the larger; default 0)
        duration: 2.0            # the analytic model's time of one round
        add: [settled(?top)]     # what a round establishes (the behaviour's own condition)
        until: [settled(?top)]   # end condition: the process ends when it holds

``kind`` names what the action is physically (:mod:`flexhrc.taskmanager.kinds`: its motion on
the robot model, its timing, its effect on the world); an unregistered explicit kind is an
error. ``duration`` and ``moves_to`` let a simulator time an action without knowing the scenario;
``human_only``/``robot_only`` are not needed: who may act is ``agents``. A process is a
behaviour with a priority kept up while its node is reached (paper eq. 5): its ``kind`` says what
it does (``hold``: both hands keep the held object at its pose with the task-priority controller,
undoing a push, :mod:`flexhrc.action.simulator`), ``priority`` (a whole number, default 0) which
of two processes wants an arm more, ``until`` its end condition. It runs in rounds — each ends
when its behaviour's own condition holds (the object back at its pose and still), and its
``add`` effects are then applied — until ``until`` holds in the knowledge base, whoever made it
true (checked after each round and whenever the state changes), then the node is met. Its
``agents`` may name a person where the domain allows it (``agents: human``, or a choice whose
type admits people): robots are preferred, as the paper has it ("processes are meant at being
executed by robots, whereas a human operator may carry them out occasionally").
"""

from __future__ import annotations

import difflib
import functools
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.logic import (
    Conjunction,
    apply_substitution,
    is_variable,
    parse_conjunction,
    parse_literal,
)
from flexhrc.logic import Literal as Lit

AgentMode = Literal["single", "choice", "joint"]


def _no_kind_check(kind: str) -> str | None:
    return None


#: Why an action kind named in a domain is unknown (None: it is known). The registry of
#: :mod:`flexhrc.taskmanager.kinds` installs its check when it is imported (the package does),
#: so the domain names kinds without depending on the module that defines them.
_kind_check: Callable[[str], str | None] = _no_kind_check


def set_kind_check(check: Callable[[str], str | None]) -> None:
    """Install the check of action-kind names (:func:`flexhrc.taskmanager.kinds.unknown_kind`)."""
    global _kind_check
    _kind_check = check


@dataclass(frozen=True)
class Agent:
    """A human operator or a robot arm. ``types`` are the KB types it counts as (e.g. arm)."""

    name: str
    kind: Literal["human", "robot"]
    types: tuple[str, ...] = ()
    params: Mapping[str, Any] = field(default_factory=dict)

    @property
    def is_human(self) -> bool:
        return self.kind == "human"


@dataclass(frozen=True)
class AgentSpec:
    mode: AgentMode
    names: tuple[str, ...] = ()  # single / joint
    variable: str | None = None  # choice


@dataclass(frozen=True)
class ActionSchema:
    name: str
    parameters: tuple[tuple[str, str], ...]  # (variable, type), in order
    agents: AgentSpec
    pre: Conjunction = ()
    add: Conjunction = ()
    delete: Conjunction = ()
    kind: str = ""  # its action kind (flexhrc.taskmanager.kinds): approach, grasp, transport, ...
    duration: float | None = None  # nominal seconds (None: the simulator's own model)
    moves_to: str | None = None  # parameter whose object/place the hand goes to
    until: Conjunction = ()  # processes only: the end condition
    carries: str | None = None  # parameter whose object travels with the hand
    fixes: str | None = None  # parameter whose object is fixed in place afterwards
    undo: str | None = None  # the action that puts things back (an operator changing its mind)
    line: int | None = field(default=None, compare=False)
    target: tuple[str, ...] = ()  # parameters the kind's motion aims at (object, place)
    priority: int = 0  # processes only: the larger wins an arm wanted by two processes
    text: str | None = None  # plain words for the person, "Screw {?leg} to {?bolt}" (words.py)

    @functools.cached_property
    def variables(self) -> tuple[str, ...]:  # read in every grounding: made once
        return tuple(v for v, _ in self.parameters)

    def grounded(self, args: tuple[str, ...]) -> GroundedSchema:
        """pre(a), eff+(a) and eff-(a) under the arguments ``args`` (in parameter order).

        Every decision grounds the same few actions again for each branch it checks
        (eq. 20), so each argument tuple is grounded once and kept."""
        cache = self._groundings
        g = cache.get(args)
        if g is None:
            if len(cache) >= _GROUNDINGS_KEPT:  # objects perceived over a long run: stay bounded
                cache.clear()
            binding = dict(zip(self.variables, args, strict=True))
            pre = tuple(apply_substitution(lit, binding) for lit in self.pre)
            g = cache[args] = GroundedSchema(
                pre=pre,
                pre_ground=tuple((lit, lit.key(), lit.negated) for lit in pre if lit.is_ground),
                pre_open=tuple(lit for lit in pre if not lit.is_ground),
                add=tuple(apply_substitution(lit, binding).key() for lit in self.add),
                delete=tuple(apply_substitution(lit, binding).key() for lit in self.delete),
            )
        return g

    @functools.cached_property
    def _groundings(self) -> dict[tuple[str, ...], GroundedSchema]:
        return {}


#: How many argument tuples an action schema keeps grounded (:meth:`ActionSchema.grounded`).
_GROUNDINGS_KEPT = 4096


@dataclass(frozen=True)
class GroundedSchema:
    """An action schema's formulas under one argument tuple (:meth:`ActionSchema.grounded`)."""

    pre: Conjunction  # pre(a), literal by literal
    # (literal, its fact, negated) of each ground literal of pre(a), in order
    pre_ground: tuple[tuple[Lit, tuple[str, ...], bool], ...]
    pre_open: Conjunction  # its literals with variables left (free in pre(a), not parameters)
    add: tuple[tuple[str, ...], ...]  # eff+(a) as facts
    delete: tuple[tuple[str, ...], ...]  # eff-(a) as facts


@dataclass(frozen=True)
class GroundAction:
    """One action of a decision-tree branch: schema, bound arguments and agent(s)."""

    schema: ActionSchema
    args: tuple[str, ...]  # constants, in parameter order
    agents: tuple[str, ...]

    @property
    def name(self) -> str:
        return self.schema.name

    @property
    def binding(self) -> dict[str, str]:
        return dict(zip(self.schema.variables, self.args, strict=True))

    def arg(self, type_or_var: str) -> str | None:
        """The argument bound to the parameter of that type (or variable name)."""
        for (var, typ), val in zip(self.schema.parameters, self.args, strict=True):
            if var == type_or_var or typ == type_or_var:
                return val
        return None

    def __str__(self) -> str:
        return f"{self.schema.name}({', '.join(self.args)})"


@dataclass(frozen=True)
class StopRule:
    """What happens to what a stopped robot holds (``on_stop`` in the domain file): facts
    matching ``holding`` (with ``agent_var`` bound to the arm) are replaced by ``release``.
    The default reads ``holding(?agent, ?obj)`` -> ``on_table(?obj), free(?agent)``: the arm lets
    go where it is."""

    holding: Lit = field(default_factory=lambda: parse_literal("holding(?agent, ?obj)"))
    release: Conjunction = field(
        default_factory=lambda: parse_conjunction(["on_table(?obj)", "free(?agent)"])
    )
    agent_var: str = "?agent"
    object_var: str = "?obj"


@dataclass
class Domain:
    """The agents and action schemas of a scenario."""

    agents: dict[str, Agent]
    actions: dict[str, ActionSchema]
    processes: dict[str, ActionSchema] = field(default_factory=dict)
    on_stop: StopRule = field(default_factory=StopRule)

    def agent(self, name: str) -> Agent:
        try:
            return self.agents[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown agent {name!r}; agents: {', '.join(self.agents)}"
            ) from None

    def schema(self, name: str) -> ActionSchema:
        try:
            return self.actions[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown action {name!r}; actions: {', '.join(sorted(self.actions))}"
            ) from None

    def process(self, name: str) -> ActionSchema:
        try:
            return self.processes[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown process {name!r}; processes: {', '.join(sorted(self.processes))}"
            ) from None

    def capable(self, schema: ActionSchema) -> list[Agent]:
        """The agents that may perform ``schema`` (agents(a) of eq. 20)."""
        spec = schema.agents
        if spec.mode in ("single", "joint"):
            return [self.agents[n] for n in spec.names if n in self.agents]
        typ = dict(schema.parameters).get(str(spec.variable), "agent")
        return self.agents_of_type(typ)

    def human_may_do(self, schema: ActionSchema) -> bool:
        """A human may carry the action out alone (single or choice among humans)."""
        if schema.agents.mode == "joint":
            return False
        return any(a.is_human for a in self.capable(schema))

    def agents_of_type(self, type: str) -> list[Agent]:
        """Agents of a parameter type; the type ``agent`` admits every agent."""
        if type == "agent":
            return list(self.agents.values())
        return [a for a in self.agents.values() if type in a.types or a.name == type]

    def invocation(
        self, text: str, *, process: bool = False
    ) -> tuple[ActionSchema, tuple[str, ...]]:
        """Parse ``transport(?arm, ?leg, bolt_2)`` into its schema and argument terms
        (``process=True``: a node process such as ``hold(?top)``)."""
        key = (text, process)
        hit = self._invocations.get(key)
        if hit is not None:
            return hit
        lit: Lit = parse_literal(text)
        schema = self.process(lit.predicate) if process else self.schema(lit.predicate)
        if len(lit.args) != len(schema.parameters):
            raise FormatError(
                f"action {text!r}: {schema.name} takes {len(schema.parameters)} arguments "
                f"({', '.join(v for v, _ in schema.parameters)}), got {len(lit.args)}"
            )
        self._invocations[key] = (schema, lit.args)
        return schema, lit.args

    def __post_init__(self) -> None:
        self._invocations: dict[tuple[str, bool], tuple[ActionSchema, tuple[str, ...]]] = {}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str | Path | None = None) -> Domain:
        agents: dict[str, Agent] = {}
        for name, ad in (data.get("agents") or {}).items():
            if not isinstance(ad, Mapping) or ad.get("kind") not in ("human", "robot"):
                raise FormatError(f"agent {name!r}: needs kind: human or robot", source)
            extra = {k: v for k, v in ad.items() if k not in ("kind", "types")}
            agents[str(name)] = Agent(str(name), ad["kind"], tuple(ad.get("types", ())), extra)
        actions = {
            str(name): _schema(str(name), sd, agents, source, "action")
            for name, sd in (data.get("actions") or {}).items()
        }
        processes = {
            str(name): _schema(str(name), sd, agents, source, "process")
            for name, sd in (data.get("processes") or {}).items()
        }
        on_stop = StopRule()
        if data.get("on_stop") is not None:
            sd = data["on_stop"]
            if not isinstance(sd, Mapping) or "holding" not in sd:
                raise FormatError(
                    "on_stop needs holding: 'holding(?agent, ?obj)' and release: [...]",
                    source,
                    _line(data, "on_stop"),
                )
            held = parse_literal(str(sd["holding"]), str(source), _line(sd, "holding"))
            if len(held.args) != 2 or not all(is_variable(a) for a in held.args):
                raise FormatError(
                    "on_stop: holding must have two variables (agent, object)",
                    source,
                    _line(sd, "holding"),
                )
            on_stop = StopRule(
                held,
                _formula(sd.get("release"), source, _line(sd, "release")),
                held.args[0],
                held.args[1],
            )
        return cls(agents, actions, processes, on_stop)

    @classmethod
    def load(cls, path: str | Path) -> Domain:
        from flexhrc.representation.formats.yaml_format import read_yaml

        data = read_yaml(path)
        if not isinstance(data, Mapping):
            raise FormatError("a domain file must be a mapping with 'agents' and 'actions'", path)
        return cls.from_dict(data, path)


def _line(d: Any, key: Any = None) -> int | None:
    lines = getattr(d, "lines", None)
    if key is not None and lines and key in lines:
        return int(lines[key])
    line = getattr(d, "line", None)
    return int(line) if line else None


#: The keys of an action or process entry (a typo such as ``txt:`` is one error, not ignored).
SCHEMA_KEYS = (
    "parameters",
    "agents",
    "pre",
    "add",
    "delete",
    "kind",
    "duration",
    "moves_to",
    "until",
    "carries",
    "fixes",
    "undo",
    "target",
    "priority",
    "text",
)


def _schema(
    name: str, sd: Any, agents: Mapping[str, Agent], source: str | Path | None, what: str
) -> ActionSchema:
    if not isinstance(sd, Mapping):
        raise FormatError(f"{what} {name!r} must be a mapping", source)
    line = _line(sd)

    def error(key: str, why: str) -> FormatError:
        """The entry's error at the line of its ``key``."""
        return FormatError(f"{what} {name!r}: {why}", source, _line(sd, key))

    for key in sd:
        if str(key) not in SCHEMA_KEYS:
            near = difflib.get_close_matches(str(key), SCHEMA_KEYS, n=1)
            raise FormatError(
                f"{what} {name!r}: unknown key {key!r}"
                + (f" (did you mean {near[0]!r}?)" if near else "")
                + f"; the keys of {'an' if what == 'action' else 'a'} {what} are "
                + ", ".join(sorted(SCHEMA_KEYS)),
                source,
                _line(sd, key) or line,
            )
    raw_params = sd.get("parameters") or {}
    if not isinstance(raw_params, Mapping):
        raise error("parameters", "parameters must be a mapping {?var: type}")
    params = tuple((str(v), str(t)) for v, t in raw_params.items())
    for v, _ in params:
        if not v.startswith("?"):
            raise error("parameters", f"parameter {v!r} must start with '?'")
    spec = _agent_spec(name, sd.get("agents"), params, agents, source, _line(sd, "agents"))
    duration = sd.get("duration")
    if duration is not None:
        try:
            duration = float(duration)
        except (TypeError, ValueError):
            duration = float("nan")
        if not (0.0 <= duration < 1e6):
            raise error(
                "duration",
                f"duration must be a number of seconds in [0, 1e6), got {sd.get('duration')!r}",
            )
    priority = sd.get("priority", 0)
    if "priority" in sd and what != "process":
        raise error("priority", "priority is a key of processes (which process wins an arm)")
    if isinstance(priority, bool) or not isinstance(priority, int) or abs(priority) > 1_000_000:
        raise error(
            "priority",
            f"priority must be a whole number (the larger wins an arm), got {priority!r}",
        )
    roles: dict[str, str | None] = {}
    for key in ("moves_to", "carries", "fixes"):
        value = sd.get(key)
        if value is not None and str(value) not in dict(params):
            raise error(
                key,
                f"{key} {value!r} is not one of its parameters "
                f"({', '.join(v for v, _ in params) or 'none'})",
            )
        roles[key] = None if value is None else str(value)
    moves_to = roles["moves_to"]
    kind = str(sd.get("kind", name))
    if "kind" in sd:
        why = _kind_check(kind)
        if why:
            raise error("kind", why)
    raw_target = sd.get("target")
    target: tuple[str, ...] = ()
    if raw_target is not None:
        target = (
            (str(raw_target),)
            if isinstance(raw_target, str)
            else tuple(str(v) for v in raw_target)
            if isinstance(raw_target, list)
            else ()
        )
        bad = [v for v in target if v not in dict(params)]
        if not target or len(target) > 2 or bad:
            raise error(
                "target",
                "target must be one or two of its parameters "
                f"({', '.join(v for v, _ in params) or 'none'}), got {raw_target!r}",
            )
    return ActionSchema(
        name,
        params,
        spec,
        _formula(sd.get("pre"), source, _line(sd, "pre")),
        _formula(sd.get("add"), source, _line(sd, "add")),
        _formula(sd.get("delete"), source, _line(sd, "delete")),
        kind,
        duration,
        moves_to,
        _formula(sd.get("until"), source, _line(sd, "until")),
        roles["carries"],
        roles["fixes"],
        None if sd.get("undo") is None else str(sd["undo"]),
        line,
        target,
        priority,
        _text(name, sd, params, source, what),
    )


#: ``{?var}`` in an action's ``text:`` (filled in by :mod:`flexhrc.taskmanager.words`)
TEXT_PLACEHOLDER = re.compile(r"\{(\?[A-Za-z_][A-Za-z0-9_]*)\}")


def placeholders(text: str) -> list[str]:
    """The ``{?var}`` parameters an action's ``text:`` names, in order."""
    return TEXT_PLACEHOLDER.findall(text)


def _text(
    name: str,
    sd: Mapping[str, Any],
    params: tuple[tuple[str, str], ...],
    source: str | Path | None,
    what: str,
) -> str | None:
    """The ``text:`` of an action: plain words whose ``{?var}`` name its parameters."""
    raw = sd.get("text")
    if raw is None:
        return None
    if not isinstance(raw, str) or not raw.strip():
        raise FormatError(
            f'{what} {name!r}: text must be plain words such as "Pick up {{?leg}}", got {raw!r}',
            source,
            _line(sd, "text"),
        )
    known = dict(params)
    bad = [v for v in placeholders(raw) if v not in known]
    if bad:
        raise FormatError(
            f"{what} {name!r}: text names {', '.join('{' + v + '}' for v in bad)}, not one of "
            f"its parameters ({', '.join(known) or 'none'})",
            source,
            _line(sd, "text"),
        )
    return raw.strip()


def _formula(v: Any, source: str | Path | None, line: int | None = None) -> Conjunction:
    if v is None or v == [] or v == "":
        return ()
    if not isinstance(v, str) and not (isinstance(v, list) and all(isinstance(x, str) for x in v)):
        raise FormatError(
            f'expected a list of literals such as ["on_table(?p)"], got {type(v).__name__} '
            f"{str(v)[:60]}",
            source,
            line,
        )
    return parse_conjunction(v, str(source), line)


def _agent_spec(
    action: str,
    v: Any,
    params: tuple[tuple[str, str], ...],
    agents: Mapping[str, Agent],
    source: str | Path | None,
    line: int | None = None,
) -> AgentSpec:
    if isinstance(v, str):
        v = {"choice": v} if v.startswith("?") else {"single": v}
    if not isinstance(v, Mapping) or len(v) != 1:
        raise FormatError(
            f"action {action!r}: agents must be a name, {{choice: ?var}} or {{joint: [names]}}",
            source,
            line,
        )
    mode, value = next(iter(v.items()))
    if mode in ("single", "choice") and not isinstance(value, str):
        raise FormatError(
            f"action {action!r}: agents {{{mode}: ...}} takes one name, got {value!r}"[:200],
            source,
            line,
        )
    if mode == "joint" and not (isinstance(value, list) and all(isinstance(x, str) for x in value)):
        raise FormatError(
            f"action {action!r}: agents {{joint: [...]}} takes a list of agent names, "
            f"got {value!r}"[:200],
            source,
            line,
        )
    if mode == "single":
        if value not in agents:
            raise FormatError(f"action {action!r}: unknown agent {value!r}", source, line)
        return AgentSpec("single", (str(value),))
    if mode == "choice":
        if value not in dict(params):
            raise FormatError(
                f"action {action!r}: choice variable {value!r} is not one of its parameters",
                source,
                line,
            )
        return AgentSpec("choice", (), str(value))
    if mode == "joint":
        names = tuple(str(x) for x in value)
        for n in names:
            if n not in agents:
                raise FormatError(f"action {action!r}: unknown agent {n!r}", source, line)
        return AgentSpec("joint", names)
    raise FormatError(f"action {action!r}: unknown agents mode {mode!r}", source, line)
