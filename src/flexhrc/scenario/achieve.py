"""Can a hyper-arc's actions make its parent's state formula true? (a check of ``validate``)

When the Task Manager has done a hyper-arc ``h``'s actions it meets the parent ``n`` only when
``S(n)`` holds under the grounding ``h`` was done with (its variables carry to ``S(n)``). A
positive literal of ``S(n)`` that nothing can make true leaves ``n`` unmet for ever and the run
ends in a deadlock. :func:`never_achieved` finds those literals *soundly*: it reports a literal
only when no grounding consistent with the parameter types can make it true, so a scenario that
can run is never refused. A literal ``L`` of ``S(n)`` counts as achievable when it unifies, with
every variable bound to a constant of the variable's type, with

1. an add effect of an action of ``h`` — ``h``'s variables are shared with ``S(n)`` exactly as
   the grounding carries them;
2. an initial fact of the world, including the type facts of objects, places and agents;
3. an add effect of an action of any hyper-arc that may run before or alongside ``h`` while
   ``n`` is unmet (every hyper-arc except those that need ``n`` met first — ``n`` is one of
   their children, or every way to reach one of their children goes through ``n``), of a
   hyper-arc of another graph definition of the hierarchy, or of any node process;
   their variables are renamed apart, as each runs with a grounding of its own.

Deleted facts are not subtracted (a delete effect may not apply under the grounding the run
picks), negated literals are never reported (something may always undo a fact), and a
predicate that no fact and no effect mentions is left to the warning about such predicates
(perception may assert it). Hyper-arcs that open a lower graph are not checked: what they do is
the lower graph's work.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

from flexhrc.errors import FormatError
from flexhrc.logic import Literal, is_variable
from flexhrc.representation import HierarchicalGraph
from flexhrc.representation.graph import AndOrGraph, Hyperarc
from flexhrc.taskmanager.domain import ActionSchema, Domain

#: variable -> the types it may take (empty: any constant)
Types = Mapping[str, frozenset[str]]


@dataclass(frozen=True)
class NeverTrue:
    """A literal of a parent's state formula that its hyper-arc's actions never make true."""

    graph: str  # definition key
    hyperarc: str
    node: str
    literal: Literal
    line: int | None
    source: str | None  # the graph's file (None: the scenario file itself)

    @property
    def message(self) -> str:
        return (
            f"hyper-arc {self.hyperarc}: its actions never make '{self.literal}' true "
            f"(node {self.node})"
        )


@dataclass(frozen=True)
class _Effect:
    literal: Literal
    types: Types


def never_achieved(
    graph: HierarchicalGraph,
    domain: Domain,
    facts: Iterable[Literal],
    constant_types: Mapping[str, frozenset[str]],
) -> list[NeverTrue]:
    """Every (hyper-arc, parent literal) pair that no grounding can make true (rules above).

    ``facts`` are the world's initial facts (type facts included); ``constant_types`` maps each
    known constant to every type it has (a constant missing there may take any type).
    """
    initial = [_Effect(lit, {}) for lit in facts if not lit.negated]
    keys = graph.used_keys()
    # what every definition's hyper-arcs add, renamed apart (rule 3)
    adds: dict[str, dict[str, list[_Effect]]] = {
        key: {
            h.name: list(_effects(h, graph.graphs[key], domain, apart=True))
            for h in graph.graphs[key].hyperarcs.values()
        }
        for key in keys
    }
    processes = [e for s in domain.processes.values() for e in _schema_effects(s)]
    # predicates of no fact and no effect at all have a warning of their own
    makeable = {e.literal.predicate for e in initial} | {
        lit.predicate
        for s in (*domain.actions.values(), *domain.processes.values())
        for lit in s.add
    }
    out: list[NeverTrue] = []
    for key in keys:
        g = graph.graphs[key]
        elsewhere = [e for k in keys if k != key for effs in adds[k].values() for e in effs]
        needing: dict[str, set[str]] = {}  # parent node -> hyper-arcs that need it (lazily)
        for h in g.hyperarcs.values():
            parent = g.nodes.get(h.parent)
            if h.lower is not None or parent is None or not parent.formula:
                continue
            try:
                own_types = _variable_types(h, g, domain)
                own = list(_effects(h, g, domain, apart=False))
            except (FormatError, KeyError):
                continue  # an unknown action: reported on its own
            for lit in parent.formula:
                if lit.negated or lit.predicate not in makeable:
                    continue
                if any(
                    _unifies(lit, e.literal, own_types, e.types, constant_types)
                    for e in (*own, *initial)
                ):
                    continue
                # the rare case: is it anything else's doing? (the graph search only now)
                if h.parent not in needing:
                    needing[h.parent] = _needing(g, h.parent)
                before = (
                    e
                    for name, effs in adds[key].items()
                    if name not in needing[h.parent] and (name != h.name or key != graph.top)
                    for e in effs
                )
                if any(
                    _unifies(lit, e.literal, own_types, e.types, constant_types)
                    for e in (*before, *elsewhere, *processes)
                ):
                    continue
                out.append(NeverTrue(key, h.name, h.parent, lit, h.line, g.source))
    return out


def _variable_types(h: Hyperarc, g: AndOrGraph, domain: Domain) -> dict[str, frozenset[str]]:
    """The types a hyper-arc variable may take: any of the parameter types it fills (the
    decision tree grounds it by the first; be lenient and accept any of them); a variable of
    a child's formula takes whatever that formula binds it to, whatever its type."""
    types: dict[str, set[str]] = {}
    for text in h.actions:
        schema, args = domain.invocation(text)
        for (_, typ), term in zip(schema.parameters, args, strict=True):
            if is_variable(term):
                types.setdefault(term, set()).add(typ)
    for c in h.children:
        child = g.nodes.get(c)
        for lit in (child.formula or ()) if child is not None else ():
            for a in lit.args:
                types.pop(a, None)
    return {v: frozenset(t) for v, t in types.items()}


