"""The Task Manager (paper 000, section V): from feasible elements to commands and suggestions.

The manager is sans-IO: it never sleeps, never talks to a robot. It is driven by three calls,
each returning the :class:`Directive` objects the caller must carry out:

* :meth:`TaskManager.start` — the first decisions;
* :meth:`TaskManager.on_ack` — a robot command finished: ``done``, ``failed`` or ``timed_out``;
* :meth:`TaskManager.on_human_action` — a human action was recognised (done).

The loop of a decision (``_plan``):

1. meet every feasible node whose state formula holds in the knowledge base (a query to the
   AND/OR graph), refresh the :class:`ActionStateTable`;
2. take the cheapest feasible hyper-arc that no running element conflicts with; build its
   :class:`DecisionTree` (groundings x agents), simulate every branch, keep the best by eq. (21);
3. if every branch scores 0, that grounding is infeasible: when no grounding is left the element
   is marked infeasible in the graph and the next cheapest is tried;
4. the best branch's first action goes to its robot arm (:class:`Command`), or — when a person
   is needed for it or strictly best at it — to the person as a :class:`Suggest`. Ties go to the
   arms, and a step that an arm busy now would do as well waits for that arm rather than going
   to whoever is free (the tree of eq. 21 ranges over every capable agent, paper Fig. 2); an
   operator who acts on their own may take it meanwhile.

Section V in full:

* **preconditions** ``pre(a)`` (eq. 20) are checked when a decision tree is built (a branch that
  fails is pruned and the decision event carries its reason) and again at dispatch, against the
  knowledge base as it is then (a failing step aborts the execution, its grounding is excluded,
  the manager re-plans);
* **the substitution chosen for a hyper-arc carries to its parent's state formula**: the parent
  is met only when ``S(parent)`` holds under that grounding, and the grounding is kept as the
  node's binding, so a hyper-arc leaving that node starts from the same objects;
* **groundings pass through the hierarchy** (section IV-B, eqs. 15-16): when a hyper-arc's
  lower instance becomes active, the hyper-arc's grounding (its children's bindings, the
  variables they leave open bound in the knowledge base as it is then) binds the lower
  variables its transition maps (M1) in every formula and action of that instance; when the
  lower root is met, its grounding binds the variables of the hyper-arc's parent that M2 maps
  (:class:`flexhrc.representation.hierarchy.Transfer`);
* **node processes** ``P(n)`` (eq. 5): when n is reached (its formula holds) its processes are
  activated in order — behaviours declared under ``processes:`` in the domain, each a
  :class:`Command` that keeps its agents busy, round after round (a round ends when the
  behaviour's own condition holds, e.g. the held object back at its pose and still), until its
  ``until`` condition holds, whoever made it true; n is met when its last process has ended (the
  text after eq. 5). Each process has a **priority**: when two want one arm, the larger wins —
  it waits for nobody, a running process of lower priority is stopped for it (and resumes when
  the arm is free again). A process the domain lets a **person** run (``agents: human``) is
  asked of them as a :class:`Suggest` of the node; their report of it ends a round, and the
  process ends when ``until`` holds (e.g. they hold the housing while the robot fastens it);
* **joint actions** (``agents: {joint: [left, right]}``) are one command for several arms;
* an **unsuggested human action** is matched against the *whole* action list of every feasible
  hyper-arc: it may be any action of A(h) whose earlier actions' effects already hold; the
  binding it gives must ground the whole list (every later action and the children's formulas);
* the **reaction** to it: ``reaction="conflicts"`` stops only robot executions that share a
  child node or an object with what the human does; ``reaction="paper"`` (paper V-B) stops every
  robot action and sends every arm to rest, then re-plans.
* the **failure policy** (``on_failure``) after a robot action fails or times out:
  ``"retry"`` (the default) excludes only that grounding and decides the same hyper-arc again
  with the groundings left (another leg, another arm); ``"paper"`` (paper V-A, the example of
  Fig. 2) marks the hyper-arc infeasible and moves to the next feasible state of least cost — if
  no feasible element is left, the cooperation fails. Either way the arms stop and rest first. A
  command of an agent that left the cell (:meth:`TaskManager.set_available`) is no failure of
  the hyper-arc: its grounding is excluded as under ``retry``.

The cooperation ends ``solved`` (the root is met) or ``failed`` with a reason (no feasible
element left). The manager is deterministic given its inputs (``start``, acks, human actions,
percepts applied to the knowledge base between calls) and keeps no clock of its own.
"""

from __future__ import annotations

import copy
import itertools
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.events import FAILURE_POLICIES, LogEventType
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import Literal, Substitution, apply_substitution, is_variable
from flexhrc.representation import OnlineGraph, Transfer, qualify, split_qualified
from flexhrc.taskmanager.decision import (
    ActionStateTable,
    Branch,
    DecisionTree,
    holds,
    unmet_precondition,
)
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.kinds import action_targets
from flexhrc.taskmanager.policy import Advice, Policy, Start
from flexhrc.taskmanager.simulator import Simulator, default_simulator
from flexhrc.taskmanager.utility import Utility

REACTIONS = ("conflicts", "paper")


# ----------------------------------------------------------------------------- directives --
class TakeRefused(FlexhrcError):
    """An operator cannot take that hyper-arc now (:meth:`TaskManager.operator_takes`); nothing
    changed. ``kind``: ``unknown`` (no such element), ``invalid`` (not a hyper-arc) or
    ``conflict`` (not possible in the current state)."""

    def __init__(self, message: str, kind: str = "conflict"):
        super().__init__(message)
        self.kind = kind


@dataclass
class Command:
    """Execute one ground action (robot agents)."""

    id: int
    agents: tuple[str, ...]
    action: GroundAction
    element: str | None  # hyper-arc (or node, for a process) it belongs to; None: a lone 'rest'
    index: int
    expected_s: float
    process: bool = False  # a round of a node process P(n), not an action of A(h)

    def to_dict(self) -> dict[str, Any]:
        d = {
            "type": "command",
            "id": self.id,
            "agents": list(self.agents),
            "action": str(self.action),
            "element": self.element,
            "index": self.index,
            "expected_s": round(self.expected_s, 6),
        }
        if self.process:
            d["process"] = True
        return d


@dataclass
class Suggest:
    """Ask the human to carry out an element's actions."""

    element: str
    actions: list[GroundAction]
    cost: float

    @property
    def agents(self) -> tuple[str, ...]:
        """The human(s) asked (several operators: the one the branch chose)."""
        return tuple(dict.fromkeys(name for a in self.actions for name in a.agents))

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "suggestion",
            "element": self.element,
            "agents": list(self.agents),
            "actions": [str(a) for a in self.actions],
            "cost": self.cost,
        }


@dataclass
class Stop:
    """Stop an agent's current command at once."""

    agent: str
    command_id: int
    reason: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "stop",
            "agent": self.agent,
            "command": self.command_id,
            "reason": self.reason,
        }


Directive = Command | Suggest | Stop
#: A graph answer with what the manager reads of it at every step: its feasible elements, its
#: feasible hyper-arcs as (cost, element id, name) cheapest first, its feasible nodes.
_AnswerViews = tuple[Any, dict[str, float], list[tuple[float, int, str]], list[str]]


@dataclass
class Ack:
    command_id: int
    status: str  # done | failed | timed_out
    reason: str | None = None


@dataclass
class HumanAction:
    """A recognised (completed) human action, e.g. ``pick_up(human, leg2)``."""

    name: str
    args: tuple[str, ...]

    def __str__(self) -> str:
        return f"{self.name}({', '.join(self.args)})"


@dataclass
class ProcessRun:
    """The processes P(n) of one reached node, run in order (eq. 5)."""

    node: str
    invocations: tuple[str, ...]
    binding: dict[str, str]
    index: int = 0  # the process running or waiting for its agents
    command: Command | None = None
    rounds: int = 0
    failures: int = 0
    asked: GroundAction | None = None  # a person's round asked for (a Suggest), not reported yet

    @property
    def ended(self) -> bool:
        return self.index >= len(self.invocations)


@dataclass
class Execution:
    """An element being carried out with the grounding and agents of its chosen branch."""

    element: str
    branch: Branch
    owner: str  # "robot" or "human"
    next_index: int = 0
    command: Command | None = None
    objects: set[str] = field(default_factory=set)  # KB objects its grounding uses

    @property
    def agents(self) -> tuple[str, ...]:
        return self.branch.agents


@dataclass
class ComputeTiming:
    """Wall-clock compute per module (paper Table I)."""

    task_manager_s: float = 0.0
    task_representation_s: float = 0.0
    simulator_s: float = 0.0


