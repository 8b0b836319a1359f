"""Simulating decision-tree branches (paper 000, V-A and eq. 21).

The Task Manager scores each branch of a decision tree by simulating its ordered actions: a
:class:`Simulator` returns whether every action succeeds and how long each takes. The utility of
a branch is ``J(b) = success(b) / sum(t_i)`` (eq. 21).

:class:`AnalyticSimulator` is the default: straight-line distances at nominal speeds, fixed times
for grasping and screwing, a reach sphere per robot arm, and an optional seeded failure model.
An action whose domain entry declares ``duration`` (seconds) and ``moves_to`` (the parameter its
hand goes to) is timed from those alone, so a scenario file needs no code for its actions; any
other is timed by its kind's model (:mod:`flexhrc.taskmanager.kinds`).
The kinematic simulator of :mod:`flexhrc.action` implements the same :class:`Simulator`
protocol; it is chosen at the edge (:mod:`flexhrc.scenario.simulators`), never imported here.
Simulations never modify the knowledge base: positions are tracked on the side.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Agent, Domain, GroundAction
from flexhrc.taskmanager.kinds import StepContext, Timing, kind_of

Vec3 = tuple[float, float, float]


@dataclass
class SimulationResult:
    """Outcome of simulating an ordered list of actions."""

    success: bool
    durations: list[float]
    reason: str | None = None
    details: list[dict[str, object]] = field(default_factory=list)

    @property
    def total_s(self) -> float:
        return sum(self.durations)

    @property
    def utility(self) -> float:
        """J(b) = success(b) / sum of action times (eq. 21)."""
        total = self.total_s
        return (1.0 / total) if self.success and total > 0 else 0.0


class Simulator(Protocol):
    """Anything that can tell success and durations of an action sequence.

    A simulator may also offer ``simulate_many(branches, kb, domain) -> list[SimulationResult]``
    (every branch of one decision at once, in order, each result what :meth:`simulate` would
    give): :meth:`DecisionTree.evaluate <flexhrc.taskmanager.decision.DecisionTree.evaluate>`
    then uses it, so branches can share their work (the kinematic simulator does, issue 23).
    It is optional: a simulator with ``simulate`` alone works as before.
    """

    def simulate(
        self, steps: Sequence[GroundAction], kb: KnowledgeBase, domain: Domain
    ) -> SimulationResult: ...


@dataclass
class StepReport:
    """How one command went on the (simulated) real robot or operator."""

    status: str  # done | failed | timed_out
    duration_s: float
    reason: str | None = None


class ExecutionModel(Protocol):
    """The simulated "real" world an agent acts in (a simulated arm or operator agent of the
    cell, :mod:`flexhrc.cell.components`). ``positions`` holds where objects and end effectors
    are; the model updates it with the physical outcome of the action."""

    def execute(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> StepReport: ...


class AnalyticSimulator:
    """Distances over speeds, reach spheres, seeded failures (the timing of each action kind).

    Robot arms are agents with ``base`` (shoulder position), ``reach`` (m) and ``rest``
    (end-effector rest position) parameters; their current end-effector position is the KB
    object of the same name. Places and objects are KB objects with positions. A robot action
    whose target is farther than ``reach`` from the arm's base fails ("unreachable").
    ``failure_rate`` makes each robot action fail with that probability (seeded).
    """

    name = "analytic"

    def __init__(
        self,
        timing: Timing | None = None,
        *,
        failure_rate: float = 0.0,
        seed: int = 0,
    ):
        if not 0.0 <= failure_rate <= 1.0:
            raise ValueError(f"failure_rate must be in [0, 1], got {failure_rate}")
        self.timing = timing or Timing()
        self.failure_rate = failure_rate
        self._rng = random.Random(seed)
        self._simulated: dict[tuple[str, tuple[str, ...]], str] = {}

    @property
    def simulated(self) -> dict[str, str]:
        """How each ground action simulated so far was: ``analytic``, or ``none`` (a kind
        without motion, :mod:`flexhrc.taskmanager.kinds`), by its text (``grasp(left, leg1)``)."""
        return simulated_record(self._simulated)

    # -- one action -----------------------------------------------------------------------
    def step(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> tuple[bool, float, str | None]:
        """Simulate one action from ``positions`` (updated in place): success, time, reason.

        Declared ``duration``/``moves_to`` time it (:meth:`_declared_step`); otherwise its kind's
        timing model (:mod:`flexhrc.taskmanager.kinds`): an operator's (default 2 s), or each
        arm's (default 1 s; a joint action lasts as long as its slowest arm)."""
        kind = kind_of(action.schema)
        self._simulated[action.name, action.args] = "analytic" if kind.moves else "none"
        ok, dt, why = self._step(action, positions, kb, domain)
        t = self.timing
        if ok and (t.human_action_overhead or t.robot_action_overhead):
            # the profile's time besides the motion (e.g. the paper's Baxter, Timing)
            if any(domain.agent(a).is_human for a in action.agents):
                dt += t.human_action_overhead
            elif kind.moves:
                dt += t.robot_action_overhead
        return ok, dt, why

    def _step(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> tuple[bool, float, str | None]:
        """:meth:`step` without the profile's per-action overheads."""
        kind = kind_of(action.schema)
        if action.schema.duration is not None or action.schema.moves_to is not None:
            return self._declared_step(action, positions, kb, domain)
        agents = [domain.agent(a) for a in action.agents]
        for agent in agents:
            if agent.is_human:
                ctx = StepContext(action, agent, positions, kb, self.timing)
                return kind.human_time(ctx) if kind.human_time else (True, 2.0, None)
        longest = 0.0
        for arm in agents:
            ctx = StepContext(action, arm, positions, kb, self.timing)
            ok, dt, why = kind.robot_time(ctx) if kind.robot_time else (True, 1.0, None)
            if not ok:
                return False, dt, why
            longest = max(longest, dt)
        if kind.fallible and self.failure_rate and self._rng.random() < self.failure_rate:
            return False, longest, f"{action} failed (simulated fault)"
        return True, longest, None

    def _declared_step(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> tuple[bool, float, str | None]:
        """An action whose domain declares ``duration`` and/or ``moves_to``: each agent's hand
        travels to the ``moves_to`` object or place at its speed (a robot arm's ``speed``,
        default :attr:`Timing.robot_speed`; an operator's ``speed``, default
        :attr:`Timing.human_speed`), then works ``duration`` s; a robot target beyond the arm's
        ``reach`` from its ``base`` (or leaving it out of ``reachable_by``) fails. A joint action
        lasts as long as its slowest agent. No scenario-specific code is needed."""
        schema = action.schema
        target_name = action.binding.get(schema.moves_to) if schema.moves_to else None
        target: Vec3 | None = None
        if target_name is not None and target_name in kb.objects:
            target = positions.get(target_name) or kb.position(target_name)
        longest = 0.0
        for name in action.agents:
            agent = domain.agent(name)
            ok, travel, why = self._travel(agent, target, target_name, positions, kb)
            if not ok:
                return False, 0.0, why
            longest = max(longest, travel)
        total = longest + (schema.duration or 0.0)
        robots = [a for a in action.agents if not domain.agent(a).is_human]
        if robots and self.failure_rate and self._rng.random() < self.failure_rate:
            return False, total, f"{action} failed (simulated fault)"
        return True, total, None

    def _travel(
        self,
        agent: Agent,
        target: Vec3 | None,
        target_name: str | None,
        positions: dict[str, Vec3],
        kb: KnowledgeBase,
    ) -> tuple[bool, float, str | None]:
        params: Mapping[str, object] = agent.params
        default = self.timing.human_speed if agent.is_human else self.timing.robot_speed
        speed = float(params.get("speed", default))  # type: ignore[arg-type]
        here = positions.get(agent.name) or (
            kb.position(agent.name) if agent.name in kb.objects else None
        )
        if target is None or here is None:
            return True, 0.0, None
        if not agent.is_human:
            rec = kb.objects.get(target_name or "")
            allowed = rec.attrs.get("reachable_by") if rec is not None else None
            if allowed is not None and agent.name not in allowed:
                return False, 0.0, f"{target_name} cannot be reached by {agent.name} (blocked)"
            if "base" in params:
                base = tuple(float(v) for v in params["base"])  # type: ignore[attr-defined]
                reach = float(params.get("reach", 0.85))  # type: ignore[arg-type]
                d = math.dist(base, target)
                if d > reach:
                    return (
                        False,
                        0.0,
                        f"{target_name} is out of reach of {agent.name} "
                        f"({d:.2f} m > {reach:.2f} m)",
                    )
        positions[agent.name] = target
        return True, math.dist(here, target) / max(speed, 1e-6), None

    def execute(
        self, action: GroundAction, positions: dict[str, Vec3], kb: KnowledgeBase, domain: Domain
    ) -> StepReport:
        """As an :class:`ExecutionModel`: the same model plays the real world."""
        ok, duration, why = self.step(action, positions, kb, domain)
        return StepReport("done" if ok else "failed", duration, why)

    # -- a sequence -----------------------------------------------------------------------
    def simulate(
        self, steps: Sequence[GroundAction], kb: KnowledgeBase, domain: Domain
    ) -> SimulationResult:
        positions: dict[str, Vec3] = {}
        durations: list[float] = []
        details: list[dict[str, object]] = []
        for action in steps:
            before = hands(action, positions, kb)
            ok, dt, why = self.step(action, positions, kb, domain)
            durations.append(dt)
            details.append(step_detail(action, dt, before, positions))
            if not ok:
                return SimulationResult(False, durations, why, details)
        return SimulationResult(True, durations, None, details)


def simulated_record(seen: Mapping[tuple[str, tuple[str, ...]], str]) -> dict[str, str]:
    """``{"grasp(left, leg1)": how}`` from ``{("grasp", ("left", "leg1")): how}`` (a simulator
    keeps the tuples: formatting every simulated step would cost more than the step)."""
    return {f"{name}({', '.join(args)})": how for (name, args), how in seen.items()}


def default_simulator() -> Simulator:
    """The simulator the Task Manager uses when it is given none: the :class:`AnalyticSimulator`.

    The Task Manager stays unaware of the action level (which imports this module); the
    kinematic simulator is chosen at the edge — the command line, a scenario loader, a cell —
    with :func:`flexhrc.scenario.simulators.choose_simulator` and passed in.
    """
    return AnalyticSimulator()


def simulator_name(simulator: object) -> str:
    """A short name for a simulator (``analytic``, ``kinematic`` ...), for logs and JSON."""
    name = getattr(simulator, "name", None)
    if isinstance(name, str) and name:
        return name
    cls = type(simulator).__name__
    for suffix in ("TaskSimulator", "Simulator"):
        if cls.endswith(suffix) and cls != suffix:
            return cls[: -len(suffix)].lower()
    return cls.lower()


def hands(
    action: GroundAction, positions: Mapping[str, Vec3], kb: KnowledgeBase
) -> dict[str, Vec3]:
    """Where the hands of ``action``'s agents are before it (the simulation's own positions,
    else the knowledge base's)."""
    out: dict[str, Vec3] = {}
    for a in action.agents:
        p = positions.get(a) or (kb.position(a) if a in kb.objects else None)
        if p is not None:
            out[a] = p
    return out


def step_detail(
    action: GroundAction, t: float, before: Mapping[str, Vec3], positions: Mapping[str, Vec3]
) -> dict[str, object]:
    """One step of a :class:`SimulationResult`'s ``details``: the action, its agents, its time
    and the paths of the hands it moved (:func:`hand_paths`)."""
    return {
        "action": str(action),
        "agents": list(action.agents),
        "t": t,
        **hand_paths(before, positions),
    }


def hand_paths(before: Mapping[str, Vec3], positions: Mapping[str, Vec3]) -> dict[str, object]:
    """``{"paths": {agent: [from, to]}}`` for each hand a simulated step moved — the planned
    end-effector path the operator's view draws before the arm moves (the paper's "upcoming
    end-effector trajectories"); ``{}`` when no hand moved."""
    paths = {
        a: [[round(v, 4) for v in p], [round(v, 4) for v in positions[a]]]
        for a, p in before.items()
        if a in positions and tuple(positions[a]) != tuple(p)
    }
    return {"paths": paths} if paths else {}
