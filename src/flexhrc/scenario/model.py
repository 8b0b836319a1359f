"""What a loaded scenario is: :class:`Scenario` and the operators it declares (:class:`HumanSpec`).

A :class:`Scenario` is immutable data plus factories: every call of :meth:`Scenario.world`
builds a fresh knowledge base and :meth:`Scenario.online_graph` a fresh online graph, so one
loaded scenario serves any number of runs (and a live cell, which owns its own copies).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.events import PROFILES as PROFILES
from flexhrc.events import SIMULATORS as SIMULATORS  # what a scenario file may name
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import Literal
from flexhrc.representation import HierarchicalGraph, OnlineGraph
from flexhrc.taskmanager.domain import Domain
from flexhrc.taskmanager.utility import Utility

Vec3 = tuple[float, float, float]

#: Where an operator's hand waits when the domain gives no ``hand`` for it.
DEFAULT_HAND: Vec3 = (1.10, 0.0, 0.10)


@dataclass(frozen=True)
class HumanSpec:
    """A simulated operator: the domain agent it plays, its profile and its speed (m/s)."""

    name: str
    profile: str = "passive"
    speed: float = 1.0


@dataclass(frozen=True)
class ObjectSpec:
    """One object of the world section."""

    name: str
    type: str
    position: Vec3
    size: Mapping[str, float] = field(default_factory=dict)
    fixed: bool = False
    attrs: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class WorldSpec:
    """Typed objects, places, initial facts and supertypes (``world:`` of a scenario)."""

    objects: tuple[ObjectSpec, ...] = ()
    places: Mapping[str, Vec3] = field(default_factory=dict)
    facts: tuple[Literal, ...] = ()
    supertypes: Mapping[str, str] = field(default_factory=dict)


@dataclass
class Scenario:
    """A cooperation task, loaded from one scenario file (see :mod:`flexhrc.scenario`)."""

    name: str
    description: str
    graph: HierarchicalGraph
    domain: Domain
    world_spec: WorldSpec
    humans: tuple[HumanSpec, ...] = ()
    simulator: str = "analytic"
    robot: Mapping[str, Any] = field(default_factory=dict)
    path: Path | None = None
    warnings: tuple[str, ...] = ()
    #: builds the knowledge base instead of the world section (scenarios built in code)
    world_factory: Callable[[], KnowledgeBase] | None = None
    #: the parts of a task split in segments that this scenario holds, in task order (the
    #: table assembly: ``tabletop``, ``legs``, ``check``); empty: the task is not split
    segments: tuple[str, ...] = ()
    #: the simulators the task can run on; another choice gets :attr:`simulator` (a bench of
    #: many arms: the analytic one only, the kinematic model is the dual-arm robot)
    simulators: tuple[str, ...] = SIMULATORS
    #: what a failed or timed-out robot action does to its hyper-arc (``on_failure:``):
    #: ``retry`` or ``paper`` (paper V-A); None: not said (``retry``, unless a run says otherwise)
    on_failure: str | None = None
    #: how long a person may leave a request unanswered before it counts as declined
    #: (``answer_timeout:``, seconds; ``--answer-timeout``); None: the manager waits
    answer_timeout: float | None = None
    #: how the Task Manager decides (``policy:``): ``paper`` or ``lookahead``
    #: (:mod:`flexhrc.planning`); None: not said (``paper``, unless a run says otherwise)
    policy: str | None = None
    #: how simulated actions are timed (:data:`flexhrc.taskmanager.kinds.TIMINGS`): ``default``,
    #: or ``paper`` (the paper's Baxter and operator, to set beside its Table I)
    timing: str = "default"
    #: the branch utility (``utility:``, :mod:`flexhrc.taskmanager.utility`); None: eq. (21)
    utility: Utility | None = None

    # -- factories ------------------------------------------------------------------------
    def world(self) -> KnowledgeBase:
        """A fresh knowledge base: the world's objects and places, one object per agent (its
        hand: a robot's ``rest`` or ``base``, an operator's ``hand``), the initial facts."""
        if self.world_factory is not None:
            return self.world_factory()
        w = self.world_spec
        kb = KnowledgeBase(supertypes=w.supertypes)
        for agent in self.domain.agents.values():
            if agent.name in kb.objects:
                continue
            typ = agent.types[0] if agent.types else agent.kind
            where = agent.params.get("hand" if agent.is_human else "rest")
            if where is None:
                where = agent.params.get("base")
            kb.add_object(agent.name, typ, _vec(where) if where is not None else DEFAULT_HAND)
        for o in w.objects:
            rec = kb.add_object(o.name, o.type, o.position, dict(o.size), **dict(o.attrs))
            rec.fixed = o.fixed
        for name, p in w.places.items():
            kb.add_object(name, "place", p)
        for lit in w.facts:
            kb.assert_fact(*lit.key())
        return kb

    def online_graph(self) -> OnlineGraph:
        return OnlineGraph(self.graph)

    def human(self, name: str) -> HumanSpec:
        for h in self.humans:
            if h.name == name:
                return h
        raise FlexhrcError(f"scenario {self.name!r} has no operator {name!r}")

    def make_simulator(self, choice: str | None = None) -> Any:
        """The branch simulator (also the execution model): ``analytic`` (durations from the
        domain, distances over speeds), ``kinematic`` (task-priority control on the robot model;
        the ``sim`` extra) or ``auto``; default (None): the scenario's ``simulator``. Chosen
        here, at the edge, and passed down to the Task Manager (and to the cell, which asks
        with None for the scenario's own choice)."""
        from flexhrc.scenario.simulators import choose_simulator, resolve_simulator_name

        name = resolve_simulator_name(choice or self.simulator)
        if name not in self.simulators:
            name = self.simulator
        return choose_simulator(name, timing=self.timing)[1]

    def summary_line(self) -> str:
        stats = self.graph.stats()
        robots = [a.name for a in self.domain.agents.values() if not a.is_human]
        return (
            f"{self.name}: {stats['graphs']} graph(s), {stats['layers']} layer(s), "
            f"{stats['instantiated_nodes']} nodes / {stats['instantiated_hyperarcs']} hyper-arcs "
            f"online; {len(self.domain.actions)} actions, {len(self.domain.processes)} processes; "
            f"robots {', '.join(robots) or 'none'}; operators "
            f"{', '.join(f'{h.name} ({h.profile})' for h in self.humans) or 'none'}; "
            f"{len(self.world_spec.objects)} objects, {len(self.world_spec.places)} places"
        )


def _vec(p: Any) -> Vec3:
    vals = [float(x) for x in p]
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals):
        raise FlexhrcError(f"a position needs three finite numbers, got {p!r}")
    return (vals[0], vals[1], vals[2])
