"""The optimal cooperation path, allocation and schedule of a task with CP-SAT (issue 23).

The task as the solver sees it (:class:`Task`, made once per scenario by :func:`build_task`):

* **the AND/OR graph** (paper 000, section IV): a Boolean ``x_h`` per hyper-arc (taken or not)
  and ``r_n`` per node (reached or not). The root is reached; a node that hyper-arcs lead to is
  reached by exactly one of them (``sum x_h = r_n``: the OR alternatives); a hyper-arc taken
  needs every child reached (the AND) and its parent reached, and starts after every child is
  met: one cooperation path to the goal, the precedence of the graph.
* **leaf nodes** hold from the start, or become true by effects: a leaf whose state formula does
  not hold is reached only when a taken branch adds each fact it misses, and after that branch
  ends (the domain's effects give the precedence the graph does not draw, e.g. a screw's hole
  is open once the cover is on).
* **branches** (section V-A): each hyper-arc's groundings x agents, grounded by the Task
  Manager's own :class:`~flexhrc.taskmanager.decision.DecisionTree` against the knowledge base
  (and the facts the task can make true, so that later steps ground too) and timed by the
  branch simulator the Task Manager uses (analytic, or kinematic where asked and the actions
  have motion kinds). One branch per hyper-arc taken; its actions run in order, each an
  optional interval on every agent it names (a joint action occupies all of them) with
  ``NoOverlap`` per agent: one action per agent at a time. Agents able to do an action are
  agents(a) of eq. 20 (capability, types, reach: the simulator fails a branch an arm cannot
  reach). An object fact a branch consumes (deletes; nothing adds it back) is consumed once: two
  hyper-arcs cannot take the same leg.
* **node processes** P(n) (eq. 5): an interval on the process's agents from the node's reaching
  to its meeting, whole rounds long, until its ``until`` facts hold (the taken branches that add
  them have ended).

Objectives: ``makespan`` (when the goal is met), ``idle`` (every agent's time without an action
before the makespan, summed; then the makespan), ``workload`` (the persons' busy time; then the
makespan). Times are whole milliseconds inside the model. The plan's makespan is comparable with
``timing.total_s`` of ``flexhrc run --json``: the same durations, from the same simulator.

:func:`solve` plans a scenario from its start, :func:`solve_remaining` the rest of a task at a
decision of a running Task Manager (what is solved stays solved, what runs keeps its agents until
their release, a warm start from the last schedule) — the ``lookahead`` policy's question —, and
:func:`hindsight` the task constrained to the cooperation path and the persons' hyper-arcs of a
finished run.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Container, Iterable, Mapping, Sequence, Set
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from flexhrc.errors import FlexhrcError
from flexhrc.events import PROFILES, SIMULATORS
from flexhrc.taskmanager.decision import DecisionTree, holds
from flexhrc.taskmanager.domain import GroundAction
from flexhrc.taskmanager.policy import Advice, Start

if TYPE_CHECKING:
    from flexhrc.taskmanager.manager import TaskManager

OBJECTIVES = ("makespan", "idle", "workload")
STATUSES = ("optimal", "feasible", "infeasible", "unknown")
#: model time unit: one millisecond
MS = 1000
#: the most branches of one agent whose order is modelled (a circuit; sequence-dependent
#: travel): beyond it, the agent's branches are timed from where its hand is at the solve
MAX_CIRCUIT = 8
Fact = tuple[str, ...]


# ---------------------------------------------------------------------------------- results --
@dataclass(frozen=True)
class PlanEntry:
    """One action of a schedule: its text, its agents, the hyper-arc it belongs to (a node's
    name for a round of a node process) and when it runs (cell seconds)."""

    action: str
    agents: tuple[str, ...]
    hyperarc: str
    start_s: float
    end_s: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "action": self.action,
            "agents": list(self.agents),
            "hyperarc": self.hyperarc,
            "start_s": round(self.start_s, 6),
            "end_s": round(self.end_s, 6),
        }


@dataclass
class Plan:
    """A solved plan. ``objective`` and ``bound`` are in seconds of the ``goal`` objective
    (``makespan``, ``idle``, ``workload``; ``bound``: the solver's proven lower bound, equal to
    the objective when ``status`` is ``optimal``); ``by_agent``: the hyper-arcs each agent takes
    part in (as ``by_agent`` of ``flexhrc run --json``); ``solve_s``: wall seconds in CP-SAT."""

    status: str
    objective: float | None
    bound: float | None
    makespan_s: float | None
    solve_s: float
    schedule: list[PlanEntry] = field(default_factory=list)
    by_agent: dict[str, int] = field(default_factory=dict)
    goal: str = "makespan"
    #: the hyper-arcs taken -> (agents, grounding) of their branch (what the policy advises)
    chosen: dict[str, tuple[tuple[str, ...], dict[str, str]]] = field(default_factory=dict)

    @property
    def gap(self) -> float | None:
        """(objective - bound) / objective; 0 when optimal, None without a solution."""
        if self.objective is None or self.bound is None:
            return None
        return (
            0.0 if self.objective <= 0 else max(0.0, self.objective - self.bound) / self.objective
        )

    def to_json(self) -> dict[str, Any]:
        """The ``flexhrc plan --json`` contract: exactly these keys."""
        return {
            "status": self.status,
            "objective": _r(self.objective),
            "bound": _r(self.bound),
            "makespan_s": _r(self.makespan_s),
            "solve_s": round(self.solve_s, 6),
            "schedule": [e.to_dict() for e in self.schedule],
            "by_agent": dict(self.by_agent),
        }


def _r(x: float | None) -> float | None:
    return None if x is None else round(x, 6)


# ------------------------------------------------------------------------------- the task --
@dataclass(frozen=True)
class Option:
    """One branch of one hyper-arc: its grounding, agents, timed steps (offset and duration
    in ms from the hyper-arc's start) and what it needs, consumes and adds."""

    hyperarc: str
    grounding: Mapping[str, str]
    agents: tuple[str, ...]
    steps: tuple[tuple[str, tuple[str, ...], int, int], ...]
    duration: int
    needs: frozenset[Fact]
    deletes: frozenset[Fact]
    adds: frozenset[Fact]
    #: a number unique in its task (the travel tables' key)
    id: int = 0
    #: where each agent's hand is when the option ends (None: the option does not move it)
    ends: tuple[tuple[str, Any], ...] = ()
    #: the ground actions (to simulate the option again from elsewhere)
    actions: tuple[GroundAction, ...] = ()


@dataclass(frozen=True)
class ProcessOption:
    """Who may run node ``node``'s process ``action`` (its first), a round's length (ms), and
    the ground facts its ``until`` waits for that the process itself does not add."""

    node: str
    action: str
    agents: tuple[str, ...]
    round_ms: int
    until: tuple[Fact, ...]


@dataclass
class Task:
    """A scenario's graph, branches and processes as the solver sees them (see the module
    docstring); made once by :func:`build_task`."""

    root: str
    nodes: list[str]
    hyperarcs: list[str]
    children: dict[str, list[str]]
    parent: dict[str, str]
    incoming: dict[str, list[str]]
    formula: dict[str, tuple[Any, ...]]
    options: dict[str, list[Option]]
    processes: dict[str, list[ProcessOption]]
    agents: list[str]
    humans: set[str]
    #: facts true at the start that some branch deletes and no branch adds: consumed once
    consumable: frozenset[Fact]
    #: sequence-dependent travel (analytic simulator): agent -> option id -> where the
    #: option leaves the agent's hand (None: it does not move it), and agent -> (that place,
    #: option id) -> how much longer (ms, < 0: shorter) the option is from there than from
    #: where the hand is at the solve
    leaves_at: dict[str, dict[int, Any]] = field(default_factory=dict)
    setup: dict[str, dict[tuple[Any, int], int]] = field(default_factory=dict)
    #: a joint branch's travel (its hands move together; it lasts as long as the slowest, so
    #: one hand's delta alone is no bound): option id -> (its agents with travel, and places
    #: one per agent — None: where the hand is at the start — -> delta ms; None: too many
    #: places to simulate, the branch may then take any time down to nothing)
    joint: dict[int, tuple[tuple[str, ...], dict[tuple[Any, ...], int] | None]] = field(
        default_factory=dict
    )
    #: the hierarchy (transition T, eq. 14): a hyper-arc with a lower instance -> that
    #: instance's root (the hyper-arc is solved when it is met, eq. 18)
    lower: dict[str, str] = field(default_factory=dict)
    #: a lower instance's root -> the hyper-arc that calls it
    upper_of: dict[str, str] = field(default_factory=dict)
    #: a lower instance's leaf -> the hyper-arc that calls the instance (the leaf is reached
    #: no earlier than the instance is active: that hyper-arc's children met, eq. 17)
    activated_by: dict[str, str] = field(default_factory=dict)


def _steps_facts(steps: Sequence[GroundAction]) -> tuple[set[Fact], set[Fact], set[Fact]]:
    """What a branch needs from the state before it (ground preconditions no earlier step
    made true), deletes for good and adds (its net effects)."""
    needs: set[Fact] = set()
    state_add: set[Fact] = set()
    state_del: set[Fact] = set()
    for step in steps:
        g = step.schema.grounded(step.args)
        for _, key, negated in g.pre_ground:
            if not negated and key not in state_add:
                needs.add(key)
        for f in g.delete:
            if f in state_add:  # made by an earlier step: gone again, the state as before
                state_add.discard(f)
            else:
                state_del.add(f)
        for f in g.add:
            state_del.discard(f)
            state_add.add(f)
    return needs, state_del, state_add


def _relaxed_kb(tm: Any, hyperarcs: list[str], scopes: Mapping[str, Mapping[str, str]]) -> Any:
    """The knowledge base with every fact the task can make true added (deletes ignored), so
    that hyper-arcs of later steps ground (their children's formulas hold there)."""
    kb = tm.kb.copy()
    for _ in range(len(hyperarcs) + 1):
        grew = False
        for h in hyperarcs:
            actions = tm.actions_of(h)
            if not actions:
                continue
            tree = DecisionTree.build(
                h,
                actions,
                tm.constraints_of(h),
                tm.domain,
                kb,
                check_pre=False,
                binding=scopes.get(tm.graph.graph_of(h)) or None,
            )
            for b in tree.branches:
                for step in b.steps:
                    for f in step.schema.grounded(step.args).add:
                        if f not in kb.facts:
                            kb.assert_fact(*f)
                            grew = True
        if not grew:
            break
    return kb


def build_task(tm: Any, simulator: Any | None = None, *, travel: bool = False) -> Task:
    """The task of ``tm``'s graph, domain and knowledge base (as it is now), every branch timed
    by ``simulator`` (default: the manager's own). ``travel``: time each branch also from where
    every other branch leaves its agents' hands (sequence-dependent travel, modelled for agents
    with at most :data:`MAX_CIRCUIT` branches; off by default: it makes big tasks slow to
    prove). ``tm`` is a running
    :class:`~flexhrc.taskmanager.TaskManager` or a scenario's read-only view (:class:`_Reader`)."""
    graph = tm.graph
    hierarchy = graph.hierarchy
    lower, upper_of, activated_by, scopes = _hierarchy(tm)
    sim = simulator if simulator is not None else tm.simulator
    names = graph.elements()
    nodes = [n for n in names if graph.kind(n) == "node"]
    hyperarcs = [n for n in names if graph.kind(n) == "hyperarc"]
    children = {h: tm.children_of(h) for h in hyperarcs}
    parent = {h: tm.parent_of(h) for h in hyperarcs}
    incoming: dict[str, list[str]] = {n: [] for n in nodes}
    for h in hyperarcs:
        incoming[parent[h]].append(h)
    relaxed = _relaxed_kb(tm, hyperarcs, scopes)
    domain, kb = tm.domain, tm.kb
    options: dict[str, list[Option]] = {}
    ids = itertools.count(1)
    for h in hyperarcs:
        actions = tm.actions_of(h)
        if not actions:
            options[h] = [Option(h, {}, (), (), 0, frozenset(), frozenset(), frozenset())]
            continue
        found: dict[tuple[Any, ...], Any] = {}
        scope = scopes.get(graph.graph_of(h)) or None  # a lower instance's binding (M1)
        for base in (kb, relaxed):  # as it is, and as the task can make it (later steps)
            tree = DecisionTree.build(
                h, actions, tm.constraints_of(h), domain, base, check_pre=False, binding=scope
            )
            for b in tree.branches:
                key = (tuple(sorted(b.grounding.items())), b.agents)
                found.setdefault(key, b)
        opts = []
        for b in found.values():
            result = sim.simulate(b.steps, kb, domain)
            if not result.success:
                continue
            steps, t = [], 0
            for step, d in zip(b.steps, result.durations, strict=True):
                ms = max(0, round(d * MS))
                steps.append((str(step), tuple(step.agents), t, ms))
                t += ms
            needs, deletes, adds = _steps_facts(b.steps)
            ends: dict[str, Any] = dict.fromkeys(b.agents)
            for detail in result.details:
                paths: Any = detail.get("paths") or {}
                for a, path in paths.items():
                    ends[a] = tuple(path[1])
            opts.append(
                Option(
                    h,
                    dict(b.grounding),
                    tuple(b.agents),
                    tuple(steps),
                    t,
                    frozenset(needs),
                    frozenset(deletes),
                    frozenset(adds),
                    next(ids),
                    tuple(ends.items()),
                    tuple(b.steps),
                )
            )
        options[h] = opts
    added = {f for opts in options.values() for o in opts for f in o.adds}
    deleted = {f for opts in options.values() for o in opts for f in o.deletes}
    processes = {n: _process_options(tm, n, sim) for n in nodes if tm.processes_of(n)}
    root = hierarchy.top_graph.root
    if root is None:
        raise FlexhrcError("plan: the graph has no root (the goal) to plan for")
    agents = list(domain.agents)
    humans = {a.name for a in domain.agents.values() if a.is_human}
    leaves_at, setup, joint = _travel(options, kb, domain, sim) if travel else ({}, {}, {})
    return Task(
        root,
        nodes,
        hyperarcs,
        children,
        parent,
        incoming,
        {n: _formula(tm, n, scopes) for n in nodes},
        options,
        {n: p for n, p in processes.items() if p},
        agents,
        humans,
        frozenset((deleted & kb.facts) - added),
        leaves_at,
        setup,
        joint=joint,
        lower=lower,
        upper_of=upper_of,
        activated_by=activated_by,
    )


def _hierarchy(
    tm: Any,
) -> tuple[dict[str, str], dict[str, str], dict[str, str], dict[str, dict[str, str]]]:
    """The lower instances of ``tm``'s graph, expanded in place of the hyper-arcs that call
    them (paper 000, IV-B): each such hyper-arc -> its instance's root, that root -> the
    hyper-arc, each instance leaf -> the hyper-arc, and each instance's binding (M1, eq. 15):
    the lower variables its transition maps, valued as the Task Manager values them when the
    instance starts — an object the upper layer names, or the upper hyper-arc's grounding, its
    open variables bound by the first grounding of its children's formulas in the knowledge
    base (at the solve: the plan grounds a hierarchy once, as a run does when it starts)."""
    from flexhrc.logic import is_variable
    from flexhrc.representation.hierarchy import qualify, split_qualified

    hierarchy = tm.graph.hierarchy
    lower: dict[str, str] = {}
    upper_of: dict[str, str] = {}
    activated_by: dict[str, str] = {}
    scopes: dict[str, dict[str, str]] = {"": {}}
    if len(hierarchy.graphs) == 1:
        return lower, upper_of, activated_by, scopes
    keys: dict[str, str] = {}
    for info in hierarchy.instances():  # depth-first: an upper instance before its lowers
        keys[info.path] = info.key
        if info.upper is None:
            continue
        definition = hierarchy.graphs[info.key]
        if definition.root is None:
            raise FlexhrcError(f"plan: lower graph {info.key!r} has no root")
        root = qualify(info.path, str(definition.root))
        lower[info.upper] = root
        upper_of[root] = info.upper
        for leaf in definition.leaves():
            activated_by[qualify(info.path, leaf)] = info.upper
        upper_path, local = split_qualified(info.upper)
        sigma = dict(scopes.get(upper_path, {}))
        transfer = hierarchy.transfer(keys[upper_path], local)
        scope: dict[str, str] = {}
        if transfer:
            terms = (*transfer.down.values(), *transfer.up.values())
            if any(is_variable(t) and t not in sigma for t in terms):
                first = next(tm.kb.iter_query(tm.constraints_of(info.upper), sigma), None)
                if first is not None:
                    sigma = dict(first)
            for mapping in (transfer.down, transfer.up):
                for lower_var, term in mapping.items():
                    value = sigma.get(term) if is_variable(term) else term
                    if value is not None:
                        scope.setdefault(lower_var, value)
        scopes[info.path] = scope
    return lower, upper_of, activated_by, scopes


def _formula(tm: Any, node: str, scopes: Mapping[str, Mapping[str, str]]) -> tuple[Any, ...]:
    """S(n), under its instance's binding (M1)."""
    from flexhrc.logic import apply_substitution

    formula = tuple(tm.formula_of(node))
    scope = scopes.get(tm.graph.graph_of(node)) if len(scopes) > 1 else None
    if scope:
        formula = tuple(apply_substitution(lit, scope) for lit in formula)
    return formula


#: the most combinations of its hands' places a joint branch is simulated from (beyond: its
#: travel is left open down to no time at all, a valid but weak bound)
MAX_JOINT_PLACES = 512


def _travel(options: Mapping[str, list[Option]], kb: Any, domain: Any, sim: Any) -> tuple[
    dict[str, dict[int, Any]],
    dict[str, dict[tuple[Any, int], int]],
    dict[int, tuple[tuple[str, ...], dict[tuple[Any, ...], int] | None]],
]:  # fmt: skip
    """The sequence-dependent travel of the branches (:attr:`Task.setup`): each branch is
    simulated again with one agent's hand where another branch leaves it; a joint branch
    (:attr:`Task.joint`) with its hands at every combination of such places (a joint action
    lasts as long as its slowest hand: both hands nearer can make it shorter than either
    one alone does)."""
    leaves_at: dict[str, dict[int, Any]] = {}
    users: dict[str, list[Option]] = {}
    for opts in options.values():
        for o in opts:
            for a, end in o.ends:
                leaves_at.setdefault(a, {})[o.id] = end
                users.setdefault(a, []).append(o)
    setup: dict[str, dict[tuple[Any, int], int]] = {}
    spots: dict[str, list[Any]] = {}  # agent -> the places its hand is left at (not the start)
    for a, using in users.items():
        if a not in kb.objects:  # a hand the simulator does not place: no travel
            continue
        here = tuple(kb.position(a))
        places = {p for p in leaves_at[a].values() if p is not None and p != here}
        table: dict[tuple[Any, int], int] = {}
        for place in sorted(places):
            moved = kb.copy()
            moved.move(a, place)
            for o in using:
                d = _delta(o, moved, domain, sim)
                if d:
                    table[place, o.id] = d
        setup[a] = table
        spots[a] = sorted(places)
    joint: dict[int, tuple[tuple[str, ...], dict[tuple[Any, ...], int] | None]] = {}
    for opts in options.values():
        for o in opts:
            moving = tuple(a for a in o.agents if a in spots)
            if len(moving) < 2:
                continue
            choices = [[None, *spots[a]] for a in moving]
            if math.prod(map(len, choices)) > MAX_JOINT_PLACES:
                joint[o.id] = (moving, None)
                continue
            deltas: dict[tuple[Any, ...], int] = {}
            for combo in itertools.product(*choices):
                if all(p is None for p in combo):
                    continue
                moved = kb.copy()
                for a, place in zip(moving, combo, strict=True):
                    if place is not None:
                        moved.move(a, place)
                # (every combination kept: its places are the known ones)
                deltas[combo] = _delta(o, moved, domain, sim)
            joint[o.id] = (moving, deltas)
    return leaves_at, setup, joint


def _delta(o: Option, moved: Any, domain: Any, sim: Any) -> int:
    """How much longer (ms) branch ``o`` lasts with the hands where ``moved`` has them (0 where
    it fails from there)."""
    result = sim.simulate(list(o.actions), moved, domain)
    if not result.success:
        return 0
    return sum(max(0, round(x * MS)) for x in result.durations) - o.duration


def _process_options(tm: Any, node: str, sim: Any) -> list[ProcessOption]:
    """Who may run ``node``'s first process: the arms of its type (a person only where no arm
    may), each with a round's simulated length."""
    from flexhrc.logic import apply_substitution, is_variable

    domain, kb = tm.domain, tm.kb
    schema, terms = domain.invocation(tm.processes_of(node)[0], process=True)
    spec = schema.agents
    if spec.mode == "choice":
        typ = dict(schema.parameters).get(str(spec.variable), "agent")
        capable = domain.agents_of_type(typ)
        arms = [a.name for a in capable if not a.is_human]
        who: list[tuple[str, ...]] = [(a,) for a in (arms or [a.name for a in capable])]
    else:
        who = [tuple(spec.names)]
    out = []
    for agents in who:
        values = []
        for (var, typ), term in zip(schema.parameters, terms, strict=True):
            value = term
            if is_variable(term):
                if spec.mode == "choice" and var == spec.variable:
                    value = agents[0]
                else:
                    found = [o.id for o in kb.objects_of_type(typ)][:1]
                    value = found[0] if found else term
            values.append(value)
        ground = GroundAction(schema, tuple(values), agents)
        result = sim.simulate([ground], kb, domain)
        d = result.total_s if result.success else (schema.duration or 1.0)
        g = schema.grounded(tuple(values))
        binding = dict(zip(schema.variables, values, strict=True))
        until = [apply_substitution(lit, binding) for lit in schema.until]
        missing = tuple(
            lit.key()
            for lit in until
            if lit.is_ground and not lit.negated and lit.key() not in g.add
        )
        out.append(ProcessOption(node, str(ground), agents, max(1, round(d * MS)), missing))
    return out


# ------------------------------------------------------------------------------- the state --
@dataclass
class State:
    """Where a task stands (all times in ms from ``now``): hyper-arcs solved or given up,
    nodes met, hyper-arcs running (their agents and when they end), node processes running,
    each agent's release time, the facts true now and the branches no longer allowed."""

    now_s: float = 0.0
    facts: frozenset[Fact] | None = None
    solved: set[str] = field(default_factory=set)
    infeasible: set[str] = field(default_factory=set)
    met: set[str] = field(default_factory=set)
    running: dict[str, tuple[tuple[str, ...], int]] = field(default_factory=dict)
    process_running: dict[str, tuple[tuple[str, ...], int]] = field(default_factory=dict)
    release: dict[str, int] = field(default_factory=dict)
    unavailable: set[str] = field(default_factory=set)
    #: hyper-arc -> agents that may not take it (declined, cannot)
    barred: dict[str, set[str]] = field(default_factory=dict)
    #: hyper-arc -> groundings that failed
    failed: dict[str, list[dict[str, str]]] = field(default_factory=dict)
    #: hindsight: the hyper-arcs to take (None: free) and the agents fixed for some of them
    path: set[str] | None = None
    agents_of: dict[str, tuple[str, ...]] = field(default_factory=dict)
    #: hindsight: agents (the persons) that take no hyper-arc beyond those fixed
    only_fixed: set[str] = field(default_factory=set)
    #: travel at a decision: agent -> where its hand is when it is next free (a place of
    #: :attr:`Task.leaves_at`; an agent not here: where it was when the task was made)
    hands: dict[str, Any] = field(default_factory=dict)


def _allowed(task: Task, st: State, o: Option) -> bool:
    if st.unavailable and any(a in st.unavailable for a in o.agents):
        return False
    barred = st.barred.get(o.hyperarc)
    if barred and any(a in barred for a in o.agents):
        return False
    for g in st.failed.get(o.hyperarc, ()):
        if all(o.grounding.get(k) == v for k, v in g.items()):
            return False
    fixed = st.agents_of.get(o.hyperarc)
    if fixed is not None and set(fixed) != set(o.agents):
        return False
    if fixed is None and st.only_fixed and any(a in st.only_fixed for a in o.agents):
        return False
    if st.facts is not None:  # a consumed object is gone
        gone = (o.needs | o.deletes) & task.consumable
        if any(f not in st.facts for f in gone):
            return False
    return True


# ------------------------------------------------------------------------------ the solver --
def _cp_model() -> Any:
    try:
        from ortools.sat.python import cp_model
    except ImportError:
        raise FlexhrcError(
            "planning needs OR-tools (ortools is missing): pip install 'flexhrc[plan]'"
        ) from None
    return cp_model


def _horizon(task: Task, st: State) -> int:
    total = sum(max((o.duration for o in opts), default=0) for opts in task.options.values())
    total += sum(max(p.round_ms for p in ps) for ps in task.processes.values())
    total += max([0, *st.release.values()])
    total += sum(end for _, end in st.running.values())
    total += sum(end for _, end in st.process_running.values())
    return max(1, 2 * total + MS)


def solve_task(
    task: Task,
    st: State,
    *,
    objective: str = "makespan",
    time_limit_s: float = 10.0,
    seed: int = 0,
    hint: Plan | None = None,
    deterministic: bool = False,
    left_shift: bool = False,
    workers: int = 1,
    max_circuit: int | None = MAX_CIRCUIT,
    improve: bool = False,
) -> Plan:
    """The CP-SAT model of ``task`` from state ``st`` (see the module docstring), solved.

    ``deterministic``: the time limit counts the solver's deterministic time (a stored run
    replays with the same answers); ``left_shift``: every hyper-arc as early as the optimum
    allows (a small second term of the objective: what a policy dispatches now);
    ``max_circuit``: the most branches of an agent whose travel is a circuit (None: every
    agent's, the exact travel model; beyond it, :func:`_least_travel`'s relaxation);
    ``improve``: only improve the ``hint`` (CP-SAT's large-neighbourhood search, at least two
    workers interleaved on one thread — deterministic —, no proof: status ``feasible`` at
    best)."""
    cap = max_circuit if max_circuit is not None else sum(map(len, task.options.values()))
    if objective not in OBJECTIVES:
        raise FlexhrcError(f"--objective {objective!r}: choose one of {', '.join(OBJECTIVES)}")
    cp_model = _cp_model()
    m = cp_model.CpModel()
    big = _horizon(task, st)
    facts = st.facts
    x = {h: m.NewBoolVar(f"x[{h}]") for h in task.hyperarcs}
    r = {n: m.NewBoolVar(f"r[{n}]") for n in task.nodes}
    s = {h: m.NewIntVar(0, big, f"s[{h}]") for h in task.hyperarcs}
    e = {h: m.NewIntVar(0, big, f"e[{h}]") for h in task.hyperarcs}
    reach = {n: m.NewIntVar(0, big, f"reach[{n}]") for n in task.nodes}
    met = {n: m.NewIntVar(0, big, f"met[{n}]") for n in task.nodes}
    lanes: dict[str, list[Any]] = {a: [] for a in task.agents}
    dvs: dict[int, Any] = {}  # option id -> how much its agents' travel changes it (ms)
    # sequence-dependent travel where an agent's branches are few enough for a circuit
    done = st.solved | set(st.running) | st.infeasible
    count = _branch_counts(task, done)
    # an agent whose hand moved since the task was made: a circuit from where it is now even
    # for one branch (its travel from there)
    circuit = {
        a
        for a, t in task.setup.items()
        if t and (1 if a in st.hands else 2) <= count.get(a, 0) <= cap
    }
    delta_of: dict[int, list[int]] = {}  # option id -> its travel deltas, those agents
    # agents with too many branches for a circuit: a relaxation (each branch as if the hand
    # came from where it is quickest), so the plan stays a lower bound of a run's times
    relaxed = {a for a, t in task.setup.items() if t and count.get(a, 0) > cap}
    least: dict[tuple[str, int], int] = {}  # (agent, option id) -> its least travel delta
    for a in sorted(circuit | relaxed):
        for (_, oid), d in task.setup[a].items():
            if oid not in task.joint:
                delta_of.setdefault(oid, []).append(d)
        if a in relaxed:
            least.update(_least_travel(task, a, done))
        if a in relaxed and a in st.hands:  # a decision: each branch from where the hand is
            for _, oid in task.setup[a]:
                least[a, oid] = task.setup[a].get((st.hands[a], oid), 0)
    duration = {o.id: o.duration for opts in task.options.values() for o in opts}
    hyperarc_of = {o.id: h for h, opts in task.options.items() for o in opts}
    left_by: dict[str, dict[str, set[Any]]] = {}  # agent -> hyper-arc -> where it leaves it
    for h, opts in task.options.items():
        if h not in done:
            for o in opts:
                for a, end in o.ends:
                    left_by.setdefault(a, {}).setdefault(h, set()).add(end)
    for oid, (moving, together) in task.joint.items():  # a joint branch: its hands together
        if any(a in circuit or a in relaxed for a in moving):
            if together is None:
                delta_of[oid] = [-duration[oid]]
                continue
            # only where a hand can come from: the start, where it is now, or where a branch
            # of another hyper-arc leaves it (never its own)
            h = hyperarc_of[oid]
            come = [
                {None, st.hands.get(a)}
                | {p for g, ps in left_by.get(a, {}).items() if g != h for p in ps}
                for a in moving
            ]
            delta_of[oid] = [0] + [
                d
                for combo, d in together.items()
                if all(p in c for p, c in zip(combo, come, strict=True))
            ]
    busy: dict[str, list[Any]] = {a: [] for a in task.agents}  # busy time terms per agent
    release = dict(st.release)
    ys: dict[str, list[tuple[Option, Any]]] = {}
    m.Add(r[task.root] == 1)
    for h in task.hyperarcs:
        if h in st.solved:
            m.Add(x[h] == 1)
            m.Add(s[h] == 0)
            m.Add(e[h] == 0)
            continue
        if h in st.running:
            agents, end = st.running[h]
            m.Add(x[h] == 1)
            m.Add(s[h] == 0)
            m.Add(e[h] == end)
            for a in agents:
                release[a] = max(release.get(a, 0), end)
            continue
        opts = [o for o in task.options.get(h, []) if _allowed(task, st, o)]
        # hindsight: off the run's path, but a hyper-arc without actions leaves no trace in
        # a run's solved list: it stays free
        off_path = st.path is not None and h not in st.path and any(o.steps for o in opts)
        if h in st.infeasible or not opts or off_path:
            m.Add(x[h] == 0)
            m.Add(s[h] == 0)
            m.Add(e[h] == 0)
            continue
        if st.path is not None:
            m.Add(x[h] == 1)
        y = [(o, m.NewBoolVar(f"y[{h}#{i}]")) for i, o in enumerate(opts)]
        ys[h] = y
        m.Add(sum(v for _, v in y) == x[h])
        for o, v in y:
            deltas = delta_of.get(o.id)
            if deltas:
                dv = dvs[o.id] = m.NewIntVar(min(0, *deltas), max(0, *deltas), f"dv[{o.id}]")
                m.Add(dv == 0).OnlyEnforceIf(v.Not())
        if h in task.lower:  # carried out by its lower instance: done when its root is met
            m.Add(e[h] == met[task.lower[h]]).OnlyEnforceIf(x[h])
            m.Add(e[h] >= s[h])
        else:
            m.Add(
                e[h]
                == s[h]
                + sum(o.duration * v for o, v in y)
                + sum(dvs[o.id] for o, _ in y if o.id in dvs)
            )
        m.Add(s[h] == 0).OnlyEnforceIf(x[h].Not())
        for o, v in y:
            if o.id in dvs:  # a block per agent, as long as the hand's travel makes it
                for a, (first, last) in _spans(o).items():
                    size = m.NewIntVar(0, big, f"block[{o.id}@{a}]")
                    m.Add(size == last - first + dvs[o.id])
                    end = m.NewIntVar(0, 2 * big, f"block_end[{o.id}@{a}]")
                    m.Add(end == s[h] + last + dvs[o.id])
                    iv = m.NewOptionalIntervalVar(s[h] + first, size, end, v, f"{h}@{a}")
                    lanes[a].append(iv)
                    busy[a].append(_held(m, size, v, big, f"busy[{o.id}@{a}]"))
                continue
            for text, agents, off, d in o.steps:
                if d <= 0:
                    continue
                for a in agents:
                    iv = m.NewOptionalFixedSizeIntervalVar(s[h] + off, d, v, f"{text}@{a}")
                    lanes[a].append(iv)
                    busy[a].append(d * v)
    # agents busy now: each is released at its time
    for a, t in release.items():
        if t > 0 and a in lanes:
            lanes[a].append(m.NewFixedSizeIntervalVar(0, t, f"busy@{a}"))
            busy[a].append(t)
    for h in task.hyperarcs:
        if h in st.solved or h in st.running:
            continue
        for c in task.children[h]:
            m.AddImplication(x[h], r[c])
            m.Add(s[h] >= met[c]).OnlyEnforceIf(x[h])
        m.AddImplication(x[h], r[task.parent[h]])
    zs: dict[str, list[tuple[ProcessOption, Any]]] = {}
    used_by: dict[str, list[str]] = {n: [] for n in task.nodes}
    for h in task.hyperarcs:
        for c in task.children[h]:
            used_by[c].append(h)
    for n in task.nodes:
        if n in task.upper_of:  # a lower instance's root: reached iff its hyper-arc is taken
            m.Add(r[n] == x[task.upper_of[n]])
        elif n != task.root:
            m.AddBoolOr([x[h] for h in used_by[n]]).OnlyEnforceIf(r[n])
        if n in st.met:
            m.Add(reach[n] == 0)
            m.Add(met[n] == 0)
            continue
        into = task.incoming[n]
        if into:
            m.Add(sum(x[h] for h in into) == r[n])
            for h in into:
                m.Add(reach[n] == e[h]).OnlyEnforceIf(x[h])
        else:
            up = task.activated_by.get(n)
            _leaf(m, task, n, r, reach, x, e, ys, facts, 0 if up is None else s[up])
        zs[n] = _process(m, task, st, n, r, reach, met, e, ys, lanes, busy, big)
    if circuit or relaxed:
        preds = _circuits(m, task, circuit, ys, s, dvs, least, st.hands)
        _joint_travel(m, task, st, ys, dvs, preds, relaxed, done)
    for ivs in lanes.values():
        if len(ivs) > 1:
            m.AddNoOverlap(ivs)
    # a fact a branch consumes for good (a leg fastened) is consumed by one branch only
    consumers: dict[Fact, list[Any]] = {}
    for y in ys.values():
        for o, v in y:
            for f in o.deletes & task.consumable:
                consumers.setdefault(f, []).append(v)
    for vs in consumers.values():
        if len(vs) > 1:
            m.AddAtMostOne(vs)
    makespan = m.NewIntVar(0, big, "makespan")
    m.Add(makespan >= met[task.root])
    for h in task.hyperarcs:
        m.Add(makespan >= e[h]).OnlyEnforceIf(x[h])
    for t in release.values():
        m.Add(makespan >= t)
    # redundant bounds (the relaxation alone is weak across alternatives): the earliest a node
    # can be met and the least time from a met node to the goal, from the shortest branches
    head, tail = _bounds(task, st, ys, delta_of)
    for n in task.nodes:
        if n in st.met:
            continue
        if head.get(n, 0) > 0:
            m.Add(met[n] >= head[n]).OnlyEnforceIf(r[n])
        if n in tail and tail[n] > 0:
            m.Add(makespan >= met[n] + tail[n]).OnlyEnforceIf(r[n])
    # the objective: primary * weight + secondary
    n_agents = len(task.agents)
    if objective == "makespan":
        primary: Any = makespan
    elif objective == "idle":
        primary = n_agents * makespan - sum(sum(b) for b in busy.values())
    else:  # workload: the persons' busy time
        primary = sum(sum(busy[a]) for a in task.humans if a in busy)
    secondary: Any = 0
    second_top = 0
    if objective != "makespan":
        secondary, second_top = makespan, big
    if left_shift:
        secondary = secondary + sum(s[h] for h in task.hyperarcs)
        second_top += big * len(task.hyperarcs)
    weight = second_top + 1
    m.Minimize(primary * weight + secondary if second_top else primary)
    if hint is not None:
        _hint(m, hint, x, s, ys, st.now_s)
    solver = cp_model.CpSolver()
    p = solver.parameters
    p.num_workers = max(1, workers)
    if improve:  # improve the hint only: neighbourhood search, workers interleaved (in turn
        # on one thread: deterministic), no proof
        p.num_workers = max(2, workers)
        p.interleave_search = True
        p.use_lns_only = True
    p.random_seed = int(seed)
    if deterministic:
        p.max_deterministic_time = float(time_limit_s)
    else:
        p.max_time_in_seconds = float(time_limit_s)
    t0 = time.perf_counter()
    code = solver.Solve(m)
    spent = time.perf_counter() - t0
    status = {
        cp_model.OPTIMAL: "optimal",
        cp_model.FEASIBLE: "feasible",
        cp_model.INFEASIBLE: "infeasible",
    }.get(code, "unknown")
    raw_bound = solver.BestObjectiveBound()
    # the objective is primary * weight + secondary with 0 <= secondary < weight: a lower bound
    # of the whole, floor-divided by weight, is a lower bound of the (integer) primary
    bound = raw_bound // weight if second_top else raw_bound
    if status not in ("optimal", "feasible"):
        # no schedule in the time, but what CP-SAT proved holds: a bound without a plan
        known = round(bound / MS, 6) if status == "unknown" and math.isfinite(bound) else None
        return Plan(status, None, known, None, spent, goal=objective)
    value = solver.Value(primary) if not isinstance(primary, int) else primary
    if status == "optimal":
        bound = value
    return _extract(
        task, st, solver, objective, status, value, bound, spent, x, s, ys, makespan,
        [(p, v, reach[n], met[n]) for n, z in zs.items() for p, v in z], dvs,
    )  # fmt: skip


def _least_travel(task: Task, a: str, done: set[str]) -> dict[tuple[str, int], int]:
    """Beyond :data:`MAX_CIRCUIT` branches, each of agent ``a``'s branches as short as the
    hand's travel can make it: from where it is now (no change) or from where a branch of
    *another* hyper-arc leaves it (one branch per hyper-arc: never one of its own), the least."""
    table = task.setup[a]
    ends = task.leaves_at.get(a, {})
    places: dict[str, set[Any]] = {}  # hyper-arc -> where its branches leave the hand
    for h, opts in task.options.items():
        if h not in done:
            for o in opts:
                if a in o.agents and ends.get(o.id) is not None:
                    places.setdefault(h, set()).add(ends[o.id])
    out: dict[tuple[str, int], int] = {}
    for h, opts in task.options.items():
        if h in done:
            continue
        before = set().union(*(p for g, p in places.items() if g != h))
        for o in opts:
            if a in o.agents:
                d = min([0, *(table.get((p, o.id), 0) for p in before)])
                if d:
                    out[a, o.id] = d
    return out


def _spans(o: Option) -> dict[str, tuple[int, int]]:
    """Each agent of ``o``: from its first action's start to its last action's end (ms)."""
    out: dict[str, tuple[int, int]] = {}
    for _, agents, off, d in o.steps:
        for a in agents:
            first, last = out.get(a, (off, off + d))
            out[a] = (min(first, off), max(last, off + d))
    return out


def _circuits(
    m: Any,
    task: Task,
    agents: set[str],
    ys: Mapping[str, list[tuple[Option, Any]]],
    s: Mapping[str, Any],
    dvs: Mapping[int, Any],
    least: Mapping[tuple[str, int], int] | None = None,
    hands: Mapping[str, Any] | None = None,
) -> dict[tuple[int, str], list[tuple[Any, Any]]]:
    """Sequence-dependent travel: per agent, the branches it takes part in form one circuit
    from where its hand is now (the depot); a branch right after another starts after it and
    is as much longer or shorter as the hand's travel from where the other left it makes it
    (a joint branch: :func:`_joint_travel`, from what this answers: (option id, agent) -> the
    arcs into the option on the agent's circuit, each with where it leaves the hand)."""
    into: dict[int, list[list[Any]]] = {}  # option id -> per agent: [delta * arc literal]
    circuit_agents: dict[int, set[str]] = {}
    preds: dict[tuple[int, str], list[tuple[Any, Any]]] = {}
    for a in sorted(agents):
        table = task.setup[a]
        nodes = [(o, v) for y in ys.values() for o, v in y if a in o.agents]
        here = (hands or {}).get(a)  # the depot: where the hand is now (None: as simulated)
        if len(nodes) < (1 if here is not None else 2):
            continue
        spans = {o.id: _spans(o)[a] for o, _ in nodes}
        arcs: list[tuple[int, int, Any]] = [(0, 0, m.NewBoolVar(f"idle[{a}]"))]
        terms: dict[int, list[Any]] = {o.id: [] for o, _ in nodes}
        for i, (o, v) in enumerate(nodes, 1):
            arcs.append((i, i, v.Not()))
            first = m.NewBoolVar(f"first[{a}#{o.id}]")
            arcs.append((0, i, first))
            preds.setdefault((o.id, a), []).append((here, first))
            d0 = table.get((here, o.id), 0) if here is not None else 0
            if d0:
                terms[o.id].append(d0 * first)
            arcs.append((i, 0, m.NewBoolVar(f"last[{a}#{o.id}]")))
        for i, (o1, _) in enumerate(nodes, 1):
            place = task.leaves_at.get(a, {}).get(o1.id)
            end1 = s[o1.hyperarc] + spans[o1.id][1] + dvs.get(o1.id, 0)
            for j, (o2, _) in enumerate(nodes, 1):
                if i == j or o1.hyperarc == o2.hyperarc:
                    continue
                lit = m.NewBoolVar(f"next[{a}#{o1.id}>{o2.id}]")
                arcs.append((i, j, lit))
                m.Add(s[o2.hyperarc] + spans[o2.id][0] >= end1).OnlyEnforceIf(lit)
                preds.setdefault((o2.id, a), []).append((place, lit))
                d = table.get((place, o2.id), 0) if place is not None else 0
                if d:
                    terms[o2.id].append(d * lit)
        m.AddCircuit(arcs)
        for oid, ts in terms.items():
            into.setdefault(oid, []).append(ts)
            circuit_agents.setdefault(oid, set()).add(a)
    for y in ys.values():
        for o, v in y:
            dv = dvs.get(o.id)
            if dv is None or o.id in task.joint:  # (a joint branch: _joint_travel)
                continue
            for ts in into.get(o.id, []):
                m.Add(dv >= sum(ts))  # the slowest hand sets a joint action's time
            for a in set(o.agents) - circuit_agents.get(o.id, set()):
                # a hand without a circuit: from where it is now (as simulated), or, beyond
                # MAX_CIRCUIT branches, the least its travel from anywhere can make it
                m.Add(dv >= (least or {}).get((a, o.id), 0)).OnlyEnforceIf(v)
    return preds


def _joint_travel(
    m: Any,
    task: Task,
    st: State,
    ys: Mapping[str, list[tuple[Option, Any]]],
    dvs: Mapping[int, Any],
    preds: Mapping[tuple[int, str], list[tuple[Any, Any]]],
    relaxed: Set[str],
    done: Set[str],
) -> None:
    """A joint branch's travel (:attr:`Task.joint`): from where each of its hands is when it
    starts — on a circuit, where the branch before it on that agent's circuit left it (one
    literal per place); at a decision without a circuit, where the hand is now; relaxed
    (beyond the circuits' limit), the quickest of where a branch of another hyper-arc or the
    start leaves it; else the start — the least delta over what is left open."""
    for y in ys.values():
        for o, v in y:
            dv = dvs.get(o.id)
            if dv is None or o.id not in task.joint:
                continue
            moving, deltas = task.joint[o.id]
            if deltas is None:  # too many places: left open (dv's domain)
                continue
            known = {a: {c[i] for c in deltas} for i, a in enumerate(moving)}

            def norm(a: str, p: Any, known: dict[str, set[Any]] = known) -> Any:
                return p if p in known[a] else None

            fixed: list[list[tuple[Any, Any]]] = []  # per agent: (place, literal or None)
            for a in moving:
                arcs = preds.get((o.id, a))
                if arcs:
                    by_place: dict[Any, list[Any]] = {}
                    for place, lit in arcs:
                        by_place.setdefault(norm(a, place), []).append(lit)
                    choice = []
                    for place, lits in sorted(by_place.items(), key=lambda kv: repr(kv[0])):
                        if len(lits) == 1:
                            q = lits[0]
                        else:
                            q = m.NewBoolVar(f"from[{a}#{o.id}]")
                            m.Add(sum(lits) == q)  # (at most one arc into a node is taken)
                        choice.append((place, q))
                    fixed.append(choice)
                elif a in st.hands:
                    fixed.append([(norm(a, st.hands[a]), None)])
                elif a in relaxed:
                    places = {
                        norm(a, task.leaves_at.get(a, {}).get(g.id))
                        for h, gs in task.options.items()
                        if h not in done and h != o.hyperarc
                        for g in gs
                        if a in g.agents
                    }
                    fixed.append([(p, None) for p in sorted(places | {None}, key=repr)])
                else:
                    fixed.append([(None, None)])
            # per combination of the circuits' places: the least over the places left open
            best: dict[tuple[int, ...], int] = {}
            for combo in itertools.product(*(range(len(c)) for c in fixed)):
                key = tuple(k for i, k in enumerate(combo) if fixed[i][k][1] is not None)
                d = deltas.get(tuple(fixed[i][k][0] for i, k in enumerate(combo)), 0)
                best[key] = min(best.get(key, d), d)
            circuits = [i for i, c in enumerate(fixed) if c[0][1] is not None]
            floor = min(best.values())  # the least of all: one constraint (dv's domain may
            m.Add(dv >= floor).OnlyEnforceIf(v)  # go lower: it has every place's delta)
            for key, d in best.items():
                if d > floor:
                    lits = [fixed[i][k][1] for i, k in zip(circuits, key, strict=True)]
                    m.Add(dv >= d).OnlyEnforceIf([*lits, v])
            # and, linear (what the LP relaxation sees): per circuit agent, the least delta
            # its hand's place allows whatever the others' are
            for j, i in enumerate(circuits):
                least_at: dict[int, int] = {}
                for key, d in best.items():
                    least_at[key[j]] = min(least_at.get(key[j], d), d)
                terms = [d * fixed[i][k][1] for k, d in least_at.items() if d]
                if terms:
                    m.Add(dv >= sum(terms))


def _bounds(
    task: Task,
    st: State,
    ys: Mapping[str, list[tuple[Option, Any]]],
    delta_of: Mapping[int, list[int]],
) -> tuple[dict[str, int], dict[str, int]]:
    """Lower bounds (ms): ``head[n]`` the earliest node n can be met, ``tail[n]`` the least
    time from n met to the goal met (shortest allowed branch of each hyper-arc, one round of a
    process that ends itself; hyper-arcs running or solved count as they stand)."""
    shortest: dict[str, int] = {}
    for h in task.hyperarcs:
        if h in st.solved:
            shortest[h] = 0
        elif h in st.running:
            shortest[h] = st.running[h][1]
        elif h in ys:  # (a hand's travel from elsewhere may save time: the least it can take)
            shortest[h] = min(o.duration + min([0, *delta_of.get(o.id, ())]) for o, _ in ys[h])
    held = {
        n: min(p.round_ms for p in ps) if not any(p.until for p in ps) else 0
        for n, ps in task.processes.items()
    }
    head: dict[str, int] = {}

    def met_lb(n: str, depth: int = 0) -> int:
        if n in head:
            return head[n]
        if n in st.met or depth > len(task.nodes):
            return 0
        into = [h for h in task.incoming[n] if h in shortest]
        best = 0
        up = task.activated_by.get(n)
        if up is not None and up not in st.solved and up not in st.running and up in shortest:
            # a lower instance's leaf: not before the instance is active
            best = max([0, *(met_lb(c, depth + 1) for c in task.children[up])])
        if into:
            best = min(
                (
                    met_lb(task.lower[h], depth + 1)  # done by its lower instance
                    if h in task.lower and h not in st.solved
                    else 0
                    if h in st.running
                    else max([0, *(met_lb(c, depth + 1) for c in task.children[h])])
                )
                + shortest[h]
                for h in into
            )
        head[n] = best + (held.get(n, 0) if n not in st.process_running else 0)
        return head[n]

    for n in task.nodes:
        met_lb(n)
    consumers: dict[str, list[str]] = {n: [] for n in task.nodes}
    for h in task.hyperarcs:
        if h in shortest and h not in st.solved:
            for c in task.children[h]:
                consumers[c].append(h)
            if h in task.lower:  # its instance's root met: h is solved (eq. 18)
                consumers[task.lower[h]].append(h)
    tail: dict[str, int] = {task.root: 0}

    def tail_of(n: str, depth: int = 0) -> int | None:
        if n in tail:
            return tail[n]
        if depth > len(task.nodes):
            return None
        found = []
        for h in consumers[n]:
            p = task.parent[h]
            rest = tail_of(p, depth + 1)
            if rest is not None:
                found.append(shortest[h] + held.get(p, 0) + rest)
        if not found:
            return None
        tail[n] = min(found)
        return tail[n]

    for n in task.nodes:
        tail_of(n)
    return head, tail


def _leaf(
    m: Any,
    task: Task,
    n: str,
    r: Mapping[str, Any],
    reach: Mapping[str, Any],
    x: Mapping[str, Any],
    e: Mapping[str, Any],
    ys: Mapping[str, list[tuple[Option, Any]]],
    facts: frozenset[Fact] | None,
    active: Any = 0,
) -> None:
    """A leaf node: it holds now (reached at 0) or when taken branches add what it misses;
    a lower instance's leaf not before ``active`` (the instance is active: the start of the
    hyper-arc that calls it, eq. 17)."""
    formula = task.formula[n]
    now = facts if facts is not None else frozenset()
    if not formula or holds(formula, now):
        m.Add(reach[n] == active)
        return
    missing = [
        lit.key() for lit in formula if lit.is_ground and not lit.negated and lit.key() not in now
    ]
    if not missing:  # (an open formula that does not hold: assume it holds when needed)
        m.Add(reach[n] == active)
        return
    m.Add(reach[n] >= active)
    for f in missing:
        makers = [(h, v) for h, y in ys.items() for o, v in y if f in o.adds]
        if not makers:
            m.Add(r[n] == 0)
            return
        m.AddBoolOr([v for _, v in makers]).OnlyEnforceIf(r[n])
        for h, v in makers:
            m.Add(reach[n] >= e[h]).OnlyEnforceIf(v)


def _process(
    m: Any,
    task: Task,
    st: State,
    n: str,
    r: Mapping[str, Any],
    reach: Mapping[str, Any],
    met: Mapping[str, Any],
    e: Mapping[str, Any],
    ys: Mapping[str, list[tuple[Option, Any]]],
    lanes: dict[str, list[Any]],
    busy: dict[str, list[Any]],
    big: int,
) -> list[tuple[ProcessOption, Any]]:
    """Node ``n``'s process P(n) on one option's agents, from reaching to meeting: until its
    ``until`` facts are added (the process is stopped then), or one round when the round
    itself makes them true; no process: met when reached."""
    opts = [p for p in task.processes.get(n, []) if not any(a in st.unavailable for a in p.agents)]
    if n in st.process_running:
        agents, end = st.process_running[n]
        m.Add(met[n] >= end)
        m.Add(met[n] >= reach[n])
        until = next((p.until for p in opts if p.agents == agents), ())
        _until(m, met, n, until, e, ys)
        return []
    if not opts:
        m.Add(met[n] == reach[n])
        return []
    if any(p.until for p in opts):
        # it runs until its end condition holds (stopped then, mid-round): met when the last
        # branch that adds an ``until`` fact ends (_until), not before it is reached
        m.Add(met[n] >= reach[n])
    else:  # its own round makes the end condition true: one round
        m.Add(met[n] == reach[n] + max(p.round_ms for p in opts)).OnlyEnforceIf(r[n])
    z = [(p, m.NewBoolVar(f"z[{n}#{i}]")) for i, p in enumerate(opts)]
    m.Add(sum(v for _, v in z) == r[n])
    size = m.NewIntVar(0, big, f"hold[{n}]")
    m.Add(size == met[n] - reach[n])
    for p, v in z:
        for a in p.agents:
            iv = m.NewOptionalIntervalVar(reach[n], size, met[n], v, f"{p.action}@{a}")
            lanes[a].append(iv)
            busy[a].append(_held(m, size, v, big, f"held[{n}@{a}]"))
        _until(m, met, n, p.until, e, ys)
    return z


def _held(m: Any, size: Any, v: Any, big: int, name: str) -> Any:
    """An agent's busy time in a block: ``size`` when ``v`` (its option is taken), else 0."""
    held = m.NewIntVar(0, big, name)
    m.Add(held == size).OnlyEnforceIf(v)
    m.Add(held == 0).OnlyEnforceIf(v.Not())
    return held


def _until(
    m: Any,
    met: Mapping[str, Any],
    n: str,
    until: Iterable[Fact],
    e: Mapping[str, Any],
    ys: Mapping[str, list[tuple[Option, Any]]],
) -> None:
    for f in until:
        for h, y in ys.items():
            for o, v in y:
                if f in o.adds:
                    m.Add(met[n] >= e[h]).OnlyEnforceIf(v)


def _hint(
    m: Any,
    hint: Plan,
    x: Mapping[str, Any],
    s: Mapping[str, Any],
    ys: Mapping[str, list[tuple[Option, Any]]],
    now_s: float,
) -> None:
    """A warm start from the last plan: its hyper-arcs, their agents and (shifted to now)
    their start times."""
    starts = _first_starts(hint, x)
    for h, (agents, _) in hint.chosen.items():
        if h not in ys:
            continue
        m.AddHint(x[h], 1)
        if h in starts:
            m.AddHint(s[h], max(0, round((starts[h] - now_s) * MS)))
        for o, v in ys[h]:
            m.AddHint(v, 1 if set(o.agents) == set(agents) else 0)


def _first_starts(plan: Plan, among: Container[str]) -> dict[str, float]:
    """When each hyper-arc of ``among`` first starts in ``plan``'s schedule (s)."""
    first: dict[str, float] = {}
    for entry in plan.schedule:
        if entry.hyperarc in among:
            first[entry.hyperarc] = min(first.get(entry.hyperarc, entry.start_s), entry.start_s)
    return first


def _extract(
    task: Task,
    st: State,
    solver: Any,
    objective: str,
    status: str,
    value: int,
    bound: float,
    spent: float,
    x: Mapping[str, Any],
    s: Mapping[str, Any],
    ys: Mapping[str, list[tuple[Option, Any]]],
    makespan: Any,
    processes: Sequence[tuple[ProcessOption, Any, Any, Any]] = (),
    dvs: Mapping[int, Any] | None = None,
) -> Plan:
    now = st.now_s
    dvs = dvs or {}
    schedule: list[PlanEntry] = []
    by_agent = dict.fromkeys(task.agents, 0)
    chosen: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {}
    for h, y in ys.items():
        if not solver.Value(x[h]):
            continue
        o = next(o for o, v in y if solver.Value(v))
        start = solver.Value(s[h])
        chosen[h] = (o.agents, dict(o.grounding))
        for a in o.agents:
            by_agent[a] = by_agent.get(a, 0) + 1
        dv = solver.Value(dvs[o.id]) if o.id in dvs else 0
        for k, (text, agents, off, d) in enumerate(o.steps):
            # the travel a hand saves or adds falls in the option's first action
            a0 = start + off + (dv if k else 0)
            a1 = max(a0, start + off + d + dv)
            t0, t1 = now + a0 / MS, now + a1 / MS
            schedule.append(PlanEntry(text, agents, h, round(t0, 6), round(t1, 6)))
    for p, v, reach, met in processes:  # a node process: the node's name as its hyper-arc
        if solver.Value(v):
            t0, t1 = now + solver.Value(reach) / MS, now + solver.Value(met) / MS
            schedule.append(PlanEntry(p.action, p.agents, p.node, round(t0, 6), round(t1, 6)))
    schedule.sort(key=lambda p: (p.start_s, p.hyperarc, p.end_s))
    return Plan(
        status,
        round(value / MS, 6),
        round(bound / MS, 6),
        round(now + solver.Value(makespan) / MS, 6),
        spent,
        schedule,
        by_agent,
        objective,
        chosen,
    )


# ---------------------------------------------------------------------------- entry points --
class _Reader:
    """What :func:`build_task` reads of a Task Manager — the graph, the domain, the knowledge
    base, the simulator, and each element's children, parent, actions, formula and processes —
    for a scenario no manager runs (only the cell makes a Task Manager: the one loop)."""

    def __init__(self, scenario: Any, simulator: Any) -> None:
        self.graph = scenario.online_graph()
        self.domain = scenario.domain
        self.kb = scenario.world()
        self.simulator = simulator

    def _def(self, name: str) -> tuple[Any, str]:
        return self.graph.definition_of(name), self.graph.local_name(name)

    def _qualified(self, element: str, local: str) -> str:
        prefix = self.graph.graph_of(element)
        return f"{prefix}/{local}" if prefix else local

    def children_of(self, hyperarc: str) -> list[str]:
        g, local = self._def(hyperarc)
        return [self._qualified(hyperarc, c) for c in g.hyperarcs[local].children]

    def parent_of(self, hyperarc: str) -> str:
        g, local = self._def(hyperarc)
        return self._qualified(hyperarc, g.hyperarcs[local].parent)

    def actions_of(self, hyperarc: str) -> tuple[str, ...]:
        g, local = self._def(hyperarc)
        return tuple(g.hyperarcs[local].actions)

    def formula_of(self, node: str) -> tuple[Any, ...]:
        g, local = self._def(node)
        formula = g.nodes[local].formula
        return tuple(formula) if formula is not None else ()

    def processes_of(self, node: str) -> tuple[str, ...]:
        g, local = self._def(node)
        return tuple(g.nodes[local].processes)

    def constraints_of(self, hyperarc: str) -> list[Any]:
        return [lit for c in self.children_of(hyperarc) for lit in self.formula_of(c)]


def _manager(scenario: Any, simulator: Any) -> Any:
    """A read-only view of ``scenario`` as :func:`build_task` reads a Task Manager."""
    return _Reader(scenario, simulator)


def _simulator(scenario: Any, simulator: Any) -> Any:
    """The branch simulator a run of ``scenario`` would use (None: the scenario's choice)."""
    if simulator is None or isinstance(simulator, str):
        if isinstance(simulator, str) and simulator not in SIMULATORS:
            raise FlexhrcError(f"--simulator {simulator!r}: choose one of {', '.join(SIMULATORS)}")
        return scenario.make_simulator(simulator)
    return simulator


def _check(objective: str, time_limit_s: float, human: str | None) -> None:
    if objective not in OBJECTIVES:
        raise FlexhrcError(f"--objective {objective!r}: choose one of {', '.join(OBJECTIVES)}")
    if not (isinstance(time_limit_s, int | float) and 0 < time_limit_s <= 3600):
        raise FlexhrcError(
            f"--time-limit must be a number of seconds in (0, 3600], got {time_limit_s}"
        )
    if human is not None and human not in PROFILES:
        raise FlexhrcError(f"--human {human!r}: choose one of {', '.join(PROFILES)}")


def solve(
    scenario: Any,
    *,
    objective: str = "makespan",
    time_limit_s: float = 10.0,
    simulator: Any = None,
    human: str | None = None,
    seed: int = 0,
    hint: Plan | None = None,
    workers: int = 1,
    travel: bool = False,
    exact_travel: bool = False,
) -> Plan:
    """The optimal plan of ``scenario`` from its start (see the module docstring).

    ``simulator`` ``analytic``, ``kinematic``, a simulator object, or None (the scenario's
    choice, as ``flexhrc run`` makes it); ``human`` an operator profile: the plan is the same
    for every profile (a profile changes what a person does on their own, not what they can
    do); it is checked and kept for the report. ``hint`` warm-starts the solver. ``travel``:
    model the hands' travel from one hyper-arc to the next (:func:`build_task`);
    ``exact_travel`` (implies ``travel``): a circuit for every agent, however many branches it
    has, warm-started (:func:`solve_exact_travel`)."""
    _check(objective, time_limit_s, human)
    _cp_model()  # before the work: a missing extra is one error
    tm = _manager(scenario, _simulator(scenario, simulator))
    task = build_task(tm, travel=travel or exact_travel)
    st = State(facts=tm.kb.facts)
    solver: Callable[..., Plan] = solve_exact_travel if exact_travel else solve_task
    return solver(
        task,
        st,
        objective=objective,
        time_limit_s=time_limit_s,
        seed=seed,
        hint=hint,
        workers=workers,
    )


def solve_exact_travel(
    task: Task,
    st: State,
    *,
    objective: str = "makespan",
    time_limit_s: float = 10.0,
    seed: int = 0,
    hint: Plan | None = None,
    workers: int = 1,
    deterministic: bool = False,
    left_shift: bool = False,
    prove: bool = True,
) -> Plan:
    """The travel model with a circuit for every agent (no relaxation beyond
    :data:`MAX_CIRCUIT`): the exact optimum of the durations model with the hands' travel, or
    a feasible schedule with a proven bound. Circuits of many branches are hard to start from
    nothing (a generated task of 20 actions: 40.298 s found in 60 s, 1 worker), so
    the solve is warm-started: the plan without travel (a quarter of the limit at most), then
    the travel model with that plan's hyper-arcs and agents fixed (a quarter at most; quick:
    only the orders are open) — a feasible schedule of the exact model —, which hints the
    full solve (the rest of the limit); when that finds nothing better, the warm start's
    schedule is answered (status ``feasible``, the full solve's bound). ``prove`` False (the
    lookahead policy's first plan): instead of the full solve, the rest of the limit improves
    the warm start by neighbourhood search only (``solve_task(..., improve=True)``, no
    proof). ``solve_s``: all of it. Every agent within :data:`MAX_CIRCUIT`: the plain travel
    solve (already exact). ``deterministic``, ``left_shift``: as
    :func:`solve_task`'s (deterministic: each stage its share of the limit in the solver's
    deterministic time, none of what is left — a stored run replays with the same plan)."""
    kw: dict[str, Any] = {
        "objective": objective,
        "seed": seed,
        "workers": workers,
        "deterministic": deterministic,
        "left_shift": left_shift,
    }
    if _few_branches(task) or not task.setup:
        return solve_task(task, st, time_limit_s=time_limit_s, hint=hint, **kw)
    t0 = time.perf_counter()
    spent = 0.0  # deterministic: the shares given so far

    def left(share: float = 1.0) -> float:
        nonlocal spent
        if deterministic:
            give = min(share, 1.0 - spent) * time_limit_s
            spent += share
            return max(0.01, give)
        return max(0.01, min(share * time_limit_s, time_limit_s - (time.perf_counter() - t0)))

    start: Plan | None = None  # a schedule of the exact model (the warm start's)
    if hint is None:
        bare = replace(task, leaves_at={}, setup={}, joint={})  # no travel
        plain = solve_task(bare, st, time_limit_s=left(0.25), **kw)
        hint = plain if plain.chosen else None
        if hint is not None:
            fixed = replace(
                st,
                path=set(hint.chosen),
                agents_of={h: agents for h, (agents, _) in hint.chosen.items()},
            )
            found = solve_task(task, fixed, time_limit_s=left(0.25), max_circuit=None, **kw)
            if found.status in ("optimal", "feasible"):
                hint = start = found  # the full solve starts from it
    if not prove and start is not None:
        kw["improve"] = True
    plan = solve_task(task, st, time_limit_s=left(), hint=hint, max_circuit=None, **kw)
    if (
        start is not None
        and start.objective is not None
        and (plan.objective is None or start.objective < plan.objective)
    ):  # (kept the better)
        plan = replace(start, status="feasible", bound=plan.bound)
    plan.solve_s = time.perf_counter() - t0
    return plan


def state_of(tm: TaskManager, now: float, seen: Mapping[int, float] | None = None) -> State:
    """Where the running Task Manager ``tm`` stands at cell time ``now``: solved and met from
    its online graph, running executions with their agents and expected ends, busy agents'
    release times (``seen``: when each command was first seen; else now), what is barred."""
    graph = tm.graph
    seen = seen or {}
    st = State(now_s=now, facts=tm.kb.facts)
    for name in graph.elements():
        kind = graph.kind(name)
        if kind == "hyperarc":
            if graph.is_solved(name):
                st.solved.add(name)
            elif graph.is_blocked(name) or name in tm.infeasible:
                st.infeasible.add(name)
        elif graph.is_met(name):
            st.met.add(name)
    release: dict[str, int] = {}
    for a, cmd in tm.busy.items():
        began = seen.get(cmd.id, now)
        release[a] = max(0, round((began + cmd.expected_s - now) * MS))
    for h, ex in tm.executions.items():
        durations = ex.branch.result.durations if ex.branch.result else []
        if ex.owner == "robot":
            first = ex.next_index + (1 if ex.command is not None else 0)
            t = max([0, *(release.get(a, 0) for a in ex.agents)])
        else:
            first, t = ex.next_index, 0
        t += round(sum(durations[first:]) * MS)
        st.running[h] = (tuple(ex.agents), t)
    for node, run in tm.processes.items():
        agents = tuple(run.command.agents) if run.command is not None else ()
        end = max([0, *(release.get(a, 0) for a in agents)])
        if run.command is not None or run.asked is not None:
            st.process_running[node] = (agents, end)
    st.release = release
    st.unavailable = set(tm.unavailable)
    for h, who in [*tm.declined.items(), *tm.cannot.items()]:
        st.barred.setdefault(h, set()).update(who)
    st.failed = {h: [dict(g) for g in gs] for h, gs in tm.failed.items()}
    return st


def hands_of(tm: TaskManager, task: Task) -> dict[str, Any]:
    """Where each hand of ``task``'s travel tables is when its agent is next free, as a place
    of :attr:`Task.leaves_at`: where the branch it runs leaves it, else where it is now;
    left out where that is no such place (the hand is where it was when the task was made, or
    somewhere the tables do not know: timed as from there)."""
    out: dict[str, Any] = {}
    running: dict[str, Option] = {}
    for h, ex in tm.executions.items():
        grounding = dict(ex.branch.grounding)
        for o in task.options.get(h, ()):
            if set(o.agents) == set(ex.agents) and dict(o.grounding) == grounding:
                for a in o.agents:
                    running[a] = o
                break
    for a, table in task.setup.items():
        places = {p for p, _ in table}
        mine = running.get(a)
        place = task.leaves_at.get(a, {}).get(mine.id) if mine is not None else None
        if place is None and a in tm.kb.objects:
            pos = tuple(tm.kb.position(a))
            place = next(
                (
                    p
                    for p in sorted(places)
                    if max(abs(u - v) for u, v in zip(p, pos, strict=True)) < 1e-6
                ),
                None,
            )
        if place in places:
            out[a] = place
    return out


def solve_remaining(
    tm: TaskManager,
    now: float,
    *,
    task: Task | None = None,
    objective: str = "makespan",
    time_limit_s: float = 0.05,
    seed: int = 0,
    hint: Plan | None = None,
    seen: Mapping[int, float] | None = None,
) -> Plan:
    """The optimal plan of what is left of ``tm``'s task at cell time ``now`` (a decision):
    deterministic solver time, one worker, a fixed seed (a stored run replays identically),
    every hyper-arc as early as the optimum allows; ``hint`` (the last plan) warm-starts it;
    ``task`` the task made once (:func:`build_task`)."""
    task = task if task is not None else build_task(tm)
    st = state_of(tm, now, seen)
    if task.setup:  # the task models travel: each circuit starts where the hand is now
        st.hands = hands_of(tm, task)
    return solve_task(
        task,
        st,
        objective=objective,
        time_limit_s=time_limit_s,
        seed=seed,
        hint=hint,
        deterministic=True,
        left_shift=True,
    )


def hindsight(
    scenario: Any,
    solved: Iterable[Mapping[str, Any]],
    *,
    objective: str = "makespan",
    time_limit_s: float = 10.0,
    simulator: Any = None,
    seed: int = 0,
    travel: bool = False,
) -> Plan:
    """The hindsight optimum of a finished run of ``scenario``: the best schedule of the
    cooperation path the run took (its ``solved_hyperarcs``, as ``flexhrc run --json`` gives
    them: ``{"hyperarc", "agent"}`` with ``agent`` the agents joined by ``+``), the persons
    doing exactly the hyper-arcs they did (with the agents they did them with) and nothing
    else — what the robots could have done around what the person actually did."""
    _check(objective, time_limit_s, None)
    _cp_model()
    tm = _manager(scenario, _simulator(scenario, simulator))
    task = build_task(tm, travel=travel)
    st = State(facts=tm.kb.facts, path=set())
    assert st.path is not None
    for item in solved:
        h = str(item["hyperarc"])
        if h not in task.options:
            raise FlexhrcError(f"hindsight: {h!r} is no hyper-arc of {scenario.name}")
        st.path.add(h)
        agents = tuple(a for a in str(item.get("agent") or "").split("+") if a)
        if any(a in task.humans for a in agents):
            st.agents_of[h] = agents
    st.only_fixed = set(task.humans)
    return solve_task(task, st, objective=objective, time_limit_s=time_limit_s, seed=seed)


# ------------------------------------------------------------------------------ the policy --
def advise_from(policy: Any, tm: TaskManager, now: float) -> Advice | None:
    """The ``lookahead`` advice (:class:`~flexhrc.planning.policies.LookaheadPolicy`): while
    the cell follows the last plan (only the hyper-arcs it chose were started, with its agents,
    and solved; nothing failed, declined, given up or lost) the plan is kept and each agent's
    hyper-arcs start in its order, as soon as the ones it planned before them on the same
    agents are solved; on any deviation the remaining task is re-solved and the hyper-arcs the
    new schedule starts now are advised with their agents, the others held back."""
    travel_task: Task | None = None
    if policy.task is None:
        task = build_task(tm)
        if policy.travel and (_few_branches(task) or policy.first_time_limit_s > 0):
            travel_task = replace(task)
            travel = _travel(task.options, tm.kb, tm.domain, tm.simulator)
            travel_task.leaves_at, travel_task.setup, travel_task.joint = travel
            if _few_branches(task):  # every decision plans the travel: circuits, quick
                task, travel_task = travel_task, None
        policy.task = task
    for cmd in tm.busy.values():
        policy.seen.setdefault(cmd.id, now)
    key = _key(tm)
    if key == policy.key:
        return policy.advice
    if travel_task is not None:  # the first plan: the hands' travel for every agent
        st = state_of(tm, now, policy.seen)
        st.hands = hands_of(tm, travel_task)
        plan = solve_exact_travel(
            travel_task,
            st,
            time_limit_s=policy.first_time_limit_s,
            seed=policy.seed,
            deterministic=True,
            left_shift=True,
            prove=False,
        )
        policy.solves += 1
        if plan.status in ("optimal", "feasible"):
            policy.key = policy.base = key
            policy.last = policy.first = plan
            policy.advice = _advice(plan, tm, now, in_order=False)
            return policy.advice
    last = policy.last
    keep = last is not None and (last.status == "optimal" or last is policy.first)
    if keep and _follows(last, policy.base, key, tm):
        advice = _advice(last, tm, now, in_order=True)
        if advice.start or tm.executions:
            policy.key = key
            policy.advice = advice
            policy.reused += 1
            return advice
    plan = solve_remaining(
        tm,
        now,
        task=policy.task,
        time_limit_s=policy.time_limit_s,
        seed=policy.seed,
        hint=policy.last,
        seen=policy.seen,
    )
    policy.solves += 1
    policy.key = policy.base = key
    if plan.status not in ("optimal", "feasible"):
        policy.fallbacks += 1
        policy.advice = None
        policy.last = None
        return None
    policy.last = plan
    policy.advice = _advice(plan, tm, now, in_order=False)
    return policy.advice


def _few_branches(task: Task) -> bool:
    """Whether every agent takes part in at most :data:`MAX_CIRCUIT` branches (travel is then
    modelled exactly, by circuits, and a decision's solve stays quick)."""
    return max(_branch_counts(task).values(), default=0) <= MAX_CIRCUIT


def _branch_counts(task: Task, done: Set[str] = frozenset()) -> dict[str, int]:
    """How many branches of the hyper-arcs not ``done`` each agent takes part in."""
    count: dict[str, int] = {}
    for h, opts in task.options.items():
        if h not in done:
            for o in opts:
                for a in o.agents:
                    count[a] = count.get(a, 0) + 1
    return count


def _follows(plan: Plan, base: Any, key: tuple[Any, ...], tm: TaskManager) -> bool:
    """Whether the cell went on as ``plan`` (solved at key ``base``) says: the same things
    given up, failed, declined, impossible and away; every hyper-arc running or solved since
    is one the plan chose, with the plan's agents."""
    if base is None or key[3:8] != base[3:8]:
        return False
    for h, ex in tm.executions.items():
        if h not in plan.chosen or set(plan.chosen[h][0]) != set(ex.agents):
            return False
    for node, run in tm.processes.items():  # a node process on the plan's agents
        agents = set(run.command.agents) if run.command is not None else set()
        planned = [set(e.agents) for e in plan.schedule if e.hyperarc == node]
        if agents and planned and agents not in planned:
            return False
    solved = key[8]  # the hyper-arcs solved now (_key)
    return all(h in plan.chosen or h in base[8] for h in solved)


def _advice(plan: Plan, tm: TaskManager, now: float, *, in_order: bool) -> Advice:
    """The advice of ``plan``: the feasible hyper-arcs it starts now (``in_order``: those whose
    predecessors on their agents in the plan are all solved), the other feasible ones held."""
    feasible = tm.feasible_hyperarcs()
    first = _first_starts(plan, plan.chosen)
    eps = 1e-3
    graph = tm.graph

    def ready(h: str, t: float) -> bool:
        if h not in feasible or h in tm.executions:
            return False
        if not in_order:
            return t <= now + eps
        agents = set(plan.chosen[h][0])
        return all(
            graph.is_solved(g)
            for g, tg in first.items()
            if g != h and tg < t and agents & set(plan.chosen[g][0])
        )

    starts = tuple(
        Start(h, plan.chosen[h][0], _objects(tm, plan.chosen[h][1]))
        for h, t in sorted(first.items(), key=lambda kv: (kv[1], kv[0]))
        if ready(h, t)
    )
    hold = frozenset(h for h in feasible if h not in {s.element for s in starts})
    return Advice(starts, hold)


def _objects(tm: TaskManager, grounding: Mapping[str, str]) -> dict[str, str]:
    return {k: v for k, v in grounding.items() if v not in tm.domain.agents}


def _key(tm: TaskManager) -> tuple[Any, ...]:
    """What a re-plan depends on: the graph's answer, the executions and their progress, the
    processes, what is barred and who is away (not the clock: a step of a running hyper-arc
    ending as planned changes nothing)."""
    return (
        tm.graph.queries,
        tuple(
            sorted(
                (h, ex.next_index if ex.owner == "human" else -1, ex.agents)
                for h, ex in tm.executions.items()
            )
        ),
        tuple(sorted((n, r.index, r.command is not None) for n, r in tm.processes.items())),
        tuple(sorted(tm.infeasible)),
        tuple(sorted((h, len(g)) for h, g in tm.failed.items())),
        tuple(sorted(tm.unavailable)),
        tuple(sorted((h, tuple(sorted(w))) for h, w in tm.declined.items())),
        tuple(sorted((h, tuple(sorted(w))) for h, w in tm.cannot.items())),
        frozenset(
            h
            for h in tm.graph.elements()
            if tm.graph.kind(h) == "hyperarc" and tm.graph.is_solved(h)
        ),
    )
