"""Generic simulated operators: they read the graph and the domain, not a script of the task.

A :class:`SimulatedOperator` plays one human agent of the domain (inside the cell's simulated
operator agent, :class:`flexhrc.cell.HumanAgent`). It sees what the Task Manager sees — the feasible
hyper-arcs with their costs (eq. 10) and the suggestions addressed to it — and the knowledge
base (what lies where). It follows a suggestion (``reluctant``: not always,
:meth:`SimulatedOperator.answer`). Besides, per profile, it acts on its own on the hyper-arcs
it may do (every action of A(h) doable by a human, as the domain's ``agents`` declare):

* ``passive`` — only when asked;
* ``takeover`` — takes every cooperation step it can, at once (paper Fig. 10);
* ``cooperative`` — takes one now and then (half of the time, after 0.5-2 s; Fig. 11);
* ``random`` — acts at random moments (0-6 s, 40 % of the steps) with random objects;
* ``reluctant`` — never acts on its own; of the suggestions it gets it declines a share
  (``decline_share``, 30 %, seeded) and answers ``cannot`` to every one with an action it
  cannot do: ``cannot_share`` (a quarter, seeded, at least one) of the domain's actions a person
  and an arm may both do — never an action only a person may do, so the cooperation stays
  solvable (:meth:`SimulatedOperator.answer`).

``takeover`` takes a step *before being asked*: a robot command the manager issued at this
very instant (``fresh``: the arm has not moved yet) does not hold its objects for it, so a
step the manager just gave an arm is still the operator's to take (the manager then stops the
arm, paper 000 V-C) — unless the node it reaches starts processes P(n) (arms keep working on
its parts there); the other profiles leave such a step to the arm.

A *step* is the parent node its hyper-arcs lead to: the operator decides once per step, in the
order the steps become reachable (for the table: bolt 1, bolt 2, ...). ``takes`` scripts it
instead: it takes exactly the K-th steps listed (1-based), whatever the profile — the paper's
Figs. 11 and 12 in tests and demos.

Its own choice of objects: the hyper-arc's decision tree restricted to this operator, objects
that no running execution reserves first, then the nearest to its hand (``random``: any). Two
operators never work on one object at once: a step is not taken while its objects are
reserved, and an action on an object another agent holds (the domain's ``on_stop.holding``
fact) fails — the operator gives up and the Task Manager continues.

What it can take beyond what it is asked: steps no arm is on (the Task Manager asks a person
only for what they are needed for or best at, so a step a busy arm does as well waits for that
arm — and for an operator who gets there first) and steps whose arm is still on its way (its
current action changes nothing yet, like the table's ``approach``). A step an arm has started
changing stays the arm's.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from flexhrc.events import PROFILES
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import apply_substitution
from flexhrc.taskmanager.decision import DecisionTree
from flexhrc.taskmanager.domain import ActionSchema, Domain, GroundAction

if TYPE_CHECKING:
    from flexhrc.taskmanager.manager import TaskManager


def operator_seed(seed: int, index: int) -> int:
    """The random seed of the ``index``-th operator (0-based) of a run with ``seed``: every front
    end derives it alike, so one seed means one cooperation in ``run`` and in a cell."""
    return seed * 1009 + index


@dataclass
class Intention:
    """An operator decided to act on its own on ``hyperarc`` (reaching ``step``), after
    ``delay_s``."""

    hyperarc: str
    step: str
    delay_s: float


@dataclass
class SimulatedOperator:
    """One simulated human agent (see the module docstring)."""

    name: str
    profile: str = "passive"
    seed: int = 0
    takes: set[int | str] | None = None
    #: robot commands issued at this very instant (``takeover`` gets there first)
    fresh: frozenset[int] = frozenset()
    #: ``reluctant``: the share of suggestions it declines
    decline_share: float = 0.3
    #: ``reluctant``: the share of the actions a person and an arm may both do that it cannot do
    cannot_share: float = 0.25
    #: ``reluctant``: the action names it cannot do (None: drawn from the domain, seeded)
    cannot: frozenset[str] | None = None
    rng: random.Random = field(init=False)
    steps_seen: list[str] = field(default_factory=list)  # target nodes, in order of appearance

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            from flexhrc.errors import FlexhrcError

            raise FlexhrcError(
                f"unknown human profile {self.profile!r}; choose one of {', '.join(PROFILES)}"
            )
        self.rng = random.Random(self.seed)

    # -- what it may do -------------------------------------------------------------------
    def may_do(self, tm: TaskManager, hyperarc: str) -> bool:
        """Every action of A(h) can be done by this operator (alone)."""
        actions = tm.actions_of(hyperarc)
        if not actions:
            return False
        for text in actions:
            schema, terms = tm.domain.invocation(text)
            if not tm.domain.human_may_do(schema):
                return False
            spec = schema.agents
            if spec.mode == "single" and self.name not in spec.names:
                return False
            if spec.mode == "choice":
                term = terms[schema.variables.index(str(spec.variable))]
                if not term.startswith("?") and term != self.name:
                    return False
                typ = dict(schema.parameters)[str(spec.variable)]
                if self.name not in [a.name for a in tm.domain.agents_of_type(typ)]:
                    return False
        return True

    def options(self, tm: TaskManager) -> dict[str, list[tuple[float, str]]]:
        """Feasible hyper-arcs it may do and nobody human does yet, by the step they reach."""
        running_human = {e for e, ex in tm.executions.items() if ex.owner == "human"}
        out: dict[str, list[tuple[float, str]]] = {}
        for h, cost in sorted(tm.feasible_hyperarcs().items(), key=lambda kv: (kv[1], kv[0])):
            if h in running_human or not self.may_do(tm, h):
                continue
            out.setdefault(tm.parent_of(h), []).append((cost, h))
        return out

    # -- deciding on its own ----------------------------------------------------------------

    def decide(self, step: str, arcs: Sequence[tuple[float, str]]) -> Intention | None:
        """The profile's choice, once, for a newly reachable ``step`` whose hyper-arcs this
        operator may do (``arcs``: (cost, hyper-arc), cheapest first): act on it, after how long
        and by which hyper-arc — or not. Also used by an operator agent of a live cell, which
        gets its ``arcs`` from the manager's ``options`` message."""
        if step not in self.steps_seen:
            self.steps_seen.append(step)
        if not arcs:
            return None
        k = self.steps_seen.index(step) + 1
        if self.takes is not None:
            # a step is named by its place in order (1-based) or by its node's name
            act = k in self.takes or step in self.takes or _local(step) in self.takes
            delay = 0.0
        elif self.profile == "takeover":
            act, delay = True, 0.0
        elif self.profile == "cooperative":
            act, delay = self.rng.random() < 0.5, self.rng.uniform(0.5, 2.0)
        elif self.profile == "random":
            act, delay = self.rng.random() < 0.4, self.rng.uniform(0.0, 6.0)
        else:  # passive and reluctant: only when asked
            return None
        if not act:
            return None
        hyperarc = self.rng.choice(list(arcs))[1] if self.profile == "random" else arcs[0][1]
        return Intention(hyperarc, step, delay)

    # -- answering a suggestion ----------------------------------------------------------------

    def cannot_do(self, domain: Domain) -> frozenset[str]:
        """The action names this operator cannot do (``reluctant``; the others can do all):
        ``cannot`` as given, else a seeded ``cannot_share`` (at least one) of the domain's
        actions that both a person and an arm may do, so an arm can always do them instead."""
        if self.profile != "reluctant":
            return frozenset()
        if self.cannot is None:
            shared = sorted(
                name
                for name, schema in domain.actions.items()
                if domain.human_may_do(schema) and _robot_may_do(domain, schema)
            )
            k = max(1, round(self.cannot_share * len(shared))) if shared else 0
            # its own generator: what it cannot do does not shift its other draws
            self.cannot = frozenset(random.Random(self.seed).sample(shared, k))
        return self.cannot

    def answer(self, actions: Sequence[GroundAction], domain: Domain) -> tuple[str, str | None]:
        """How it answers a suggestion of ``actions``: ``("follow", None)``, ``("decline",
        reason)`` (not now: the step goes back to the pool) or ``("cannot", reason)`` (this
        person never does that branch), sent by the operator's agent as the protocol's
        ``decline``/``cannot`` replies. Only ``reluctant`` says anything but ``follow``; a
        ``cannot`` does not use up a draw, so one seed gives the same declines."""
        if self.profile != "reluctant":
            return "follow", None
        unable = self.cannot_do(domain)
        for a in actions:
            if a.schema.name in unable and self.name in a.agents:
                return "cannot", f"{self.name} cannot {a.schema.name}"
        if self.rng.random() < self.decline_share:
            return "decline", f"{self.name}: not now"
        return "follow", None

    def candidate_branches(
        self, tm: TaskManager, kb: KnowledgeBase, hyperarc: str
    ) -> list[list[GroundAction]]:
        """The ground branches of ``hyperarc`` this operator can do alone now: objects no other
        agent works on or holds, those no execution reserves first (if there are any)."""
        actions = tm.actions_of(hyperarc)
        constraints = tm.constraints_of(hyperarc)
        reserved = tm.reserved_objects()
        in_use = self._in_use(tm, kb)
        # a object a robot only plans to use is still free to take; prefer the others
        for avoid in (reserved, set()):
            tree = DecisionTree.build(
                hyperarc,
                actions,
                constraints,
                tm.domain,
                kb,
                available_agents=[self.name],
                reserved=avoid,
                binding=tm.binding_of(hyperarc),
            )
            branches = [
                b
                for b in tree.branches
                if not self._held_by_other(kb, tm.domain, b.steps)
                and not in_use & {a for s in b.steps for a in s.args}
            ]
            if branches:
                return [list(b.steps) for b in branches]
        return []

    def pick_branch(
        self, kb: KnowledgeBase, domain: Domain, branches: Sequence[Sequence[GroundAction]]
    ) -> list[GroundAction]:
        """Its own choice among ``branches``: the nearest object to its hand (``random``: any)."""
        if self.profile == "random":
            return list(self.rng.choice(list(branches)))
        hand = kb.position(self.name) if self.name in kb.objects else (1.1, 0.0, 0.1)

        def distance(steps: list[GroundAction]) -> tuple[float, str]:
            first = next(
                (a for s in steps for a in s.args if a in kb.objects and a not in domain.agents),
                None,
            )
            if first is None:
                return (0.0, "")
            return (math.dist(hand, kb.position(first)), first)

        return min((list(b) for b in branches), key=distance)

    def _in_use(self, tm: TaskManager, kb: KnowledgeBase) -> set[str]:
        """Objects another agent works on right now: those a robot's current command changes
        (its effects name them — a mere approach does not: that part is still free to take,
        the Task Manager then stops the robot), and those of another operator's execution."""
        agents = tm.domain.agents
        out: set[str] = set()
        for cmd in tm.busy.values():
            if self.profile == "takeover" and cmd.id in self.fresh and self._first_on(tm, cmd):
                continue  # issued this instant: the arm has not moved, the operator is first
            schema, binding = cmd.action.schema, cmd.action.binding
            for lit in (*schema.add, *schema.delete):
                for term in lit.args:
                    value = binding.get(term, term)
                    if value in kb.objects and value not in agents:
                        out.add(value)
        for ex in tm.executions.values():
            if ex.owner == "human" and self.name not in ex.agents:
                for step in ex.branch.steps[ex.next_index :]:
                    out.update(a for a in step.args if a in kb.objects and a not in agents)
        return out

    @staticmethod
    def _first_on(tm: TaskManager, cmd: Any) -> bool:
        """A step a fresh command is on may go to a takeover operator unless the node it
        reaches starts processes P(n): there the arms keep working on the parts (the table's
        hold of the tabletop), and a person's hand in the way would stall them."""
        element = cmd.element
        if element is None or cmd.process:
            return False
        try:
            return not tm.has_processes(tm.parent_of(element))
        except KeyError:
            return False

    def holder_of(self, kb: KnowledgeBase, domain: Domain, step: GroundAction) -> str | None:
        """Another agent holding an object this step works on (then the step cannot be done)."""
        return self._held_by_other(kb, domain, [step])

    def _held_by_other(
        self, kb: KnowledgeBase, domain: Domain, steps: list[GroundAction]
    ) -> str | None:
        rule = domain.on_stop
        objects = {a for s in steps for a in s.args if a in kb.objects and a not in domain.agents}
        for obj in objects:
            probe = apply_substitution(rule.holding, {rule.object_var: obj})
            for sub in kb.query([probe]):
                holder = sub.get(rule.agent_var)
                if holder is not None and holder != self.name:
                    return holder
        return None


__all__ = ["PROFILES", "Intention", "SimulatedOperator", "operator_seed"]


def _robot_may_do(domain: Domain, schema: ActionSchema) -> bool:
    """Some arm of the domain may do ``schema``."""
    spec = schema.agents
    if spec.mode == "choice":
        typ = dict(schema.parameters)[str(spec.variable)]
        return any(not a.is_human for a in domain.agents_of_type(typ))
    return all(not domain.agent(n).is_human for n in spec.names)


def _local(qualified: str) -> str:
    """A node's own name, without the instance path of its lower graph (``h1/Leg`` -> ``Leg``)."""
    return qualified.rsplit("/", 1)[-1]