def _effects(h: Hyperarc, g: AndOrGraph, domain: Domain, *, apart: bool) -> Iterator[_Effect]:
    """The add effects of h's actions in h's variables (renamed apart when ``apart``)."""
    if h.lower is not None:
        return
    try:
        types = _variable_types(h, g, domain)
        parsed = [domain.invocation(text) for text in h.actions]
    except (FormatError, KeyError):
        return
    for schema, args in parsed:
        subst = dict(zip(schema.variables, args, strict=True))
        for lit in schema.add:
            # a variable that is no parameter is free: its own name, kept apart
            terms = tuple(subst.get(a, "?~" + a[1:]) if is_variable(a) else a for a in lit.args)
            if apart:
                terms = tuple("?~" + t[1:] if is_variable(t) else t for t in terms)
                tys = {"?~" + v[1:]: t for v, t in types.items()}
            else:
                tys = dict(types)
            yield _Effect(Literal(lit.predicate, terms), tys)


def _schema_effects(schema: ActionSchema) -> Iterator[_Effect]:
    types = {"?~" + v[1:]: frozenset({t}) for v, t in schema.parameters}
    for lit in schema.add:
        terms = tuple("?~" + a[1:] if is_variable(a) else a for a in lit.args)
        yield _Effect(Literal(lit.predicate, terms), types)


def _needing(g: AndOrGraph, node: str) -> set[str]:
    """Hyper-arcs of g that can run only once ``node`` is met: ``node`` is one of their
    children, or one of their children can be reached only through such hyper-arcs (every
    hyper-arc into it is one). A leaf (no hyper-arc into it) needs nothing."""
    incoming: dict[str, list[str]] = {}
    for h in g.hyperarcs.values():
        incoming.setdefault(h.parent, []).append(h.name)
    nodes = {node}
    arcs: set[str] = set()
    changed = True
    while changed:
        changed = False
        for h in g.hyperarcs.values():
            if h.name not in arcs and any(c in nodes for c in h.children):
                arcs.add(h.name)
                changed = True
        for n, into in incoming.items():
            if n not in nodes and all(a in arcs for a in into):
                nodes.add(n)
                changed = True
    return arcs


def _unifies(
    goal: Literal,
    effect: Literal,
    goal_types: Types,
    effect_types: Types,
    constant_types: Mapping[str, frozenset[str]],
) -> bool:
    """Whether some grounding consistent with the types makes ``effect`` equal ``goal``.

    A variable of both is one variable (the hyper-arc's own effects share the goal's); effects
    of other elements were renamed apart beforehand."""
    if goal.predicate != effect.predicate or len(goal.args) != len(effect.args):
        return False
    subst: dict[str, str] = {}

    def walk(t: str) -> str:
        while t in subst:
            t = subst[t]
        return t

    for a, b in zip(goal.args, effect.args, strict=True):
        a, b = walk(a), walk(b)
        if a == b:
            continue
        if is_variable(a):
            subst[a] = b
        elif is_variable(b):
            subst[b] = a
        else:
            return False
    types = {**effect_types, **goal_types}  # shared: the same map; apart: disjoint keys
    for var in subst:
        value = walk(var)
        if is_variable(value):
            continue  # two variables: some common constant may exist
        wanted = types.get(var)
        has = constant_types.get(value)
        if wanted and has is not None and not (wanted & has):
            return False
    return True
