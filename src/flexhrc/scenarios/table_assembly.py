"""The cooperative table assembly of FlexHRC+ (paper 000, VI-D, Figs. 5 and 9-12).

A dual-arm robot and a human operator fix N legs (default 4) to a tabletop, bolt by bolt in a
fixed order. The single-layer first-order AND/OR graph has, for every bolt k, the four
cooperation paths of Fig. 5:

=================  ==================================================  ======
path               hyper-arcs                                          cost
=================  ==================================================  ======
robot direct       ``robot_k``                                           1
robot via middle   ``to_middle_k`` then ``robot_from_middle_k``          2
robot then human   ``to_middle_k`` then ``human_from_middle_k``          3
human direct       ``human_k``                                           3
=================  ==================================================  ======

Nodes are first order: ``leg_k`` is ``leg(?leg) & on_table(?leg)`` — *some* leg on the table —
so the same graph serves legs of any length and either tabletop; which leg and which arm is
decided at run time by the decision tree (4 legs x 2 arms = 8 branches at the start). The
"middle pose" lies in front of the human, where either arm can leave a leg for the other arm or
for the operator (the reason for the middle paths: one arm may reach a leg but not its bolt).
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import parse_conjunction
from flexhrc.representation import AndOrGraph, HierarchicalGraph, Node
from flexhrc.taskmanager.domain import Domain

# Geometry (metres, x forward, y left, z up, table at z = 0) sized for flexhrc.action's dual-arm
# robot, so the analytic and the kinematic simulator see the same workspace.
TABLETOPS = {"large": (0.30, 0.40), "small": (0.26, 0.34)}  # width (x), depth (y)
LEG_LENGTHS = {"long": 0.40, "short": 0.30}
TABLETOP_CENTRE = (0.45, 0.0, 0.0)
MIDDLE_POSE = (0.70, 0.0, 0.10)  # a stand between the tabletop and the operator
HUMAN_HAND = (1.10, 0.0, 0.10)

ROBOT_DIRECT = (
    "approach(?arm, ?leg)",
    "grasp(?arm, ?leg)",
    "transport(?arm, ?leg, {bolt})",
    "screw(?arm, ?leg, {bolt})",
    "ungrasp(?arm, ?leg)",
    "rest(?arm)",
)
TO_MIDDLE = (
    "approach(?arm, ?leg)",
    "grasp(?arm, ?leg)",
    "transport(?arm, ?leg, middle)",
    "ungrasp(?arm, ?leg)",
    "rest(?arm)",
)
HUMAN = ("pick_up(human, ?leg)", "screw(human, ?leg, {bolt})")


def build_graph(legs: int = 4) -> HierarchicalGraph:
    """The FOL AND/OR graph for ``legs`` legs (single layer, four paths per leg)."""
    if legs < 1:
        raise FlexhrcError(f"--legs must be at least 1, got {legs}")
    g = AndOrGraph("TableAssembly", root=f"connected_{legs}")
    g.add_node(Node("tabletop", 0, parse_conjunction("tabletop(?top) & placed(?top)")))
    for k in range(1, legs + 1):
        g.add_node(Node(f"leg_{k}", 0, parse_conjunction("leg(?leg) & on_table(?leg)")))
        g.add_node(Node(f"middle_{k}", 0, parse_conjunction("leg(?leg) & at(?leg, middle)")))
        g.add_node(Node(f"connected_{k}", 0, parse_conjunction(f"filled(bolt_{k})")))
    for k in range(1, legs + 1):
        before = "tabletop" if k == 1 else f"connected_{k - 1}"
        bolt = f"bolt_{k}"
        children = [f"leg_{k}", before]
        # the middle state already includes the previous bolt (to_middle_k consumed it):
        # a second child "before" would be blocked by Algorithm 2 once to_middle_k is solved
        mid = [f"middle_{k}"]
        fill = [a.format(bolt=bolt) for a in ROBOT_DIRECT]
        human = [a.format(bolt=bolt) for a in HUMAN]
        g.add_hyperarc(f"robot_{k}", children, f"connected_{k}", 1, actions=tuple(fill))
        g.add_hyperarc(f"to_middle_{k}", children, f"middle_{k}", 1, actions=TO_MIDDLE)
        g.add_hyperarc(f"robot_from_middle_{k}", mid, f"connected_{k}", 1, actions=tuple(fill))
        g.add_hyperarc(f"human_from_middle_{k}", mid, f"connected_{k}", 2, actions=tuple(human))
        g.add_hyperarc(f"human_{k}", children, f"connected_{k}", 3, actions=tuple(human))
    h = HierarchicalGraph.single(g)
    h.validate()
    return h


def load_domain(human: bool = True) -> Domain:
    """Agents (human, left, right) and action schemas, from the packaged YAML."""
    import yaml

    text = resources.files("flexhrc.scenarios").joinpath("data/table_assembly/domain.yaml")
    data = yaml.safe_load(text.read_text(encoding="utf-8"))
    if not human:  # the human's actions stay in the domain, with nobody to do them
        data["agents"].pop("human")
    return Domain.from_dict(data, "table_assembly/domain.yaml")


@dataclass
class TableScenario:
    """Objects and options of one table assembly run."""

    legs: int = 4
    tabletop: str = "large"
    leg_length: str = "long"
    seed: int = 0
    human: bool = True
    unreachable_bolts: tuple[int, ...] = ()  # bolts no arm can reach (e.g. an obstacle)
    reachable_only_by: dict[str, str] = field(default_factory=dict)  # object -> arm
    leg_positions: list[tuple[float, float, float]] | None = None

    def __post_init__(self) -> None:
        if self.tabletop not in TABLETOPS:
            raise FlexhrcError(f"unknown tabletop {self.tabletop!r}; choose {', '.join(TABLETOPS)}")
        if self.leg_length not in LEG_LENGTHS:
            raise FlexhrcError(
                f"unknown leg length {self.leg_length!r}; choose {', '.join(LEG_LENGTHS)}"
            )
        for b in self.unreachable_bolts:
            if not 1 <= b <= self.legs:
                raise FlexhrcError(f"unreachable bolt {b} is not one of 1..{self.legs}")

    def graph(self) -> HierarchicalGraph:
        return build_graph(self.legs)

    def domain(self) -> Domain:
        return load_domain(self.human)

    def bolt_positions(self) -> list[tuple[float, float, float]]:
        """Bolts at the tabletop corners (inset 4 cm), then along the long sides."""
        w, d = TABLETOPS[self.tabletop]
        cx, cy, _ = TABLETOP_CENTRE
        corners = [(+1, +1), (+1, -1), (-1, -1), (-1, +1)]
        out = []
        for k in range(self.legs):
            sx, sy = corners[k % 4]
            shrink = 1.0 - 0.35 * (k // 4)
            out.append(
                (
                    round(cx + sx * (w / 2 - 0.04) * shrink, 4),
                    round(cy + sy * (d / 2 - 0.04), 4),
                    0.0,
                )
            )
        return out

    def knowledge(self) -> KnowledgeBase:
        kb = KnowledgeBase()
        w, d = TABLETOPS[self.tabletop]
        kb.add_object("tabletop", "tabletop", TABLETOP_CENTRE, {"width": w, "depth": d})
        kb.assert_fact("placed", "tabletop")
        domain = self.domain()
        for arm in ("left", "right"):
            rest = domain.agent(arm).params["rest"]
            kb.add_object(arm, "arm", rest)
            kb.assert_fact("free", arm)
        if self.human:
            kb.add_object("human", "human", HUMAN_HAND)
        for k, p in enumerate(self.bolt_positions(), 1):
            if k in self.unreachable_bolts:
                # a fixture right above the bolt: no arm gets there (the analytic simulator reads
                # reachable_by, the kinematic one keeps its distance from the obstacle sphere)
                kb.add_object(f"bolt_{k}", "place", p, reachable_by=[])
                kb.add_object(
                    f"fixture_{k}", "obstacle", (p[0], p[1], p[2] + 0.10), {"radius": 0.05}
                )
            else:
                kb.add_object(f"bolt_{k}", "place", p)
        kb.add_object("middle", "place", MIDDLE_POSE)
        length = LEG_LENGTHS[self.leg_length]
        for i, p in enumerate(self.leg_positions or self._random_leg_positions(), 1):
            leg = f"leg{i}"
            attrs: dict[str, Any] = {}
            if leg in self.reachable_only_by:
                attrs["reachable_by"] = [self.reachable_only_by[leg]]
            kb.add_object(leg, "leg", p, {"length": length, "diameter": 0.04}, **attrs)
            kb.assert_fact("on_table", leg)
        return kb

    def _random_leg_positions(self) -> list[tuple[float, float, float]]:
        """Legs scattered on the table beside the tabletop, within reach (seeded)."""
        rng = random.Random(self.seed)
        out: list[tuple[float, float, float]] = []
        _w, d = TABLETOPS[self.tabletop]
        while len(out) < self.legs:
            x = rng.uniform(0.25, 0.60)
            y = rng.choice((-1, 1)) * rng.uniform(d / 2 + 0.06, 0.48)
            if all(math.dist((x, y), q[:2]) > 0.08 for q in out):
                out.append((round(x, 3), round(y, 3), 0.0))
        return out
