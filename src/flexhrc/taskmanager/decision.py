"""The Action-State table and the decision tree (paper 000, section V).

:class:`ActionStateTable` has one row per feasible node or hyper-arc: its ordered actions (for a
hyper-arc, A(h)) or processes (for a node, P(n)), its cost, and the progress of execution — which
actions are done, and by whom.

:class:`DecisionTree` enumerates, for one element, every consistent grounding of its variables
against the knowledge base times every admissible agent assignment; each leaf is a
:class:`Branch` whose ordered ground actions are simulated and scored with the utility of
eq. (21). The branch with the highest utility wins (ties: enumeration order, deterministic).

Before a branch is simulated its preconditions are checked symbolically (paper 000, eq. 20):
``pre(a_i)`` must hold in the knowledge base's facts progressed by the effects of
``a_1 .. a_{i-1}``. A branch that fails is *pruned* — kept in :attr:`DecisionTree.pruned` with
the reason, so the log says why it was never simulated.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import Literal, Substitution, is_variable, satisfy
from flexhrc.taskmanager.domain import ActionSchema, Domain, GroundAction, GroundedSchema
from flexhrc.taskmanager.simulator import SimulationResult, Simulator


@dataclass
class Row:
    """One row of the Action-State table."""

    element: str
    kind: str
    cost: float
    actions: tuple[str, ...]
    done_by: list[str | None] = field(default_factory=list)
    status: str = "feasible"  # feasible | running | solved | infeasible

    def __post_init__(self) -> None:
        if not self.done_by:
            self.done_by = [None] * len(self.actions)

    @property
    def next_index(self) -> int:
        for i, who in enumerate(self.done_by):
            if who is None:
                return i
        return len(self.actions)

    def to_dict(self) -> dict[str, Any]:
        return {
            "element": self.element,
            "kind": self.kind,
            "cost": self.cost,
            "actions": list(self.actions),
            "done_by": list(self.done_by),
            "status": self.status,
        }


class ActionStateTable:
    """Rows for the feasible elements, refreshed after every graph answer."""

    def __init__(self) -> None:
        self.rows: dict[str, Row] = {}

    def refresh(self, feasible: Mapping[str, float], describe: Any) -> None:
        """Add rows for new feasible elements, update costs, drop rows no longer feasible
        (unless running)."""
        for name, cost in feasible.items():
            row = self.rows.get(name)
            if row is None:
                kind, actions = describe(name)
                self.rows[name] = Row(name, kind, cost, actions)
            else:
                row.cost = cost
        for name in [
            n for n, r in self.rows.items() if n not in feasible and r.status != "running"
        ]:
            del self.rows[name]

    def __getitem__(self, name: str) -> Row:
        return self.rows[name]

    def __contains__(self, name: object) -> bool:
        return name in self.rows

    def running(self) -> list[Row]:
        return [r for r in self.rows.values() if r.status == "running"]


@dataclass
class Branch:
    """One leaf of a decision tree: a grounding, the agents, the ground actions, the score."""

    grounding: dict[str, str]
    steps: list[GroundAction]
    result: SimulationResult | None = None
    pruned: str | None = None  # why it was never simulated (a precondition fails)
    #: the terms of a shaped utility (:mod:`flexhrc.taskmanager.utility`), None for eq. (21)
    terms: dict[str, float] | None = None

    @property
    def utility(self) -> float:
        if self.terms is not None:
            return self.terms["utility"]
        return self.result.utility if self.result else 0.0

    @property
    def agents(self) -> tuple[str, ...]:
        seen: dict[str, None] = {}
        for s in self.steps:
            for a in s.agents:
                seen.setdefault(a, None)
        return tuple(seen)

    def to_dict(self) -> dict[str, Any]:
        r = self.result
        return {
            "grounding": dict(self.grounding),
            "agents": list(self.agents),
            "success": bool(r and r.success),
            "durations": [round(d, 6) for d in (r.durations if r else [])],
            "utility": self.utility,
            "reason": r.reason if r else self.pruned,
            **({"terms": dict(self.terms)} if self.terms is not None else {}),
        }


class DecisionTree:
    """Groundings x agent assignments for one element, simulated and scored (eq. 21)."""

    def __init__(self, element: str, branches: list[Branch], pruned: list[Branch] | None = None):
        self.element = element
        self.branches = branches
        self.pruned = pruned or []

    @classmethod
    def build(
        cls,
        element: str,
        invocations: Sequence[str],
        constraints: Iterable[Literal],
        domain: Domain,
        kb: KnowledgeBase,
        *,
        exclude: Iterable[Mapping[str, str]] = (),
        available_agents: Iterable[str] | None = None,
        reserved: Iterable[str] = (),
        check_pre: bool = True,
        from_index: int = 0,
        binding: Mapping[str, str] | None = None,
    ) -> DecisionTree:
        """Enumerate branches.

        ``constraints`` are the state formulas of the element's children (the objects must be
        in the state the element starts from); each action's agent parameter ranges over the
        capable agents in ``available_agents``; objects in ``reserved`` (used by another
        running element) and groundings in ``exclude`` (failed before) are left out. With
        ``check_pre`` every branch's preconditions are checked from step ``from_index`` on
        (earlier steps count as done) and failing branches go to :attr:`pruned`. ``binding``
        fixes variables beforehand (the groundings the children were reached with).
        """
        parsed = [domain.invocation(text) for text in invocations]
        variables: dict[str, str] = {}  # variable -> type
        agent_vars: set[str] = set()
        for schema, args in parsed:
            for (pvar, ptype), term in zip(schema.parameters, args, strict=True):
                if is_variable(term):
                    variables.setdefault(term, ptype)
                    if schema.agents.mode == "choice" and schema.agents.variable == pvar:
                        agent_vars.add(term)
        available = set(available_agents) if available_agents is not None else set(domain.agents)
        reserved_set = set(reserved)
        excluded = [dict(x) for x in exclude]
        constraint_list = list(constraints)
        bound_by_constraints = {a for lit in constraint_list for a in lit.args if is_variable(a)}
        bound_by_constraints |= set(binding or {})

        # Object variables: ground them from the KB (children's formulas + their types).
        object_vars = [v for v in variables if v not in agent_vars]
        type_lits = [
            Literal(variables[v], (v,)) for v in object_vars if v not in bound_by_constraints
        ]
        groundings: list[Substitution] = []
        seen: set[tuple[tuple[str, str], ...]] = set()
        for sub in kb.iter_query([*constraint_list, *type_lits], binding):
            key = tuple(sorted((k, v) for k, v in sub.items() if k in variables))
            if key in seen:
                continue
            seen.add(key)
            if any(sub.get(v) in reserved_set for v in object_vars):
                continue
            groundings.append({k: v for k, v in key})
        # Agent variables: every capable, available agent of the parameter's type.
        agent_choices: list[list[tuple[str, str]]] = []
        for v in sorted(agent_vars):
            names = [a.name for a in domain.agents_of_type(variables[v]) if a.name in available]
            agent_choices.append([(v, n) for n in names])
        branches: list[Branch] = []
        pruned: list[Branch] = []
        facts = kb.facts if check_pre else frozenset()
        grounders = [(schema, args, _choice_index(schema)) for schema, args in parsed]
        for g in groundings:
            combos: list[dict[str, str]] = [dict(g)]
            for choices in agent_choices:
                combos = [{**c, v: n} for c in combos for v, n in choices]
            for full in combos:
                if excluded and any(
                    all(full.get(k) == v for k, v in ex.items()) for ex in excluded
                ):
                    continue
                steps = [_ground(schema, args, full, i) for schema, args, i in grounders]
                if any(a not in available for s in steps for a in s.agents):
                    continue
                why = unmet_precondition(steps, facts, from_index) if check_pre else None
                if why is not None:
                    pruned.append(Branch(full, steps, pruned=why))
                    continue
                branches.append(Branch(full, steps))
        return cls(element, branches, pruned)

    def evaluate(
        self,
        simulator: Simulator,
        kb: KnowledgeBase,
        domain: Domain,
        score: Callable[[Branch], dict[str, float] | None] | None = None,
    ) -> Branch | None:
        """Simulate every branch; the best one (utility > 0), or None. ``score`` gives a
        simulated branch its terms under a shaped utility or an operator model (None, or no
        ``score``: eq. 21).

        A simulator that offers ``simulate_many(branches, kb, domain)`` (the kinematic one:
        branches share their motions, issue 23) gets every branch at once; any other is asked
        branch by branch (:class:`~flexhrc.taskmanager.simulator.Simulator`)."""
        many = getattr(simulator, "simulate_many", None)
        if many is not None and self.branches:
            results = many([b.steps for b in self.branches], kb, domain)
            for b, r in zip(self.branches, results, strict=True):
                b.result = r
        else:
            for b in self.branches:
                b.result = simulator.simulate(b.steps, kb, domain)
        if score is not None:
            for b in self.branches:
                b.terms = score(b)
        best = None
        for b in self.branches:
            if b.utility > 0 and (best is None or b.utility > best.utility):
                best = b
        return best

    def to_dict(self) -> dict[str, Any]:
        return {
            "element": self.element,
            "branches": [b.to_dict() for b in self.branches],
            "pruned": [b.to_dict() for b in self.pruned],
        }


Facts = frozenset[tuple[str, ...]] | set[tuple[str, ...]]


def holds(formula: Iterable[Literal], facts: Facts) -> bool:
    """Whether a conjunction holds in ``facts`` (closed world); ground literals are set lookups,
    the rest a search."""
    rest: list[Literal] = []
    for lit in formula:
        if lit.is_ground:
            if (lit.key() in facts) == lit.negated:
                return False
        else:
            rest.append(lit)
    return not rest or next(satisfy(rest, facts), None) is not None


def unmet_precondition(
    steps: Sequence[GroundAction],
    facts: Facts,
    from_index: int = 0,
) -> str | None:
    """The first step whose ``pre(a)`` fails in ``facts`` progressed by the earlier steps'
    effects (eq. 20), as a sentence; None when every precondition holds."""
    state: set[tuple[str, ...]] | None = None  # copied on the first effect only
    current: Facts = facts
    for i, step in enumerate(steps):
        g = step.schema.grounded(step.args)
        if i >= from_index and g.pre and not _pre_holds(g, current):
            # name the literals that fail (all of them when they share free variables)
            bad = [lit for lit, key, negated in g.pre_ground if (key in current) == negated]
            bad = bad or list(g.pre_open) or list(g.pre)
            return f"pre({step}) does not hold: {' & '.join(str(x) for x in bad)}"
        if g.add or g.delete:
            if state is None:
                state = set(current)
                current = state
            state.difference_update(g.delete)
            state.update(g.add)
    return None


def _pre_holds(g: GroundedSchema, facts: Facts) -> bool:
    """:func:`holds` for a grounded pre(a): its ground literals are set lookups made once."""
    for _, key, negated in g.pre_ground:
        if (key in facts) == negated:
            return False
    return not g.pre_open or next(satisfy(g.pre_open, facts), None) is not None


def _choice_index(schema: ActionSchema) -> int | None:
    """The position of the argument that names the agent (``choice``), or None (fixed)."""
    spec = schema.agents
    return schema.variables.index(str(spec.variable)) if spec.mode == "choice" else None


def _ground(
    schema: ActionSchema, args: Sequence[str], subst: Mapping[str, str], choice: int | None
) -> GroundAction:
    # a[:1] == "?" is is_variable(a), inline: this runs for every action of every branch
    values = tuple([subst.get(a, a) if a[:1] == "?" else a for a in args])
    agents = schema.agents.names if choice is None else (values[choice],)
    return GroundAction(schema, values, agents)
