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
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.logic import Conjunction, parse_conjunction, parse_literal
from flexhrc.logic import Literal as Lit

AgentMode = Literal["single", "choice", "joint"]


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
    kind: str = ""  # what the simulator does: approach, grasp, transport, screw, ...

    @property
    def variables(self) -> tuple[str, ...]:
        return tuple(v for v, _ in self.parameters)


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


@dataclass
class Domain:
    """The agents and action schemas of a scenario."""

    agents: dict[str, Agent]
    actions: dict[str, ActionSchema]

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

    def agents_of_type(self, type: str) -> list[Agent]:
        """Agents of a parameter type; the type ``agent`` admits every agent."""
        if type == "agent":
            return list(self.agents.values())
        return [a for a in self.agents.values() if type in a.types or a.name == type]

    def invocation(self, text: str) -> tuple[ActionSchema, tuple[str, ...]]:
        """Parse ``transport(?arm, ?leg, bolt_2)`` into its schema and argument terms."""
        lit: Lit = parse_literal(text)
        schema = self.schema(lit.predicate)
        if len(lit.args) != len(schema.parameters):
            raise FormatError(
                f"action {text!r}: {schema.name} takes {len(schema.parameters)} arguments "
                f"({', '.join(v for v, _ in schema.parameters)}), got {len(lit.args)}"
            )
        return schema, lit.args

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str | Path | None = None) -> Domain:
        agents: dict[str, Agent] = {}
        for name, ad in (data.get("agents") or {}).items():
            if not isinstance(ad, Mapping) or ad.get("kind") not in ("human", "robot"):
                raise FormatError(f"agent {name!r}: needs kind: human or robot", source)
            extra = {k: v for k, v in ad.items() if k not in ("kind", "types")}
            agents[str(name)] = Agent(str(name), ad["kind"], tuple(ad.get("types", ())), extra)
        actions: dict[str, ActionSchema] = {}
        for name, sd in (data.get("actions") or {}).items():
            if not isinstance(sd, Mapping):
                raise FormatError(f"action {name!r} must be a mapping", source)
            params = tuple((str(v), str(t)) for v, t in (sd.get("parameters") or {}).items())
            for v, _ in params:
                if not v.startswith("?"):
                    raise FormatError(
                        f"action {name!r}: parameter {v!r} must start with '?'", source
                    )
            spec = _agent_spec(name, sd.get("agents"), params, agents, source)
            actions[str(name)] = ActionSchema(
                str(name),
                params,
                spec,
                _formula(sd.get("pre"), source),
                _formula(sd.get("add"), source),
                _formula(sd.get("delete"), source),
                str(sd.get("kind", name)),
            )
        return cls(agents, actions)

    @classmethod
    def load(cls, path: str | Path) -> Domain:
        from flexhrc.representation.formats.yaml_format import read_yaml

        data = read_yaml(path)
        if not isinstance(data, Mapping):
            raise FormatError("a domain file must be a mapping with 'agents' and 'actions'", path)
        return cls.from_dict(data, path)


def _formula(v: Any, source: str | Path | None) -> Conjunction:
    if not v:
        return ()
    return parse_conjunction(v if isinstance(v, str) else [str(x) for x in v], str(source))


def _agent_spec(
    action: str,
    v: Any,
    params: tuple[tuple[str, str], ...],
    agents: Mapping[str, Agent],
    source: str | Path | None,
) -> AgentSpec:
    if isinstance(v, str):
        v = {"choice": v} if v.startswith("?") else {"single": v}
    if not isinstance(v, Mapping) or len(v) != 1:
        raise FormatError(
            f"action {action!r}: agents must be a name, {{choice: ?var}} or {{joint: [names]}}",
            source,
        )
    mode, value = next(iter(v.items()))
    if mode == "single":
        if value not in agents:
            raise FormatError(f"action {action!r}: unknown agent {value!r}", source)
        return AgentSpec("single", (str(value),))
    if mode == "choice":
        if value not in dict(params):
            raise FormatError(
                f"action {action!r}: choice variable {value!r} is not one of its parameters",
                source,
            )
        return AgentSpec("choice", (), str(value))
    if mode == "joint":
        names = tuple(str(x) for x in value)
        for n in names:
            if n not in agents:
                raise FormatError(f"action {action!r}: unknown agent {n!r}", source)
        return AgentSpec("joint", names)
    raise FormatError(f"action {action!r}: unknown agents mode {mode!r}", source)
