"""A wide workbench with independent sockets: enough parallel work for many arms and operators.

The table assembly fills its bolts in a fixed order, so at most one arm screws at a time. Here
``legs`` sockets are independent: the root ``assembled`` is reached by one immediate hyper-arc
from every ``connected_k``, and each ``connected_k`` has the robot and the human paths of the
table assembly (``robot_k`` cost 1, ``human_k`` cost 3) from its own leg (``kit(leg, bolt_k)``)
and socket nodes. The first ``human_legs`` legs lie where no arm reaches, so operators fix them. The
arms (``arm1`` ...) stand side by side along the bench, each reaching the sockets and legs in
front of it and its neighbours'; the operators (``op1`` ...) stand opposite. Branches are simulated
with the analytic simulator (the kinematic one models the dual-arm robot only).
"""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import parse_conjunction
from flexhrc.representation import AndOrGraph, HierarchicalGraph, Node
from flexhrc.scenario.builtin.table import ROBOT_DIRECT
from flexhrc.taskmanager.domain import Domain

if TYPE_CHECKING:
    from flexhrc.scenario.model import Scenario

ARM_SPACING = 0.5  # metres between neighbouring shoulders, along y
HUMAN = ("pick_up(?op, ?leg)", "screw(?op, ?leg, {bolt})")  # any of the operators


@dataclass
class _Bench:
    """The options of one bench (checked on creation); :func:`parallel_assembly` builds it."""

    arms: int = 6
    humans: int = 3
    legs: int = 12
    seed: int = 0
    human_legs: int = 0  # the first ones lie where no arm reaches: the operators fix them
    chain: bool = False  # socket k only after socket k-1 (one long sequence: long event logs)

    def __post_init__(self) -> None:
        for field, value, low in (("arms", self.arms, 1), ("humans", self.humans, 0)):
            if not low <= value <= 64:
                raise FlexhrcError(f"{field} must be in {low}..64, got {value}")
        if not 1 <= self.legs <= 256:
            raise FlexhrcError(f"legs must be in 1..256, got {self.legs}")
        if not 0 <= self.human_legs <= self.legs:
            raise FlexhrcError(
                f"human_legs must be in 0..legs ({self.legs}), got {self.human_legs}"
            )
        if self.human_legs and not self.humans:
            raise FlexhrcError("human_legs needs humans >= 1")

    def _y(self, i: int, n: int) -> float:
        return round((i - (n - 1) / 2) * ARM_SPACING, 4)

    def graph(self) -> HierarchicalGraph:
        root = f"connected_{self.legs}" if self.chain else "assembled"
        g = AndOrGraph("ParallelAssembly", root=root)
        if not self.chain:
            g.add_node(Node("assembled", 0, None))
        for k in range(1, self.legs + 1):
            bolt = f"bolt_{k}"
            # leg k belongs to socket k (a kit): the sockets never compete for legs
            g.add_node(Node(f"leg_{k}", 0, parse_conjunction(f"kit(?leg, {bolt}) & leg(?leg)")))
            if not self.chain or k == 1:
                g.add_node(Node(f"socket_{k}", 0, parse_conjunction(f"place({bolt})")))
            g.add_node(Node(f"connected_{k}", 0, parse_conjunction(f"filled({bolt})")))
            before = f"connected_{k - 1}" if self.chain and k > 1 else f"socket_{k}"
            children = [f"leg_{k}", before]
            fill = tuple(a.format(bolt=bolt) for a in ROBOT_DIRECT)
            human = tuple(a.format(bolt=bolt) for a in HUMAN)
            g.add_hyperarc(f"robot_{k}", children, f"connected_{k}", 1, actions=fill)
            if self.humans:
                g.add_hyperarc(f"human_{k}", children, f"connected_{k}", 3, actions=human)
        if not self.chain:
            g.add_hyperarc(
                "finish", [f"connected_{k}" for k in range(1, self.legs + 1)], "assembled", 0
            )
        h = HierarchicalGraph.single(g)
        h.validate()
        return h

    def domain(self) -> Domain:
        from importlib import resources

        import yaml

        text = resources.files("flexhrc.scenario.builtin").joinpath(
            "data/table_assembly/domain.yaml"
        )
        data: dict[str, Any] = yaml.safe_load(text.read_text(encoding="utf-8"))
        agents: dict[str, Any] = {}
        for i in range(self.arms):
            y = self._y(i, self.arms)
            agents[f"arm{i + 1}"] = {
                "kind": "robot",
                "types": ["arm"],
                "base": [0.0, y, 0.433],
                "rest": [0.307, y, 0.587],
                "reach": 0.9,
            }
        for j in range(self.humans):
            agents[f"op{j + 1}"] = {"kind": "human", "types": ["human"]}
        data["agents"] = agents
        return Domain.from_dict(data, "parallel_assembly (generated)")

    def world(self) -> KnowledgeBase:
        rng = random.Random(self.seed)
        kb = KnowledgeBase()
        dom = self.domain()
        for name, agent in dom.agents.items():
            if agent.is_human:
                j = int(name[2:]) - 1
                kb.add_object(name, "human", (1.1, self._y(j, self.humans), 0.1))
            else:
                kb.add_object(name, "arm", agent.params["rest"])
                kb.assert_fact("free", name)
        span = ARM_SPACING * max(self.arms - 1, 1)
        for k in range(1, self.legs + 1):
            y = round(-span / 2 + span * (k - 0.5) / self.legs, 4)
            kb.add_object(f"bolt_{k}", "place", (0.45, y, 0.0))
            leg = f"leg{k}"
            p = (round(rng.uniform(0.3, 0.4), 3), round(y + rng.uniform(-0.05, 0.05), 3), 0.0)
            attrs: dict[str, Any] = {"reachable_by": []} if k <= self.human_legs else {}
            kb.add_object(leg, "leg", p, {"length": 0.4, "diameter": 0.04}, **attrs)
            kb.assert_fact("on_table", leg)
            kb.assert_fact("kit", leg, f"bolt_{k}")
        kb.add_object("middle", "place", (0.7, 0.0, 0.1))
        return kb


def parallel_assembly(
    arms: int = 6,
    humans: int = 3,
    legs: int = 12,
    *,
    seed: int = 0,
    human_legs: int = 0,
    chain: bool = False,
    profile: str = "passive",
    name: str = "parallel_assembly",
) -> Scenario:
    """``legs`` independent sockets on one bench for ``arms`` arms and ``humans`` operators
    (see the module docstring) as a :class:`~flexhrc.scenario.Scenario`; ``chain`` makes
    socket k wait for socket k-1. Simulated with the analytic simulator (the kinematic one
    models the dual-arm robot only)."""
    from flexhrc.scenario.model import HumanSpec, Scenario, WorldSpec

    bench = _Bench(
        arms=arms, humans=humans, legs=legs, seed=seed, human_legs=human_legs, chain=chain
    )
    domain = bench.domain()
    return Scenario(
        name,
        f"A bench of {legs} independent sockets for {arms} arms and {humans} operators.",
        bench.graph(),
        domain,
        WorldSpec(),
        tuple(HumanSpec(a.name, profile) for a in domain.agents.values() if a.is_human),
        "analytic",
        world_factory=bench.world,
        simulators=("analytic",),
    )
