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
4. the best branch's first action goes to its robot arm (:class:`Command`), or — when only the
   human can do it — to the human as a :class:`Suggest`.

A human action that was not suggested is matched to the feasible hyper-arc it advances; any robot
element that conflicts with it is stopped (:class:`Stop`), the arm sent to rest, and the manager
continues from the new state. The cooperation ends ``solved`` (the root is met) or ``failed``
with a reason (no feasible element left).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import Literal, apply_substitution, is_variable
from flexhrc.representation import OnlineGraph
from flexhrc.taskmanager.decision import ActionStateTable, Branch, DecisionTree
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.simulator import Simulator, default_simulator


# ----------------------------------------------------------------------------- directives --
@dataclass
class Command:
    """Execute one ground action (robot agents)."""

    id: int
    agents: tuple[str, ...]
    action: GroundAction
    element: str | None  # hyper-arc it belongs to; None for a lone 'rest'
    index: int
    expected_s: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "command",
            "id": self.id,
            "agents": list(self.agents),
            "action": str(self.action),
            "element": self.element,
            "index": self.index,
            "expected_s": round(self.expected_s, 6),
        }


@dataclass
class Suggest:
    """Ask the human to carry out an element's actions."""

    element: str
    actions: list[GroundAction]
    cost: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": "suggestion",
            "element": self.element,
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
class Execution:
    """An element being carried out with the grounding and agents of its chosen branch."""

    element: str
    branch: Branch
    owner: str  # "robot" or "human"
    next_index: int = 0
    command: Command | None = None
    objects: set[str] = field(default_factory=set)  # KB objects its grounding uses


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
    ):
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
        self.waiting_for_consistency = False
        self.unavailable: set[str] = set()  # agents that left the cell (e.g. a dead process)
        self._answer = graph.query()
        self._formulas = self._collect_formulas()

    # -- public API -----------------------------------------------------------------------
    def start(self, now: float = 0.0) -> list[Directive]:
        return self._entry(now, self._plan)

    def on_ack(self, now: float, ack: Ack) -> list[Directive]:
        return self._entry(now, lambda: self._handle_ack(ack))

    def on_human_action(self, now: float, action: HumanAction) -> list[Directive]:
        return self._entry(now, lambda: self._handle_human(action))

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

    # -- plumbing -------------------------------------------------------------------------
    def _entry(self, now: float, body: Callable[[], list[Directive]]) -> list[Directive]:
        self._now = now
        t0 = self._timer()
        rep0, sim0 = self.timing.task_representation_s, self.timing.simulator_s
        try:
            return body()
        finally:
            spent = self._timer() - t0
            inner = (self.timing.task_representation_s - rep0) + (self.timing.simulator_s - sim0)
            self.timing.task_manager_s += max(0.0, spent - inner)

    def _emit(self, kind: str, **data: Any) -> None:
        data.pop("type", None)
        self._log({"t": round(self._now, 6), "type": kind, **data})

    def _update_graph(self, **kw: Iterable[str]) -> None:
        t0 = self._timer()
        self._answer = self.graph.update(**kw)
        self.timing.task_representation_s += self._timer() - t0
        self._emit(
            "query",
            report={k: list(v) for k, v in kw.items() if v},
            outcome=self._answer.outcome,
            feasible={k: _num(v) for k, v in self._answer.feasible.items()},
        )
        if self._answer.solved:
            self._finish("solved", None)
        elif self._answer.failed:
            self._finish("failed", self._answer.reason)

    def _finish(self, outcome: str, reason: str | None) -> None:
        if self.outcome == "running":
            self.outcome, self.reason = outcome, reason
            self._emit("outcome", outcome=outcome, reason=reason)

    def _collect_formulas(self) -> dict[str, tuple[Literal, ...]]:
        out: dict[str, tuple[Literal, ...]] = {}
        for name in self.graph.elements():
            if self.graph.kind(name) == "node":
                node = self.graph.definition_of(name).nodes[self.graph.local_name(name)]
                out[name] = node.formula if node.formula is not None else ()
        return out

    def _describe(self, name: str) -> tuple[str, tuple[str, ...]]:
        g = self.graph.definition_of(name)
        local = self.graph.local_name(name)
        if self.graph.kind(name) == "node":
            return "node", tuple(g.nodes[local].processes)
        return "hyperarc", tuple(g.hyperarcs[local].actions)

    def _children(self, element: str) -> list[str]:
        g = self.graph.definition_of(element)
        h = g.hyperarcs[self.graph.local_name(element)]
        prefix = self.graph.graph_of(element)
        return [f"{prefix}/{c}" if prefix else c for c in h.children]

    def _parent(self, element: str) -> str:
        g = self.graph.definition_of(element)
        h = g.hyperarcs[self.graph.local_name(element)]
        prefix = self.graph.graph_of(element)
        return f"{prefix}/{h.parent}" if prefix else h.parent

    # -- deciding -------------------------------------------------------------------------
    def _meet_nodes(self) -> None:
        """Meet feasible nodes whose state holds (processes: none modelled as pending)."""
        while self.outcome == "running":
            met = []
            for name in self._answer.feasible:
                if self.graph.kind(name) != "node":
                    continue
                formula = self._formulas.get(name, ())
                if not formula or self.kb.query(formula):
                    met.append(name)
            if not met:
                return
            self._update_graph(met_nodes=met)

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
        for _ in range(10_000):
            if self.done:
                return out
            self.table.refresh(self._answer.feasible, self._describe)
            started = self._start_next(out)
            if not started:
                break
        return out

    def _conflicts(self, element: str) -> bool:
        if element in self.executions:
            return True
        children = set(self._children(element))
        return any(children & set(self._children(e)) for e in self.executions)

    def _start_next(self, out: list[Directive]) -> bool:
        """Start the cheapest startable element; True if something changed."""
        candidates = sorted(
            (
                (cost, self.graph.element_id(name), name)
                for name, cost in self._answer.feasible.items()
                if self.graph.kind(name) == "hyperarc"
            ),
        )
        robots_idle = self.idle_robots
        human_busy = any(ex.owner == "human" for ex in self.executions.values())
        for cost, _, name in candidates:
            if self._conflicts(name):
                continue
            actions = self._describe(name)[1]
            if not actions:  # nothing to do: the transition is immediate
                self._update_graph(solved_hyperarcs=[name])
                self._meet_nodes()
                return True
            available = list(robots_idle) + ([] if human_busy else self._humans())
            reserved = set().union(*(ex.objects for ex in self.executions.values()))
            constraints = [lit for c in self._children(name) for lit in self._formulas.get(c, ())]
            tree = DecisionTree.build(
                name,
                actions,
                constraints,
                self.domain,
                self.kb,
                exclude=self.failed.get(name, ()),
                available_agents=available,
                reserved=reserved,
            )
            if not tree.branches:
                # no branch with the agents free now: maybe later (an agent is busy)
                if self._could_run_later(name, actions, constraints, reserved):
                    continue
                self._emit("infeasible", element=name, reason="no grounding or agent left")
                self._update_graph(infeasible=[name])
                self._meet_nodes()
                return True
            t0 = self._timer()
            best = tree.evaluate(self.simulator, self.kb, self.domain)
            self.timing.simulator_s += self._timer() - t0
            self.decisions += 1
            self.branches_simulated += len(tree.branches)
            self._emit(
                "decision",
                element=name,
                cost=_num(cost),
                branches=[b.to_dict() for b in tree.branches],
                chosen=tree.branches.index(best) if best else None,
            )
            if best is None:
                self.failed.setdefault(name, []).extend(dict(b.grounding) for b in tree.branches)
                if not self._could_run_later(name, actions, constraints, reserved):
                    self._emit("infeasible", element=name, reason="every branch scores 0")
                    self._update_graph(infeasible=[name])
                    self._meet_nodes()
                    return True
                continue
            self._launch(name, best, cost, out)
            return True
        return False

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
        tree = DecisionTree.build(
            name, actions, constraints, self.domain, self.kb, exclude=self.failed.get(name, ())
        )
        return bool(tree.branches) and (bool(self.busy) or bool(reserved) or bool(self.executions))

    def _launch(self, name: str, branch: Branch, cost: float, out: list[Directive]) -> None:
        human = any(self.domain.agent(a).is_human for a in branch.agents)
        ex = Execution(name, branch, "human" if human else "robot", objects=self._objects(branch))
        self.executions[name] = ex
        row = self.table.rows.get(name)
        if row:
            row.status = "running"
        if human:
            sug = Suggest(name, list(branch.steps), cost)
            self._emit("suggestion", **sug.to_dict())
            out.append(sug)
        else:
            out.append(self._command(ex))

    def _command(self, ex: Execution) -> Command:
        step = ex.branch.steps[ex.next_index]
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
        ex = self.executions.get(cmd.element) if cmd.element else None
        if ack.status == "done":
            self._apply_effects(cmd.action)
            if ex is not None:
                self._progress(ex, cmd.agents[0])
                if ex.element in self.executions and not self.done:
                    out.append(self._command(ex))
        else:
            if ex is not None:
                self.failed.setdefault(ex.element, []).append(dict(ex.branch.grounding))
                self._emit(
                    "action_failed",
                    element=ex.element,
                    grounding=ex.branch.grounding,
                    status=ack.status,
                    reason=ack.reason,
                )
                self._abort(ex, out, reason=f"{cmd.action} {ack.status}")
        out += self._plan()
        return out

    def _progress(self, ex: Execution, who: str) -> None:
        row = self.table.rows.get(ex.element)
        if row and ex.next_index < len(row.done_by):
            row.done_by[ex.next_index] = who
        ex.next_index += 1
        if ex.next_index >= len(ex.branch.steps):
            del self.executions[ex.element]
            ex.command = None
            if row:
                row.status = "solved"
            self._emit(
                "solved",
                element=ex.element,
                agents=list(ex.branch.agents),
                grounding=dict(ex.branch.grounding),
            )
            self._update_graph(solved_hyperarcs=[ex.element])
            self._meet_nodes()

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
        self._emit("abort", element=ex.element, reason=reason)
        for agent in ex.branch.agents:
            if self.domain.agent(agent).is_human:
                continue
            cmd = self.busy.pop(agent, None)
            if cmd is not None:
                out.append(Stop(agent, cmd.id, reason))
                self._emit("stop", agent=agent, command=cmd.id, reason=reason)
            for fact in sorted(self.kb.facts):
                if fact[0] == "holding" and fact[1] == agent:
                    obj = fact[2]
                    self.kb.retract_fact(*fact)
                    self.kb.assert_fact("on_table", obj)
                    self.kb.assert_fact("free", agent)
                    if agent in self.kb.objects:
                        p = self.kb.position(agent)
                        self.kb.move(obj, (p[0], p[1], 0.0))
            if "rest" in self.domain.actions:
                rest = GroundAction(self.domain.actions["rest"], (agent,), (agent,))
                t0 = self._timer()
                sim = self.simulator.simulate([rest], self.kb, self.domain)
                self.timing.simulator_s += self._timer() - t0
                cmd = Command(next(self._ids), (agent,), rest, None, 0, sim.total_s)
                self.busy[agent] = cmd
                self._emit("command", **cmd.to_dict())
                out.append(cmd)

    # -- the human ------------------------------------------------------------------------
    def _handle_human(self, action: HumanAction) -> list[Directive]:
        self._emit("human_action", action=str(action))
        out: list[Directive] = []
        ex = self._match_running_human(action)
        if ex is None:
            ex = self._recognise(action, out)
        if ex is None:
            self._emit("human_action_unmatched", action=str(action))
            out += self._plan()
            return out
        step = ex.branch.steps[ex.next_index]
        self._apply_effects(step)
        self._progress(ex, "human")
        out += self._plan()
        return out

    def _match_running_human(self, action: HumanAction) -> Execution | None:
        for ex in self.executions.values():
            if ex.owner != "human" or ex.next_index >= len(ex.branch.steps):
                continue
            step = ex.branch.steps[ex.next_index]
            if step.name == action.name and step.args == action.args:
                return ex
        return None

    def _recognise(self, action: HumanAction, out: list[Directive]) -> Execution | None:
        """Which feasible hyper-arc does this unsuggested action advance? Cheapest match."""
        candidates = sorted(
            (cost, self.graph.element_id(n), n)
            for n, cost in self._answer.feasible.items()
            if self.graph.kind(n) == "hyperarc"
        )
        for cost, _, name in candidates:
            actions = self._describe(name)[1]
            if not actions:
                continue
            goal = self._formulas.get(self._parent(name), ())
            if goal and self.kb.query(goal):
                continue  # its outcome already holds (e.g. a robot just did it): not this one
            schema, terms = self.domain.invocation(actions[0])
            if schema.name != action.name or len(terms) != len(action.args):
                continue
            binding: dict[str, str] = {}
            ok = True
            for term, value in zip(terms, action.args, strict=True):
                if is_variable(term):
                    if binding.setdefault(term, value) != value:
                        ok = False
                elif term != value:
                    ok = False
            if not ok:
                continue
            constraints = [
                apply_substitution(lit, binding)
                for c in self._children(name)
                for lit in self._formulas.get(c, ())
            ]
            # the action already happened: check the state it started from, with its binding
            tree = DecisionTree.build(
                name, actions, constraints, self.domain, self.kb, available_agents=self._humans()
            )
            branch = next(
                (
                    b
                    for b in tree.branches
                    if all(b.grounding.get(k, v) == v for k, v in binding.items())
                ),
                None,
            )
            if branch is None:
                # the precondition may already be consumed by the action's own effect
                tree = DecisionTree.build(
                    name, actions, [], self.domain, self.kb, available_agents=self._humans()
                )
                branch = next(
                    (
                        b
                        for b in tree.branches
                        if all(b.grounding.get(k) == v for k, v in binding.items())
                    ),
                    None,
                )
            if branch is None:
                continue
            branch.grounding.update(binding)
            # stop whatever conflicts with the human's choice
            for other in list(self.executions.values()):
                shared = set(self._children(other.element)) & set(self._children(name))
                uses_object = bool(other.objects & set(binding.values()))
                if other.element == name or shared or uses_object:
                    if other.owner == "human":
                        self.executions.pop(other.element, None)
                        self._emit("abort", element=other.element, reason="human changed plan")
                    else:
                        self._abort(other, out, reason=f"human does {name}")
            ex = Execution(name, branch, "human", objects=self._objects(branch))
            self.executions[name] = ex
            row = self.table.rows.get(name)
            if row:
                row.status = "running"
            self._emit("recognised", action=str(action), element=name, cost=_num(cost))
            return ex
        return None

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


def _num(x: float) -> float | int:
    return int(x) if float(x).is_integer() else x


__all__ = [
    "Ack",
    "Command",
    "Directive",
    "Execution",
    "HumanAction",
    "Stop",
    "Suggest",
    "TaskManager",
]