# --------------------------------------------------------------------------- the manager --
class TaskManager:
    def __init__(
        self,
        graph: OnlineGraph,
        domain: Domain,
        kb: KnowledgeBase,
        simulator: Simulator | None = None,
        *,
        log: Callable[[dict[str, Any]], None] | None = None,
        timer: Callable[[], float] = time.perf_counter,
        reaction: str = "conflicts",
        max_process_rounds: int = 1000,
        on_failure: str = "retry",
        utility: Utility | None = None,
        policy: Policy | None = None,
    ):
        if reaction not in REACTIONS:
            raise FlexhrcError(
                f"unknown reaction {reaction!r}; choose one of {', '.join(REACTIONS)}"
            )
        self.reaction = reaction
        self.on_failure = check_failure_policy(on_failure)
        self.max_process_rounds = max_process_rounds
        # the scenario's ``utility:``; None: eq. (21) as the paper has it, no terms logged
        self.utility = utility
        # an advisor asked at each decision (:mod:`.policy`); None: the paper's decision alone
        self.policy = policy
        #: the advisor's latency at each decision it was asked (seconds of compute)
        self.advice_s: list[float] = []
        # each person's effort-weighted busy time the manager gave them (workload term)
        self.person_time: dict[str, float] = {}
        self.graph = graph
        self.domain = domain
        self.kb = kb
        # default: the kinematic simulator when the sim extra is installed (paper V-A)
        self.simulator = simulator if simulator is not None else default_simulator()
        self.table = ActionStateTable()
        self.timing = ComputeTiming()
        self.decisions = 0
        self.branches_simulated = 0
        self.outcome = "running"
        self.reason: str | None = None
        self._log = log or (lambda ev: None)
        self._timer = timer
        self._now = 0.0
        self._ids = itertools.count(1)
        self.executions: dict[str, Execution] = {}  # element -> execution
        self.busy: dict[str, Command] = {}  # agent -> its running command
        self.failed: dict[str, list[dict[str, str]]] = {}  # element -> failed groundings
        self.infeasible: dict[str, str] = {}  # element -> why it was marked infeasible
        self.waiting_for_consistency = False
        self.unavailable: set[str] = set()  # agents that left the cell (e.g. a dead process)
        # node -> the substitution its producing hyper-arc was solved with (carried to S(n))
        self.bindings: dict[str, Substitution] = {}
        self.processes: dict[str, ProcessRun] = {}  # reached nodes whose P(n) is running
        self._process_of: dict[int, str] = {}  # command id -> node of that process
        # (person, process) of persons' processes that ended before the person said so
        self._let_go: set[tuple[str, str]] = set()
        self._extra: list[Directive] = []  # directives raised deep inside (process stops)
        self._answer = graph.query()
        self._answer_views: _AnswerViews | None = None  # see _feasible
        # what the graph's definitions say of an element (fixed): read at every step
        self._described: dict[str, tuple[str, tuple[str, ...]]] = {}
        self._children_of: dict[str, list[str]] = {}
        self._parent_of: dict[str, str] = {}
        self._constraints_of: dict[str, list[Literal]] = {}
        nodes = list(self._node_definitions())
        self._formulas: dict[str, tuple[Literal, ...]] = {
            name: node.formula if node.formula is not None else () for name, node in nodes
        }
        self._node_processes = {name: tuple(n.processes) for name, n in nodes if n.processes}
        # groundings through the hierarchy (M1/M2): instance path -> (its transfer, the upper
        # hyper-arc that created it), only where something passes (empty: a single graph)
        self._transfers: dict[str, tuple[Transfer, str]] = {}
        self._lower_roots: dict[str, str] = {}  # root of such an instance -> its path
        self._scopes: dict[str, Substitution] = {}  # instance path -> its binding (made once)
        self._sigmas: dict[str, Substitution] = {}  # upper hyper-arc -> its grounding
        self._instance_of: dict[str, str] = {}  # element -> its instance path (kept)
        self._collect_transfers()
        # operator answers (docs/protocol.md, "Operator answers"): hyper-arc -> persons who
        # said "not now" (until the cooperation moves on) or "I can't do this" (for the run)
        self.declined: dict[str, set[str]] = {}
        self.cannot: dict[str, set[str]] = {}

    # -- public API -----------------------------------------------------------------------
    def start(self, now: float = 0.0) -> list[Directive]:
        return self._entry(now, self._plan)

    def on_ack(self, now: float, ack: Ack) -> list[Directive]:
        if ack.status == "done":
            self.declined.clear()  # the cooperation moved on: a "not now" may be asked again
        return self._entry(now, lambda: self._handle_ack(ack))

    def on_human_action(self, now: float, action: HumanAction) -> list[Directive]:
        self.declined.clear()
        return self._entry(now, lambda: self._handle_human(action))

    def operator_replies(
        self, now: float, human: str, element: str, reply: str, reason: str | None = None
    ) -> list[Directive]:
        """A person answers what they were asked to do, or had taken (``docs/protocol.md``,
        "Operator answers"). ``decline`` ("not now") and ``give_back``: the person's execution
        of ``element`` ends and the step goes back to the pool; the manager may give it to an
        arm that can do it, or ask the person again once the cooperation has moved on (an
        ack or a report; at once when nothing else is left to wait for). ``cannot`` ("I can't
        do this"): the same, and the hyper-arc is never offered to that person again in this
        run (its reason goes into the log). The decision of eq. (21) then ranges over the
        agents left (paper 000, V-A)."""
        if reply not in ("decline", "give_back", "cannot"):
            raise FlexhrcError(f"unknown operator reply {reply!r}")

        def body() -> list[Directive]:
            ex = self.executions.get(element)
            if ex is not None and ex.owner == "human" and human in ex.agents:
                del self.executions[element]
                row = self.table.rows.get(element)
                if row is not None and row.status == "running":
                    row.status = "feasible"
            (self.cannot if reply == "cannot" else self.declined).setdefault(element, set()).add(
                human
            )
            self._emit("human_declined", agent=human, element=element, reply=reply, reason=reason)
            return self._plan()

        return self._entry(now, body)

    def _excluded(self, element: str) -> set[str]:
        """The persons who may not be asked to do ``element`` now (declined or cannot)."""
        return self.declined.get(element, set()) | self.cannot.get(element, set())

    def on_percept(
        self, now: float, moved: Iterable[str] = (), retracted: Iterable[HumanAction] = ()
    ) -> list[Directive]:
        """Perception changed the knowledge base: ``moved`` objects are not where the running
        branches were simulated with, so robot elements using them stop and are re-planned
        (validity checking, paper 002); human reports found false (``retracted``) drop the
        human element they started. Then decide again (the base may be consistent again)."""
        return self._entry(now, lambda: self._handle_percept(set(moved), list(retracted)))

    def replan(self, now: float) -> list[Directive]:
        """Decide again (e.g. after the knowledge base became consistent)."""
        return self._entry(now, self._plan)

    def set_available(self, now: float, agent: str, available: bool) -> list[Directive]:
        """An agent left the cell (its process died) or came back: decide without it / with it.

        A command it was running is not failed here: the caller acknowledges it as failed
        (reason ``agent lost``), so the failure is an input like any other."""
        self.domain.agent(agent)  # an unknown name is an error
        if available:
            self.unavailable.discard(agent)
        else:
            self.unavailable.add(agent)
        self._emit("agent_available" if available else "agent_unavailable", agent=agent)
        return self._entry(now, self._plan)

    def operator_takes(
        self, now: float, element: str, *, record: bool = True, agent: str | None = None
    ) -> list[Directive]:
        """A person says they *will* do the feasible hyper-arc ``element`` (a panel's "I'll do
        this"): the robots leave that part as when an unsuggested human action is recognised
        (paper 000, V-C: every robot execution sharing a child or an object with it is aborted),
        and its actions, grounded for the operators by a decision tree (eq. 21), are suggested
        to them. Raises :class:`TakeRefused` — before anything changes — when it is not a
        feasible hyper-arc an operator can do now (:meth:`check_take`). ``record`` False: no
        ``taken`` event (the caller records the operator's own decision its way). ``agent``: the
        person who takes it (None: the best operator by eq. 21, as a panel with one person)."""
        tree, cost = self.check_take(element, agent)

        def body() -> list[Directive]:
            best = tree.evaluate(self.simulator, self.kb, self.domain) or tree.branches[0]
            out: list[Directive] = []
            objects = {k: v for k, v in best.grounding.items() if v not in self.domain.agents}
            self._take_over(element, best, objects, out)  # the robot leaves that part
            if record:
                self._emit("taken", element=element, grounding=dict(best.grounding))
            self._launch(element, best, cost, out)
            out += self._plan()
            return out

        return self._entry(now, body)

    def advances(self, now: float, action: HumanAction) -> bool:
        """Would the human ``action`` advance a feasible part of the task now (a recognised
        step, not ``human_action_unmatched``)? Tried on a copy of this manager (sharing the
        simulator and the domain): nothing here changes and nothing is logged — a panel asks
        before it stores a person's report."""
        events: list[dict[str, Any]] = []
        self._twin(events.append).on_human_action(now, action)
        return not any(ev.get("type") == "human_action_unmatched" for ev in events)

    def what_if(
        self, now: float, *, action: HumanAction | None = None, take: str | None = None
    ) -> tuple[list[Command], TaskManager]:
        """What the robots would be told if a person did ``action`` now — or took the hyper-arc
        ``take`` and did its steps — tried on a copy of this manager, as :meth:`advances`
        does: nothing here changes and nothing is logged (the operator station's "what if I
        do this?"). Returns the robot commands the copy issued, in order, and the copy (its
        ``busy`` arms and their executions' simulated branches say what each arm does then).
        A take that is not possible raises :class:`TakeRefused`, as :meth:`operator_takes`."""
        if (action is None) == (take is None):
            raise FlexhrcError("what_if: give exactly one of action= or take=")
        twin = self._twin(lambda event: None)
        out: list[Directive] = []
        if take is not None:
            out += twin.operator_takes(now, take, record=False)
            ex = twin.executions.get(take)
            for step in list(ex.branch.steps) if ex is not None else []:
                out += twin.on_human_action(now, HumanAction(step.name, step.args))
        elif action is not None:
            out += twin.on_human_action(now, action)
        return [d for d in out if isinstance(d, Command)], twin

    def _twin(self, log: Callable[[dict[str, Any]], None]) -> TaskManager:
        """A copy of this manager that shares its simulator and domain and logs to ``log``."""
        memo: dict[int, Any] = {
            id(self.simulator): self.simulator,
            id(self.domain): self.domain,
            id(self._log): log,
        }
        return copy.deepcopy(self, memo)

    def check_take(self, element: str, agent: str | None = None) -> tuple[DecisionTree, float]:
        """Whether an operator (``agent``, when given) can take ``element`` now: its operators'
        decision tree and its cost, or :class:`TakeRefused` saying why not. Changes nothing."""
        try:
            kind = self.graph.kind(element)
        except KeyError:
            raise TakeRefused(f"unknown hyper-arc {element!r}", "unknown") from None
        if self.done:
            raise TakeRefused(f"the cooperation has ended ({self.outcome})")
        if kind != "hyperarc":
            raise TakeRefused(f"{element!r} is a node; take a hyper-arc", "invalid")
        feasible = self.feasible_hyperarcs()
        if element not in feasible:
            raise TakeRefused(f"{element!r} is not feasible now")
        ex = self.executions.get(element)
        if ex is not None and ex.owner == "human":
            raise TakeRefused(f"{element!r} is already the operator's")
        if not self.actions_of(element):
            raise TakeRefused(f"{element!r} has no action to do")
        tree = self.operator_branches(element, agent)
        if not tree.branches:
            who = "no operator" if agent is None else repr(agent)
            raise TakeRefused(
                f"{who} can do {element!r} now (no grounding, or its actions are a robot's)"
            )
        return tree, feasible[element]

    def operator_branches(self, element: str, agent: str | None = None) -> DecisionTree:
        """The operators' ways of doing a feasible hyper-arc now (groundings x available
        operators, or ``agent`` alone), with the objects of the operators' other executions
        left out."""
        reserved = set().union(
            *(ex.objects for ex in self.executions.values() if ex.owner == "human")
        )
        humans = [a.name for a in self.domain.agents.values() if a.is_human]
        return DecisionTree.build(
            element,
            self.actions_of(element),
            self.constraints_of(element),
            self.domain,
            self.kb,
            exclude=self.failed.get(element, ()),
            available_agents=[
                h for h in humans if h not in self.unavailable and agent in (None, h)
            ],
            reserved=reserved,
            binding=self.binding_of(element),
        )

    @property
    def idle_robots(self) -> list[str]:
        return [
            a.name
            for a in self.domain.agents.values()
            if not a.is_human and a.name not in self.busy and a.name not in self.unavailable
        ]

    @property
    def done(self) -> bool:
        return self.outcome != "running"

    # -- what the operators see (read only) -----------------------------------------------
    def feasible_hyperarcs(self) -> dict[str, float]:
        """Feasible hyper-arcs and their suggestion costs (eq. 10), as the graph answered."""
        return {n: c for n, c in self._answer.feasible.items() if self.graph.kind(n) == "hyperarc"}

    def actions_of(self, hyperarc: str) -> tuple[str, ...]:
        """A(h): the hyper-arc's ordered action invocations."""
        return self._describe(hyperarc)[1]

    def constraints_of(self, hyperarc: str) -> list[Literal]:
        """The state formulas of h's children."""
        return list(self._constraints(hyperarc))

    def binding_of(self, hyperarc: str) -> dict[str, str]:
        """The groundings h's children were reached with."""
        return self._child_binding(hyperarc)

    def parent_of(self, hyperarc: str) -> str:
        return self._parent(hyperarc)

    def children_of(self, hyperarc: str) -> list[str]:
        """The hyper-arc's children (qualified names)."""
        return list(self._children(hyperarc))

    def formula_of(self, node: str) -> tuple[Literal, ...]:
        """S(n): the node's state formula (empty: always holds)."""
        return self._formulas.get(node, ())

    def processes_of(self, node: str) -> tuple[str, ...]:
        """P(n): the node's process invocations, in order."""
        return self._node_processes.get(node, ())

    def has_processes(self, node: str) -> bool:
        """Whether reaching ``node`` starts processes P(n) (arms keep working on its parts)."""
        return bool(self._node_processes.get(node))

    def reserved_objects(self) -> set[str]:
        """Objects that running executions' groundings use."""
        return set().union(*(ex.objects for ex in self.executions.values()))

    # -- plumbing -------------------------------------------------------------------------
    def _entry(self, now: float, body: Callable[[], list[Directive]]) -> list[Directive]:
        self._now = now
        t0 = self._timer()
        rep0, sim0 = self.timing.task_representation_s, self.timing.simulator_s
        try:
            out = body()
            if self._extra:
                out = [*self._extra, *out]
                self._extra = []
            return out
        finally:
            spent = self._timer() - t0
            inner = (self.timing.task_representation_s - rep0) + (self.timing.simulator_s - sim0)
            self.timing.task_manager_s += max(0.0, spent - inner)

    def _feasible(self) -> dict[str, float]:
        """The graph's answer's feasible elements (eq. 10), made once per answer: a plan
        reads them at every step it takes (read only)."""
        return self._views()[1]

    def _hyperarcs_by_cost(self) -> list[tuple[float, int, str]]:
        """(cost, element id, name) of the answer's feasible hyper-arcs, cheapest first (ties:
        element id), made once per answer (read only)."""
        return self._views()[2]

    def _feasible_nodes(self) -> list[str]:
        """The answer's feasible nodes, in its order, made once per answer (read only)."""
        return self._views()[3]

    def _views(self) -> _AnswerViews:
        views = self._answer_views
        if views is None or views[0] is not self._answer:
            feasible = self._answer.feasible
            graph = self.graph
            kinds = [(name, cost, graph.kind(name)) for name, cost in feasible.items()]
            arcs = sorted(
                (cost, graph.element_id(name), name)
                for name, cost, kind in kinds
                if kind == "hyperarc"
            )
            nodes = [name for name, _, kind in kinds if kind == "node"]
            views = self._answer_views = (self._answer, feasible, arcs, nodes)
        return views

    def _emit(self, kind: LogEventType, **data: Any) -> None:
        data.pop("type", None)  # a misspelt kind is a type error: the tags of flexhrc.events
        self._log({"t": round(self._now, 6), "type": kind, **data})

    def _update_graph(self, **kw: Iterable[str]) -> None:
        t0 = self._timer()
        self._answer = self.graph.update(**kw)
        self.timing.task_representation_s += self._timer() - t0
        self._emit(
            "query",
            report={k: list(v) for k, v in kw.items() if v},
            outcome=self._answer.outcome,
            feasible={k: _num(v) for k, v in self._feasible().items()},
        )
        if self._answer.solved:
            self._finish("solved", None)
        elif self._answer.failed:
            self._finish("failed", self._answer.reason)

    def _finish(self, outcome: str, reason: str | None) -> None:
        if self.outcome == "running":
            self.outcome, self.reason = outcome, reason
            self._emit("outcome", outcome=outcome, reason=reason)

    def _node_definitions(self) -> Iterator[tuple[str, Any]]:
        """Every node's name and its definition."""
        for name in self.graph.elements():
            if self.graph.kind(name) == "node":
                yield name, self.graph.definition_of(name).nodes[self.graph.local_name(name)]

    def _collect_transfers(self) -> None:
        hierarchy = self.graph.hierarchy
        if len(hierarchy.graphs) == 1:
            return
        keys: dict[str, str] = {}  # instance path -> definition key (depth-first: upper first)
        for info in hierarchy.instances():
            keys[info.path] = info.key
            if info.upper is None:
                continue
            upper_path, local = split_qualified(info.upper)
            transfer = hierarchy.transfer(keys[upper_path], local)
            if transfer:
                self._transfers[info.path] = (transfer, info.upper)
                root = hierarchy.graphs[info.key].root
                self._lower_roots[qualify(info.path, str(root))] = info.path

    # -- groundings through the hierarchy (paper 000, IV-B, eqs. 15-16) -------------------
    def _scope(self, element: str) -> Substitution:
        """The binding of the graph instance ``element`` belongs to: the lower variables its
        transition maps (M1, and M2 where the upper layer already knows the result), valued
        by the grounding of the upper hyper-arc that created it. Empty for the top graph and
        where nothing passes; read only."""
        path = self._instance_of.get(element)
        if path is None:
            path = self._instance_of[element] = self.graph.graph_of(element)
        found = self._scopes.get(path)
        if found is None:
            if path not in self._transfers:
                return _NO_BINDING
            found = self._bind_instance(path)
            if found is None:
                return _NO_BINDING  # not active yet: nothing is bound
            self._scopes[path] = found
        return found

    def _bind_instance(self, path: str) -> Substitution | None:
        """M1: the grounding of the upper hyper-arc u when its instance starts — what its
        children were reached with, the variables they leave open bound in the knowledge
        base as it is now (the first grounding, in the knowledge base's order) — carried to
        the lower variables the transition maps. None while u's children are not all met."""
        transfer, u = self._transfers[path]
        graph = self.graph
        if not all(graph.is_met(c) for c in self._children(u)):
            return None
        sigma = self._child_binding(u)
        terms = (*transfer.down.values(), *transfer.up.values())
        if any(is_variable(t) and t not in sigma for t in terms):
            first = next(self.kb.iter_query(self._constraints(u), sigma), None)
            if first is not None:
                sigma = first
        self._sigmas[u] = sigma
        scope: Substitution = {}
        for mapping in (transfer.down, transfer.up):
            for lower_var, term in mapping.items():
                value = sigma.get(term) if is_variable(term) else term
                if value is not None:
                    scope.setdefault(lower_var, value)
        return scope

    def _carry_up(self, path: str, root: str) -> None:
        """M2: the lower root ``root`` of instance ``path`` is met, so its hyper-arc u is
        solved (eq. 18): u's parent is reached with u's grounding, and the variables of the
        parent's formula that the transition maps to the lower root are grounded by what the
        lower instance did (the root's binding; a variable the root's formula leaves open, by
        the knowledge base now)."""
        transfer, u = self._transfers[path]
        parent = self._parent(u)
        formula = self._formulas.get(parent, ())
        if not formula:
            return
        wanted = {a for lit in formula for a in lit.args if is_variable(a)}
        sigma = self._sigmas.get(u) or self._child_binding(u)
        carried = {k: v for k, v in sigma.items() if k in wanted}
        open_ = {
            t: lv
            for lv, t in transfer.up.items()
            if is_variable(t) and t in wanted and t not in carried
        }
        if open_:
            below = {**self._scope(root), **self.bindings.get(root, {})}
            if any(lv not in below for lv in open_.values()):
                first = next(self.kb.iter_query(self._formulas.get(root, ()), below), None)
                below = first if first is not None else below
            for t, lv in open_.items():
                if lv in below:
                    carried[t] = below[lv]
        if carried:
            self.bindings[parent] = carried

    def _describe(self, name: str) -> tuple[str, tuple[str, ...]]:
        found = self._described.get(name)
        if found is None:
            found = self._described[name] = self._read_description(name)
        return found

    def _read_description(self, name: str) -> tuple[str, tuple[str, ...]]:
        g = self.graph.definition_of(name)
        local = self.graph.local_name(name)
        if self.graph.kind(name) == "node":
            return "node", tuple(g.nodes[local].processes)
        return "hyperarc", tuple(g.hyperarcs[local].actions)

    def _hyperarc(self, element: str) -> tuple[Any, str]:
        """Hyper-arc ``element``'s definition and the path of its instance."""
        g = self.graph.definition_of(element)
        return g.hyperarcs[self.graph.local_name(element)], self.graph.graph_of(element)

    def _children(self, element: str) -> list[str]:
        """The hyper-arc's children (kept: read only)."""
        found = self._children_of.get(element)
        if found is None:
            h, path = self._hyperarc(element)
            found = self._children_of[element] = [qualify(path, c) for c in h.children]
        return found

    def _parent(self, element: str) -> str:
        found = self._parent_of.get(element)
        if found is None:
            h, path = self._hyperarc(element)
            found = self._parent_of[element] = qualify(path, h.parent)
        return found

    # -- deciding -------------------------------------------------------------------------
    def _node_holds(self, name: str) -> bool:
        """S(n) under the binding carried from the hyper-arc that reached n."""
        formula = self._formulas.get(name, ())
        if not formula:
            return True
        # (inline for a single graph: this runs for every feasible node at every step)
        binding = self._node_binding(name) if self._transfers else self.bindings.get(name)
        if binding:
            formula = tuple(apply_substitution(lit, binding) for lit in formula)
        return holds(formula, self.kb.facts)

    def _node_binding(self, name: str) -> Substitution:
        """What node ``name`` was reached with: its instance's binding (M1) and the grounding
        carried from its producing hyper-arc (read only)."""
        binding = self.bindings.get(name, _NO_BINDING)
        if self._transfers:
            scope = self._scope(name)
            if scope:
                return {**scope, **binding}
        return binding

    def _meet_nodes(self) -> None:
        """Meet feasible nodes whose state holds and whose processes have ended (eq. 5)."""
        while self.outcome == "running":
            met = []
            for name in self._by_process_priority(self._feasible_nodes()):
                if not self._node_holds(name):
                    continue
                if name in self._node_processes and not self._processes_ended(name):
                    continue
                met.append(name)
            if not met:
                return
            for name in met:
                self.processes.pop(name, None)
            self._update_graph(met_nodes=met)
            if self._lower_roots:
                for name in met:
                    path = self._lower_roots.get(name)
                    if path is not None:
                        self._carry_up(path, name)  # M2: before the parent is looked at

    # -- node processes P(n) --------------------------------------------------------------
    def _processes_ended(self, node: str) -> bool:
        """Activate n's processes when it is reached; True once the last one has ended."""
        run = self.processes.get(node)
        if run is None:
            run = ProcessRun(node, self._node_processes[node], dict(self._node_binding(node)))
            self.processes[node] = run
            self._emit("process_activated", node=node, processes=list(run.invocations))
        while not run.ended:
            ground = self._ground_process(run)
            if ground is None:
                return False
            schema_until = [apply_substitution(lit, ground.binding) for lit in ground.schema.until]
            if schema_until and holds(schema_until, self.kb.facts):
                self._end_process(run, ground, "its end condition holds")
                continue
            if run.command is None and run.asked is None:
                if not self._agents_free_for(ground):
                    return False  # its agents are busy: it starts when they are free
                self._start_process(run, ground)
            return False
        return True

    def _by_process_priority(self, nodes: list[str]) -> list[str]:
        """``nodes`` with those whose next process has the higher priority first (stable: the
        graph's order among equals), so the process that should win an arm asks for it first."""
        if not self._node_processes:
            return nodes
        return sorted(nodes, key=lambda n: -self._process_priority(n))

    def _process_priority(self, node: str) -> int:
        invocations = self._node_processes.get(node)
        run = self.processes.get(node)
        i = run.index if run is not None else 0
        if not invocations or i >= len(invocations):
            return 0
        return self.domain.invocation(invocations[i], process=True)[0].priority

    def _agents_free_for(self, ground: GroundAction) -> bool:
        """Can ``ground`` (a process round) start now? Its arms are idle or run a process of lower
        priority — stopped here for it (the run of that process waits and resumes when the arm
        is free again); a person is free when no execution or process of theirs is running."""
        people = self._busy_humans()
        lower: list[Command] = []
        for a in ground.agents:
            if a in self.unavailable or a in people:
                return False
            cmd = self.busy.get(a)
            if cmd is None:
                continue
            if not cmd.process or cmd.action.schema.priority >= ground.schema.priority:
                return False
            if all(c is not cmd for c in lower):  # a joint command counts once
                lower.append(cmd)
        for cmd in lower:
            node = self._process_of.pop(cmd.id, None)
            run = self.processes.get(node) if node is not None else None
            if run is not None and run.command is cmd:
                run.command = None
            why = (
                f"preempted by process {ground} (priority {ground.schema.priority} > "
                f"{cmd.action.schema.priority})"
            )
            self._stop_round(cmd, why)
        return True

    def _stop_round(self, cmd: Command, why: str) -> None:
        """Stop a process round's command on every arm it still holds."""
        for a in cmd.agents:
            if self.busy.get(a) is cmd:
                self.busy.pop(a)
                self._extra.append(Stop(a, cmd.id, why))
                self._emit("stop", agent=a, command=cmd.id, reason=why)

    def _ground_process(self, run: ProcessRun) -> GroundAction | None:
        schema, terms = self.domain.invocation(run.invocations[run.index], process=True)
        binding = dict(run.binding)
        values: list[str] = []
        for (var, typ), term in zip(schema.parameters, terms, strict=True):
            value = binding.get(term, term) if is_variable(term) else term
            if is_variable(value):
                if schema.agents.mode == "choice" and var == schema.agents.variable:
                    found = self._process_agent(typ, schema.priority)
                else:
                    found = [o.id for o in self.kb.objects_of_type(typ)][:1]
                if not found:
                    return None
                value = binding[term] = found[0]
            values.append(value)
        run.binding = binding
        spec = schema.agents
        if spec.mode == "choice":
            agents: tuple[str, ...] = (values[schema.variables.index(str(spec.variable))],)
        else:
            agents = spec.names
        return GroundAction(schema, tuple(values), agents)

    def _process_agent(self, typ: str, priority: int) -> list[str]:
        """Who runs a process whose agent is a choice of type ``typ``: an idle arm, else an arm
        running a process of lower priority (it is preempted), else — where the type admits
        people — a person with nothing running (paper eq. 5: processes are meant for robots, a
        person may carry them out occasionally). Empty: nobody now."""
        capable = [a for a in self.domain.agents_of_type(typ) if a.name not in self.unavailable]
        arms = [a.name for a in capable if not a.is_human]
        idle = [a for a in arms if a not in self.busy]
        lower = [
            a
            for a in arms
            if not idle and self.busy[a].process and self.busy[a].action.schema.priority < priority
        ]
        people = self._busy_humans()
        persons = [a.name for a in capable if a.is_human and a.name not in people]
        return (idle or lower or persons)[:1]

    def _start_process(self, run: ProcessRun, ground: GroundAction) -> None:
        if any(self.domain.agent(a).is_human for a in ground.agents):
            # a person's round: asked as a suggestion of the node; their report ends it
            sug = Suggest(run.node, [ground], 0.0)
            run.asked = ground
            run.rounds += 1
            self._emit("suggestion", **sug.to_dict())
            self._extra.append(sug)
            return
        t0 = self._timer()
        sim = self.simulator.simulate([ground], self.kb, self.domain)
        self.timing.simulator_s += self._timer() - t0
        expected = sim.total_s if sim.success else (ground.schema.duration or 1.0)
        cmd = Command(next(self._ids), ground.agents, ground, run.node, run.index, expected, True)
        for a in ground.agents:
            self.busy[a] = cmd
        run.command = cmd
        run.rounds += 1
        self._process_of[cmd.id] = run.node
        self._emit("command", **cmd.to_dict())
        self._extra.append(cmd)

    def _end_process(self, run: ProcessRun, ground: GroundAction, why: str) -> None:
        cmd = run.command
        if cmd is not None:  # still running: its end condition came true meanwhile
            self._stop_round(cmd, f"process {ground} ended")
            self._process_of.pop(cmd.id, None)
        if run.asked is not None:  # a person still at it: their coming report is no new round
            self._let_go.add((self._human_of(run.asked), str(run.asked)))
        self._emit("process_ended", node=run.node, process=str(ground), reason=why)
        run.command = None
        run.asked = None
        run.index += 1
        run.rounds = 0

    def _person_process_report(self, action: HumanAction) -> list[Directive] | None:
        """A person reports a round of a process they were asked to run: its effects apply, the
        process ends if ``until`` now holds (else they are asked again). A report of one that
        ended meanwhile (its condition came true first) is taken quietly. None: not a process."""
        said = str(action)
        for run in self.processes.values():
            asked = run.asked
            if asked is None or str(asked) != said:
                continue
            self._emit("human_action", action=said)
            run.asked = None
            self._apply_effects(asked)
            self._round_done(run, asked)
            return self._plan()
        for who, process in list(self._let_go):
            if process == said and who in action.args:
                self._let_go.discard((who, process))
                self._emit("human_action", action=said)
                return self._plan()
        return None

    def _process_ack(self, node: str, cmd: Command, ack: Ack) -> None:
        run = self.processes.get(node)
        self._process_of.pop(cmd.id, None)
        if run is None or run.command is not cmd:
            return
        run.command = None
        ground = cmd.action
        if ack.status == "done":
            self._apply_effects(ground)
            # what the behaviour observed (e.g. a push undone) is part of why it ended
            self._round_done(run, ground, ack.reason)
        else:
            run.failures += 1
            self._emit("process_failed", node=node, process=str(ground), reason=ack.reason)
            if run.failures >= 3:
                self._finish("failed", f"process {ground} of {node} failed 3 times: {ack.reason}")

    def _round_done(self, run: ProcessRun, ground: GroundAction, said: str | None = None) -> None:
        """A round of ``run``'s process ``ground`` is done (its effects applied): the process
        ends if its ``until`` holds (``said``: what was observed, part of why), the run fails
        after too many rounds, else it goes on."""
        until = [apply_substitution(lit, ground.binding) for lit in ground.schema.until]
        if not until or holds(until, self.kb.facts):
            why = "its end condition holds" if until else "done"
            self._end_process(run, ground, f"{why}; {said}" if said else why)
        elif run.rounds >= self.max_process_rounds:
            self._finish(
                "failed",
                f"process {ground} of {run.node}: end condition {' & '.join(map(str, until))} "
                f"still false after {run.rounds} rounds",
            )

    def _plan(self) -> list[Directive]:
        out: list[Directive] = []
        if self.done:
            return out
        if not self.kb.consistent:
            if not self.waiting_for_consistency:
                self.waiting_for_consistency = True
                self._emit(
                    "waiting",
                    reason="knowledge base inconsistent",
                    inconsistencies=[i.reason for i in self.kb.inconsistencies],
                )
            return out
        self.waiting_for_consistency = False
        self._meet_nodes()
        self._drop_obsolete(out)
        for _ in range(10_000):
            if self.done:
                return out
            self.table.refresh(self._feasible(), self._describe)
            started = self._start_next(out)
            if not started:
                if self.declined and not (self.executions or self.busy or self.processes):
                    # nothing else is left to wait for: a "not now" is asked again now
                    self.declined.clear()
                    continue
                break
        return out

    def _drop_obsolete(self, out: list[Directive]) -> None:
        """Executions whose hyper-arc is no longer feasible (an alternative was solved, its
        graph instance closed) are given up: robots stop and rest, operators are told nothing
        more (their next action will not be recognised)."""
        for ex in list(self.executions.values()):
            if self.graph.is_feasible(ex.element):
                continue
            if ex.owner == "robot":
                self._abort(ex, out, reason=f"{ex.element} is no longer feasible")
            else:
                self.executions.pop(ex.element, None)
                self._emit(
                    "abort",
                    element=ex.element,
                    reason=f"{ex.element} is no longer feasible",
                    agents=list(ex.agents),
                )

    def _conflicts(self, element: str) -> bool:
        if element in self.executions:
            return True
        children = set(self._children(element))
        return any(children & set(self._children(e)) for e in self.executions)

    def _constraints(self, element: str) -> list[Literal]:
        """The children's state formulas (h starts from the state its children describe; kept:
        read only)."""
        found = self._constraints_of.get(element)
        if found is None:
            found = [lit for c in self._children(element) for lit in self._formulas.get(c, ())]
            self._constraints_of[element] = found
        return found

    def _child_binding(self, element: str) -> dict[str, str]:
        """The groundings h's children were reached with (carried from their hyper-arcs),
        within the binding of h's graph instance (M1)."""
        out: dict[str, str] = dict(self._scope(element)) if self._transfers else {}
        for c in self._children(element):
            out.update(self.bindings.get(c, {}))
        return out

    def _busy_humans(self) -> set[str]:
        return {
            a
            for ex in self.executions.values()
            if ex.owner == "human"
            for a in ex.agents
            if self.domain.agent(a).is_human
        } | {
            a
            for run in self.processes.values()
            if run.asked is not None
            for a in run.asked.agents
            if self.domain.agent(a).is_human
        }

    def _advice(self) -> Advice | None:
        """The policy's advice at this decision (None: no policy, or no answer)."""
        if self.policy is None:
            return None
        t0 = self._timer()
        advice = self.policy.advise(self, self._now)
        self.advice_s.append(self._timer() - t0)
        return advice

    @staticmethod
    def _advised(
        candidates: list[tuple[float, int, str]], advice: Advice
    ) -> list[tuple[float, int, str]]:
        """The candidates in the advice's order: its starts first, the held ones left out, the
        rest (the advisor said nothing of them) after, cheapest first."""
        by_name = {c[2]: c for c in candidates}
        first = [by_name[s.element] for s in advice.start if s.element in by_name]
        told = {s.element for s in advice.start} | advice.hold
        return [*first, *(c for c in candidates if c[2] not in told)]

    def _start_next(self, out: list[Directive]) -> bool:
        """Start the cheapest startable element; True if something changed."""
        candidates = self._hyperarcs_by_cost()
        advice = self._advice()
        advised: dict[str, Start] = {}
        if advice is not None:
            candidates = self._advised(candidates, advice)
            advised = {s.element: s for s in advice.start}
        robots_idle = self.idle_robots
        busy_humans = self._busy_humans()
        for cost, _, name in candidates:
            if self._conflicts(name):
                continue
            actions = self._describe(name)[1]
            if not actions:  # nothing to do: the transition is immediate
                self._update_graph(solved_hyperarcs=[name])
                self._meet_nodes()
                return True
            excluded = self._excluded(name) if (self.declined or self.cannot) else set()
            available = list(robots_idle) + [
                h for h in self._humans() if h not in busy_humans and h not in excluded
            ]
            reserved = self.reserved_objects()
            constraints = self._constraints(name)
            tree = self._tree(
                name, actions, constraints, available_agents=available, reserved=reserved
            )
            if not tree.branches:
                # no branch with the agents free now: maybe later (an agent is busy)
                if self._could_run_later(name, actions, constraints, reserved):
                    continue
                reason = "no grounding or agent left"
                if tree.pruned:
                    reason = f"every branch fails a precondition ({tree.pruned[0].pruned})"
                    self._emit(
                        "decision",
                        element=name,
                        cost=_num(cost),
                        branches=[],
                        pruned=[b.to_dict() for b in tree.pruned],
                        chosen=None,
                    )
                self._mark_infeasible(name, reason)
                return True
            t0 = self._timer()
            best = tree.evaluate(self.simulator, self.kb, self.domain, self._score_fn())
            self.branches_simulated += len(tree.branches)
            planned = self._planned_branch(tree, advised[name]) if name in advised else None
            if planned is not None:  # the advisor's branch: its agents, its grounding
                best = planned
            elif name in advised and not any(
                set(b.agents) == set(advised[name].agents) for b in tree.branches
            ):
                # the advised agents are not free (yet): wait for them, as the plan does
                self.timing.simulator_s += self._timer() - t0
                continue
            if planned is None and best is not None and self._is_persons(best):
                best = self._robot_if_as_good(tree, best)
            if (
                planned is None
                and best is not None
                and self._is_persons(best)
                and self._robot_would_do_better(name, actions, constraints, reserved, best)
            ):
                # a busy arm is the best by eq. (21): the step waits for it (it is re-planned
                # when the arm is free) and stays free meanwhile for an operator who acts on
                # their own; a person is asked only for what they are needed for or best at
                self.timing.simulator_s += self._timer() - t0
                continue
            self.timing.simulator_s += self._timer() - t0
            self.decisions += 1
            event: dict[str, Any] = {
                "element": name,
                "cost": _num(cost),
                "branches": [b.to_dict() for b in tree.branches],
                "chosen": tree.branches.index(best) if best else None,
            }
            if tree.pruned:
                event["pruned"] = [b.to_dict() for b in tree.pruned]
            self._emit("decision", **event)
            if best is None:
                self.failed.setdefault(name, []).extend(dict(b.grounding) for b in tree.branches)
                if not self._could_run_later(name, actions, constraints, reserved):
                    self._mark_infeasible(name, "every branch scores 0")
                    return True
                continue
            self._launch(name, best, cost, out)
            return True
        if advice is not None and not (self.executions or self.busy or self.processes):
            # the advice started nothing and nothing runs that could end: the paper decides
            saved, self.policy = self.policy, None
            try:
                return self._start_next(out)
            finally:
                self.policy = saved
        return False

    @staticmethod
    def _planned_branch(tree: DecisionTree, start: Start) -> Branch | None:
        """The simulated branch of ``tree`` an advisor's :class:`Start` names: the same agents
        and (where it gives one) the same grounding, else the best with those agents; None
        when none of them succeeds."""
        agents = set(start.agents)
        fits = [b for b in tree.branches if set(b.agents) == agents and b.utility > 0]
        exact = [
            b for b in fits if all(b.grounding.get(k) == v for k, v in start.grounding.items())
        ]
        pool = exact or fits
        return max(pool, key=lambda b: b.utility) if pool else None

    def _is_persons(self, branch: Branch) -> bool:
        """A branch that needs a person (it would be a suggestion, not a command)."""
        return any(self.domain.agent(a).is_human for a in branch.agents)

    def _robot_if_as_good(self, tree: DecisionTree, best: Branch) -> Branch:
        """Ties go to the robots: a person is asked only when their branch is strictly better
        by eq. (21) (Fig. 9: the robot does what it can while the operator does not step in)."""
        for b in tree.branches:
            if b.utility >= best.utility > 0 and not self._is_persons(b):
                return b
        return best

    def _robot_would_do_better(
        self,
        name: str,
        actions: tuple[str, ...],
        constraints: list[Literal],
        reserved: set[str],
        persons: Branch,
    ) -> bool:
        """Would an arm that is busy now do ``name`` better than the person's best branch?

        The decision tree of eq. (21) ranges over every agent that may do the actions (paper
        000, Fig. 2), not only the idle ones: when the best of them is a busy arm, the person
        is not what the step needs — it waits for the arm (no person is asked to do what a
        robot does as well just because the robot is busy right now; ties go to the robots). The
        arm's branches are checked and simulated after the rest of its current execution."""
        # an arm in a node process is left out: the process may be waiting for this very step
        busy = [
            a.name
            for a in self.domain.agents.values()
            if not a.is_human
            and a.name in self.busy
            and not self.busy[a.name].process
            and a.name not in self.unavailable
        ]
        if not busy:
            return False
        robots = [*self.idle_robots, *busy]
        tree = self._tree(
            name,
            actions,
            constraints,
            available_agents=robots,
            reserved=reserved,
            check_pre=False,  # checked below, after what the busy arm still has to do
        )
        for b in tree.branches:
            # from where the arm will be: after the rest of what it is doing now
            running = {self.busy[a].id: self.busy[a] for a in b.agents if a in busy}
            if not running:
                continue
            before: list[GroundAction] = []
            for cmd in running.values():
                ex = self.executions.get(cmd.element) if cmd.element else None
                if ex is not None and ex.command is cmd:
                    before += ex.branch.steps[ex.next_index :]
                else:
                    before.append(cmd.action)
            steps = [*before, *b.steps]
            if unmet_precondition(steps, self.kb.facts, len(before)) is not None:
                continue
            result = self.simulator.simulate(steps, self.kb, self.domain)
            total = sum(result.durations[len(before) :])
            if self.utility is not None:
                # the arm's branch scored like the person's, from where the arm will be
                terms = self._terms(b.steps, result.success, result.durations[len(before) :])
                if terms["utility"] > 0 and terms["utility"] >= persons.utility:
                    return True
                continue
            if result.success and total > 0 and 1.0 / total >= persons.utility:
                return True
        return False

    def _terms(
        self, steps: Sequence[GroundAction], success: bool, durations: Sequence[float]
    ) -> dict[str, float]:
        """A branch's terms under the scenario's shaped utility (:mod:`.utility`)."""
        assert self.utility is not None
        return self.utility.terms(
            steps,
            success,
            durations,
            self.domain,
            now=self._now,
            person_time=self.person_time,
        )

    def _score_fn(self) -> Callable[[Branch], dict[str, float] | None] | None:
        """How a simulated branch is scored: None for eq. (21), else its terms — the shaped
        utility's (:mod:`.utility`) and, with an operator model that knows how often the
        branch's people decline or cannot (``answer_odds`` of the simulator,
        :class:`~flexhrc.taskmanager.operator_model.OperatorModelSimulator`), the expected
        utility ``J(b) * p_does`` with its terms ``p_decline`` and ``p_cannot``. A branch the
        model says nothing about keeps eq. (21) (no terms) when there is no ``utility:``."""
        odds = getattr(self.simulator, "answer_odds", None)  # an operator model's only
        if self.utility is None and odds is None:
            return None

        def score(b: Branch) -> dict[str, float] | None:
            r = b.result
            success, durations = bool(r and r.success), (r.durations if r else [])
            said = odds(b.steps, self.domain) if odds is not None else None
            if self.utility is not None:
                terms = self._terms(b.steps, success, durations)
            elif said is None:
                return None  # eq. (21) as the paper has it
            else:
                total = float(sum(durations))
                j = 1.0 / total if success and total > 0 else 0.0  # eq. (21)
                terms = {"success": 1.0 if success else 0.0, "time": round(total, 6), "utility": j}
            if said is not None:
                terms["p_decline"] = said["p_decline"]
                terms["p_cannot"] = said["p_cannot"]
                terms["utility"] = terms["utility"] * said["p_does"]  # the expected utility
            return terms

        return score

    def _objects(self, branch: Branch) -> set[str]:
        return {v for v in branch.grounding.values() if v not in self.domain.agents}

    def _humans(self) -> list[str]:
        return [
            a.name
            for a in self.domain.agents.values()
            if a.is_human and a.name not in self.unavailable
        ]

    def _could_run_later(
        self, name: str, actions: tuple[str, ...], constraints: list[Literal], reserved: set[str]
    ) -> bool:
        """Would some branch exist if every agent were free and nothing reserved?"""
        # an agent that left the cell may come back (cell: its process is restarted); a person
        # who said "not now" may be asked again
        if not (
            self.busy or reserved or self.executions or self.unavailable or self.declined.get(name)
        ):
            return False
        cannot = self.cannot.get(name)
        kw = (
            {"available_agents": [a for a in self.domain.agents if a not in cannot]}
            if cannot
            else {}
        )
        tree = self._tree(
            name, actions, constraints, check_pre=False, **kw
        )  # a precondition may come true when the others are done
        return bool(tree.branches)

    def _tree(
        self, name: str, actions: Sequence[str], constraints: list[Literal], **kw: Any
    ) -> DecisionTree:
        """The decision tree of hyper-arc ``name`` (groundings x agents, section V-A) in the
        knowledge base as it is, without the groundings that failed before and with the
        grounding its children carry."""
        return DecisionTree.build(
            name,
            actions,
            constraints,
            self.domain,
            self.kb,
            exclude=self.failed.get(name, ()),
            binding=self._child_binding(name),
            **kw,
        )

    def _launch(self, name: str, branch: Branch, cost: float, out: list[Directive]) -> None:
        human = any(self.domain.agent(a).is_human for a in branch.agents)
        ex = Execution(name, branch, "human" if human else "robot", objects=self._objects(branch))
        self.executions[name] = ex
        row = self.table.rows.get(name)
        if row:
            row.status = "running"
        if human and self.utility is not None and branch.result is not None:
            for step, d in zip(branch.steps, branch.result.durations, strict=False):
                for a in step.agents:
                    if self.domain.agent(a).is_human:
                        t = self.utility.effort_time(step, d)
                        self.person_time[a] = self.person_time.get(a, 0.0) + t
        if human:
            sug = Suggest(name, list(branch.steps), cost)
            self._emit("suggestion", **sug.to_dict())
            out.append(sug)
        else:
            cmd = self._command(ex, out)
            if cmd is not None:
                out.append(cmd)

    def _command(self, ex: Execution, out: list[Directive]) -> Command | None:
        """Issue the execution's next action; its precondition is checked again first (at
        dispatch the world may differ from what the decision tree saw)."""
        step = ex.branch.steps[ex.next_index]
        why = unmet_precondition([step], self.kb.facts)
        if why is not None:
            self._emit("precondition_failed", element=ex.element, action=str(step), reason=why)
            self.failed.setdefault(ex.element, []).append(dict(ex.branch.grounding))
            self._abort(ex, out, reason=why)
            return None
        expected = ex.branch.result.durations[ex.next_index] if ex.branch.result else 0.0
        cmd = Command(next(self._ids), step.agents, step, ex.element, ex.next_index, expected)
        for a in step.agents:
            self.busy[a] = cmd
        ex.command = cmd
        self._emit("command", **cmd.to_dict())
        return cmd

    # -- acknowledgements -----------------------------------------------------------------
    def _handle_ack(self, ack: Ack) -> list[Directive]:
        cmd = next((c for c in self.busy.values() if c.id == ack.command_id), None)
        if cmd is None:
            self._emit("ack_ignored", command=ack.command_id, status=ack.status)
            return self._plan()
        for a in cmd.agents:
            self.busy.pop(a, None)
        self._emit(
            "ack", command=cmd.id, status=ack.status, reason=ack.reason, action=str(cmd.action)
        )
        out: list[Directive] = []
        node = self._process_of.get(cmd.id)
        if node is not None:
            self._process_ack(node, cmd, ack)
            out += self._plan()
            return out
        ex = self.executions.get(cmd.element) if cmd.element else None
        if ack.status == "done":
            self._apply_effects(cmd.action)
            if ex is not None:
                self._progress(ex, cmd.agents[0])
                if ex.element in self.executions and not self.done:
                    nxt = self._command(ex, out)
                    if nxt is not None:
                        out.append(nxt)
        else:
            if ex is not None and (self._only_motions_left(ex) or self._held_fast(ex)):
                # what failed changes no fact, nor does anything after it (an arm that could not
                # go to rest), or its part is fixed in place (a gripper that did not open on a
                # screwed leg): the hyper-arc's result holds; redoing it would undo nothing
                self._emit_failed(ex, ack, kept=True)
                ex.next_index = len(ex.branch.steps) - 1
                self._progress(ex, cmd.agents[0])
            elif ex is not None:
                self.failed.setdefault(ex.element, []).append(dict(ex.branch.grounding))
                policy = self._failure_policy(cmd)
                self._emit_failed(ex, ack, policy=policy)
                self._abort(ex, out, reason=f"{cmd.action} {ack.status}")
                if policy == "paper":
                    self._give_up(ex.element, f"{cmd.action} {ack.status} (failure policy paper)")
        out += self._plan()
        return out

    def _emit_failed(self, ex: Execution, ack: Ack, **extra: Any) -> None:
        """The ``action_failed`` event of ``ex``'s command that ``ack`` answered."""
        self._emit(
            "action_failed",
            element=ex.element,
            grounding=ex.branch.grounding,
            status=ack.status,
            reason=ack.reason,
            **extra,
        )

    def _failure_policy(self, cmd: Command) -> str:
        """The policy a failed command falls under: :attr:`on_failure`, except for a command
        of an agent that left the cell (the hyper-arc did not fail: its agent went)."""
        if any(a in self.unavailable for a in cmd.agents):
            return "retry"
        return self.on_failure

    def _give_up(self, element: str, reason: str) -> None:
        """Paper V-A: "sets the optimal hyper-arc to follow as infeasible, and finds a new
        optimal hyper-arc among the available ones" — for good, in the graph, so the next plan
        takes the feasible state of least cost that is left (none left, Nf and Hf empty: the
        cooperation fails, section IV)."""
        if not self.graph.is_feasible(element):
            return  # meanwhile an alternative was solved: nothing left to give up
        self._mark_infeasible(element, reason)

    def _mark_infeasible(self, element: str, reason: str) -> None:
        """``element`` can never be done: said, and marked in the graph."""
        self.infeasible[element] = reason
        self._emit("infeasible", element=element, reason=reason)
        self._update_graph(infeasible=[element])
        self._meet_nodes()

    def _progress(self, ex: Execution, who: str) -> None:
        row = self.table.rows.get(ex.element)
        if row and ex.next_index < len(row.done_by):
            row.done_by[ex.next_index] = who
        ex.next_index += 1
        if ex.next_index >= len(ex.branch.steps):
            del self.executions[ex.element]
            if not self.graph.is_feasible(ex.element):
                # meanwhile an alternative was solved: this transition no longer counts
                self._emit("obsolete", element=ex.element, agents=list(ex.branch.agents))
                return
            ex.command = None
            if row:
                row.status = "solved"
            self._emit(
                "solved",
                element=ex.element,
                agents=list(ex.branch.agents),
                grounding=dict(ex.branch.grounding),
            )
            # the grounding carries to the parent's state formula (its variables only)
            parent = self._parent(ex.element)
            wanted = {a for lit in self._formulas.get(parent, ()) for a in lit.args}
            carried = {k: v for k, v in ex.branch.grounding.items() if k in wanted}
            if carried:
                self.bindings[parent] = carried
            self._update_graph(solved_hyperarcs=[ex.element])
            self._meet_nodes()

    def _held_fast(self, ex: Execution) -> bool:
        """The hyper-arc's result holds and the part the failed step handles is fixed in place
        — a gripper that did not open after screwing its leg: the connection cannot be undone,
        so the transition counts as done, and the arm, never ``free`` again, is left as it is:
        later decisions prune its branches by their preconditions (eq. 20)."""
        if not self._outcome_holds(ex):
            return False
        step = ex.branch.steps[min(ex.next_index, len(ex.branch.steps) - 1)]
        obj, _ = action_targets(step, self.kb)
        return obj is not None and obj in self.kb.objects and self.kb.objects[obj].fixed

    @staticmethod
    def _only_motions_left(ex: Execution) -> bool:
        """The running step and every one after it change no fact (add and delete empty), and
        at least one step before them did the hyper-arc's work."""
        rest = ex.branch.steps[ex.next_index :]
        done = ex.branch.steps[: ex.next_index]
        return (
            bool(rest)
            and any(s.schema.add or s.schema.delete for s in done)
            and not any(s.schema.add or s.schema.delete for s in rest)
        )

    def _apply_effects(self, action: GroundAction) -> None:
        schema = action.schema
        self.kb.apply_effects(schema.add, schema.delete, action.binding)

    def _abort(self, ex: Execution, out: list[Directive], reason: str) -> None:
        """Give up an execution: release what its arms hold where they are, send them to rest."""
        self.executions.pop(ex.element, None)
        row = self.table.rows.get(ex.element)
        if row:
            row.status = "feasible"
            row.done_by = [None] * len(row.actions)
        self._emit("abort", element=ex.element, reason=reason, agents=list(ex.branch.agents))
        for agent in ex.branch.agents:
            if self.domain.agent(agent).is_human:
                continue
            cmd = self.busy.get(agent)
            if cmd is not None and cmd.element == ex.element and not cmd.process:
                self._stop_agent(agent, cmd, reason, out)
            self._release(agent)
            self._rest(agent, out)

    def _stop_agent(self, agent: str, cmd: Command, reason: str, out: list[Directive]) -> None:
        for a in cmd.agents:  # a joint command stops on every arm
            if self.busy.get(a) is cmd:
                self.busy.pop(a)
        out.append(Stop(agent, cmd.id, reason))
        self._emit("stop", agent=agent, command=cmd.id, reason=reason)

    def _release(self, agent: str) -> None:
        """What a stopped arm holds stays where the arm is (the domain's ``on_stop`` rule)."""
        rule = self.domain.on_stop
        for sub in self.kb.query([rule.holding], {rule.agent_var: agent}):
            obj = sub.get(rule.object_var)
            self.kb.apply_effects(rule.release, (rule.holding,), sub)
            if obj in self.kb.objects and agent in self.kb.objects:
                p = self.kb.position(agent)
                self.kb.move(obj, (p[0], p[1], 0.0))

    def _rest(self, agent: str, out: list[Directive]) -> None:
        # an agent that left the cell is sent nowhere (it would never answer)
        if agent in self.busy or agent in self.unavailable or "rest" not in self.domain.actions:
            return
        schema = self.domain.actions["rest"]
        if len(schema.parameters) != 1:
            return
        rest = GroundAction(schema, (agent,), (agent,))
        t0 = self._timer()
        sim = self.simulator.simulate([rest], self.kb, self.domain)
        self.timing.simulator_s += self._timer() - t0
        cmd = Command(next(self._ids), (agent,), rest, None, 0, sim.total_s)
        self.busy[agent] = cmd
        self._emit("command", **cmd.to_dict())
        out.append(cmd)

    def _handle_percept(self, moved: set[str], retracted: list[HumanAction]) -> list[Directive]:
        self._emit("percept", moved=sorted(moved), retracted=[str(a) for a in retracted])
        out: list[Directive] = []
        wrong = {a for r in retracted for a in r.args}
        for ex in list(self.executions.values()):
            if ex.owner == "robot" and ex.objects & moved:
                self._abort(ex, out, reason=f"{', '.join(sorted(ex.objects & moved))} moved")
            elif ex.owner == "human" and ex.objects & wrong:
                self._drop_human(ex, "human report retracted")
                row = self.table.rows.get(ex.element)
                if row:
                    row.status = "feasible"
                    row.done_by = [None] * len(row.actions)
        out += self._plan()
        return out

    def _drop_human(self, ex: Execution, reason: str) -> None:
        """A person's execution ends, its hyper-arc not done."""
        self.executions.pop(ex.element, None)
        self._emit("abort", element=ex.element, reason=reason, agents=list(ex.agents))

    # -- the human ------------------------------------------------------------------------
    def _handle_human(self, action: HumanAction) -> list[Directive]:
        process = self._person_process_report(action)
        if process is not None:
            return process
        self._emit("human_action", action=str(action))
        out: list[Directive] = []
        ex = self._match_running_human(action)
        if ex is None:
            ex = self._recognise(action, out)
            if self.reaction == "paper":
                self._stop_every_robot(out, f"human did {action} (not suggested)")
        if ex is None:
            self._emit("human_action_unmatched", action=str(action))
        else:
            step = ex.branch.steps[ex.next_index]
            self._apply_effects(step)
            self._progress(ex, self._human_of(step))
        out += self._plan()
        return out

    def _human_of(self, step: GroundAction) -> str:
        humans = [a for a in step.agents if self.domain.agent(a).is_human]
        return humans[0] if humans else "human"

    def _stop_every_robot(self, out: list[Directive], reason: str) -> None:
        """Paper V-B: every robot action stops and every arm goes to rest. An execution whose
        hyper-arc's outcome already holds (S(parent) under its grounding: only releasing and
        resting are left) finishes: stopping it would undo nothing."""
        finishing: set[str] = set()
        for other in list(self.executions.values()):
            if other.owner != "robot":
                continue
            if self._outcome_holds(other):
                finishing.update(other.agents)
                continue
            self._abort(other, out, reason=reason)
        for agent, cmd in list(self.busy.items()):
            if cmd.process or self.domain.agent(agent).is_human or agent in finishing:
                continue
            if cmd.element is None and cmd.action.name == "rest":
                continue
            self._stop_agent(agent, cmd, reason, out)
            self._release(agent)
            self._rest(agent, out)

    def _outcome_holds(self, ex: Execution) -> bool:
        formula = self._formulas.get(self._parent(ex.element), ())
        if not formula:
            return False
        binding = ex.branch.grounding
        if self._transfers:
            binding = {**self._scope(ex.element), **binding}
        grounded = tuple(apply_substitution(lit, binding) for lit in formula)
        return holds(grounded, self.kb.facts)

    def _match_running_human(self, action: HumanAction) -> Execution | None:
        for ex in self.executions.values():
            if ex.owner != "human" or ex.next_index >= len(ex.branch.steps):
                continue
            step = ex.branch.steps[ex.next_index]
            if step.name == action.name and step.args == action.args:
                return ex
        return None

    def _unify(self, invocation: str, action: HumanAction) -> dict[str, str] | None:
        schema, terms = self.domain.invocation(invocation)
        if schema.name != action.name or len(terms) != len(action.args):
            return None
        binding: dict[str, str] = {}
        for term, value in zip(terms, action.args, strict=True):
            if is_variable(term):
                if binding.setdefault(term, value) != value:
                    return None
            elif term != value:
                return None
        return binding

    def _already_done(self, steps: list[GroundAction]) -> bool:
        """The earlier actions of a list count as done when their add effects hold."""
        facts = self.kb.facts
        for step in steps:
            adds = [apply_substitution(lit, step.binding) for lit in step.schema.add]
            if not adds or not holds(adds, facts):
                return False
        return True

    def _recognise(self, action: HumanAction, out: list[Directive]) -> Execution | None:
        """Which feasible hyper-arc does this unsuggested action advance? The action may be any
        action of A(h) whose earlier actions are already done; the binding it gives must ground
        the whole list. Cheapest hyper-arc first, then the earliest position in its list."""
        for cost, _, name in self._hyperarcs_by_cost():
            actions = self._describe(name)[1]
            if not actions:
                continue
            goal = self._formulas.get(self._parent(name), ())
            if goal and self.kb.query(goal, self._scope(name) if self._transfers else None):
                continue  # its outcome already holds (e.g. a robot just did it): not this one
            for index, invocation in enumerate(actions):
                binding = self._unify(invocation, action)
                if binding is None:
                    continue
                branch = self._recognised_branch(name, actions, binding, index)
                if branch is None:
                    continue
                self._take_over(name, branch, binding, out)
                ex = Execution(name, branch, "human", index, objects=self._objects(branch))
                self.executions[name] = ex
                row = self.table.rows.get(name)
                if row:
                    row.status = "running"
                self._emit(
                    "recognised",
                    action=str(action),
                    element=name,
                    cost=_num(cost),
                    index=index,
                )
                return ex
        return None

    def _recognised_branch(
        self, name: str, actions: tuple[str, ...], binding: dict[str, str], index: int
    ) -> Branch | None:
        fixed = {**self._child_binding(name), **binding}
        if any(self._child_binding(name).get(k, v) != v for k, v in binding.items()):
            return None  # the human's objects are not those the children were reached with

        def pick(constraints: list[Literal]) -> Branch | None:
            tree = DecisionTree.build(
                name,
                actions,
                constraints,
                self.domain,
                self.kb,
                available_agents=self._humans(),
                from_index=index,
                binding=fixed,
            )
            for b in tree.branches:
                if all(b.grounding.get(k, v) == v for k, v in binding.items()) and (
                    index == 0 or self._already_done(b.steps[:index])
                ):
                    return b
            return None

        # the action already happened: check the state it started from, with its binding
        branch = pick(self._constraints(name) if index == 0 else [])
        if branch is None and index == 0:
            # the children's state may already be consumed by the action's own effect
            branch = pick([])
        if branch is not None:
            branch.grounding.update(binding)
        return branch

    def _take_over(
        self, name: str, branch: Branch, binding: dict[str, str], out: list[Directive]
    ) -> None:
        """Stop whatever conflicts with the human's choice (reaction ``conflicts``; with
        ``paper`` every robot action is stopped by the caller anyway)."""
        children = set(self._children(name))
        objects = set(binding.values())
        for other in list(self.executions.values()):
            shared = set(self._children(other.element)) & children
            uses_object = bool(other.objects & objects)
            if other.element == name or shared or uses_object:
                if other.owner == "human":
                    self._drop_human(other, "human changed plan")
                else:
                    self._abort(other, out, reason=f"human does {name}")

    # -- inspection -----------------------------------------------------------------------
    def summary(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome,
            "reason": self.reason,
            "decisions": self.decisions,
            "branches_simulated": self.branches_simulated,
            "timing": {
                "task_manager_s": self.timing.task_manager_s,
                "task_representation_s": self.timing.task_representation_s,
                "simulator_s": self.timing.simulator_s,
            },
        }


#: the binding of an element nothing binds (shared: never changed)
_NO_BINDING: Substitution = {}


def check_failure_policy(value: str, option: str = "on_failure") -> str:
    """``value`` if it names a failure policy (:data:`FAILURE_POLICIES`), else one
    :class:`FlexhrcError` in the words of ``option`` (``--on-failure`` at the command line)."""
    if value not in FAILURE_POLICIES:
        raise FlexhrcError(f"{option} {value!r}: choose one of {', '.join(FAILURE_POLICIES)}")
    return value


def _num(x: float) -> float | int:
    return int(x) if float(x).is_integer() else x


__all__ = [
    "FAILURE_POLICIES",
    "REACTIONS",
    "Ack",
    "Command",
    "Directive",
    "Execution",
    "HumanAction",
    "ProcessRun",
    "Stop",
    "Suggest",
    "TakeRefused",
    "TaskManager",
    "check_failure_policy",
]
