"""The cooperative table assembly of FlexHRC+ (paper 000, VI-D, Figs. 5 and 8-13).

:func:`table_assembly` builds it as a :class:`~flexhrc.scenario.Scenario`, in three segments
(:data:`SEGMENTS`): the tabletop placement (Fig. 8: ``place_tabletop`` picks the tabletop from
its stand, turns it flat and places it, each step one joint command of both arms; at the node
``tabletop_placed`` the process ``hold(?top)`` keeps it still with both hands until it has
settled; ``arms_to_rest`` sends both arms to rest; the operator's alternative
``human_places_tabletop`` only when asked for), the legs fix (Figs. 9-12, below) and
the check (Fig. 13: ``check_connections``, weight 0, so the suggestion costs of the legs fix are
those of Figs. 9-12; left out without an operator). ``segments="legs"`` is the legs fix alone.
With its defaults it is the task of the shipped ``table_assembly`` file (:func:`write_shipped`).

The legs fix: a dual-arm robot and a human operator fix N legs (default 4) to a tabletop, bolt
by bolt in a fixed order. The single-layer first-order AND/OR graph has, for every bolt k, the four
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

Any number of legs the table holds: bolts sit on the tabletop's edge (the four corners first,
then evenly spaced along the edges, at least :data:`BOLT_SPACING` apart) and the legs lie on a
grid of slots beside the tabletop (:data:`LEG_SPACING` apart; a seed picks the slots and a small
offset within them). Both are computed, never searched for, so a request beyond the capacity is
a :class:`ScenarioError` saying how many legs fit and what size of tabletop would hold more.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.logic import parse_conjunction
from flexhrc.representation import AndOrGraph, HierarchicalGraph, Node
from flexhrc.representation.graph import Hyperarc
from flexhrc.taskmanager.domain import Domain

if TYPE_CHECKING:
    from flexhrc.scenario.model import Scenario

# Geometry (metres, x forward, y left, z up, table at z = 0) sized for flexhrc.action's dual-arm
# robot, so the analytic and the kinematic simulator see the same workspace.
TABLETOPS = {"large": (0.30, 0.40), "small": (0.26, 0.34)}  # width (x), depth (y)
LEG_LENGTHS = {"long": 0.40, "short": 0.30}
TABLETOP_CENTRE = (0.45, 0.0, 0.0)  # of the named tabletops; a larger one moves away
TABLETOP_NEAR_EDGE_X = 0.15  # a large tabletop's edge nearest the robot stays this far out
TABLETOP_LIMITS_M = (0.12, 5.0)  # smallest and largest side accepted
BOLT_INSET = 0.04  # bolts sit this far inside the tabletop's edge
BOLT_SPACING = 0.05  # at least this far apart (a leg is 4 cm thick)
LEG_SPACING = 0.08  # leg slots beside the tabletop: grid pitch
LEG_JITTER = 0.015  # seeded offset of a leg within its slot (keeps >= 5 cm between legs)
LEG_CLEARANCE = 0.04  # two given leg positions closer than this are the same place
ARMS = ("left", "right")
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


class ScenarioError(FlexhrcError):
    """A bad scenario setting. ``key`` names it (``legs``, ``tabletop`` ...) so the caller can
    say where it came from: ``--legs`` on the command line, a line of a scenario file."""

    def __init__(self, key: str, message: str, fix: tuple[str, str] | None = None):
        self.key = key
        self.detail = message
        self.fix = fix  # (key, value) that gets further, e.g. ("tabletop", "0.9x0.9")
        text = f"{key} {message}"
        if fix is not None:
            text += f"; {fix[0]} {fix[1]} would do"
        super().__init__(text)


def parse_tabletop(value: str | Sequence[float]) -> tuple[float, float]:
    """Width (x) and depth (y) in metres of ``large``, ``small``, ``"WIDTHxDEPTH"`` or a pair."""
    if isinstance(value, str):
        if value in TABLETOPS:
            return TABLETOPS[value]
        w_s, sep, d_s = value.lower().partition("x")
        try:
            if not sep:
                raise ValueError
            pair: Sequence[float] = (float(w_s), float(d_s))
        except ValueError:
            raise ScenarioError(
                "tabletop",
                f"{value!r} is not a tabletop: use {' or '.join(TABLETOPS)}, or WIDTHxDEPTH in "
                "metres (e.g. 0.9x0.9)",
            ) from None
    else:
        pair = value
    if len(pair) != 2:
        raise ScenarioError("tabletop", "needs two sides: WIDTHxDEPTH in metres")
    lo, hi = TABLETOP_LIMITS_M
    sides = []
    for v in pair:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise ScenarioError("tabletop", f"sides must be finite numbers of metres, got {v!r}")
        if not lo <= v <= hi:
            raise ScenarioError("tabletop", f"sides must be between {lo} and {hi} m, got {v}")
        sides.append(float(v))
    return sides[0], sides[1]


def tabletop_centre(size: tuple[float, float]) -> tuple[float, float, float]:
    """The named tabletops sit at :data:`TABLETOP_CENTRE`; a larger one is moved away from the
    robot so that its near edge stays in front of the arms' bases."""
    w, _d = size
    return (max(TABLETOP_CENTRE[0], TABLETOP_NEAR_EDGE_X + w / 2), 0.0, 0.0)


def bolt_slots(size: tuple[float, float], legs: int) -> list[tuple[float, float, float]] | None:
    """Positions of ``legs`` bolts on a tabletop of ``size``, or None if they do not fit.

    The four corners (inset :data:`BOLT_INSET`) first, in the order of the paper's figures; then
    bolts spread along the four edges, each new one on the edge where the bolts are farthest
    apart, evenly spaced there, never closer than :data:`BOLT_SPACING`.
    """
    w, d = size
    cx, cy, _ = tabletop_centre(size)
    a, b = w / 2 - BOLT_INSET, d / 2 - BOLT_INSET
    corners = [(cx + a, cy + b), (cx + a, cy - b), (cx - a, cy - b), (cx - a, cy + b)]
    if legs <= 4:
        return [(round(x, 4), round(y, 4), 0.0) for x, y in corners[:legs]]
    # edges from corner i to corner i+1: the far edge (x = +a), the right, near and left edges
    edges = [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    lengths = [math.dist(p, q) for p, q in edges]
    room = [max(int(length / BOLT_SPACING + 1e-9) - 1, 0) for length in lengths]
    extra = legs - 4
    if extra > sum(room):
        return None
    count = [0, 0, 0, 0]
    for _ in range(extra):  # at most capacity steps: every step places one bolt
        i = max(
            (j for j in range(4) if count[j] < room[j]),
            key=lambda j: lengths[j] / (count[j] + 1),
        )
        count[i] += 1
    out = [(round(x, 4), round(y, 4), 0.0) for x, y in corners]
    for (p, q), n in zip(edges, count, strict=True):
        for j in range(1, n + 1):
            f = j / (n + 1)
            out.append(
                (round(p[0] + f * (q[0] - p[0]), 4), round(p[1] + f * (q[1] - p[1]), 4), 0.0)
            )
    return out


def leg_slots(size: tuple[float, float]) -> list[tuple[float, float]]:
    """Where legs can lie: a grid beside the tabletop, on both of its sides, within the arms'
    workspace (the band the paper's legs are scattered in, lengthened with the tabletop)."""
    w, d = size
    cx, _, _ = tabletop_centre(size)
    x0, x1 = 0.25, max(0.60, cx + w / 2 - 0.05)
    y0, y1 = d / 2 + 0.06, d / 2 + 0.28
    cols = int((x1 - x0) / LEG_SPACING + 1e-9) + 1
    rows = int((y1 - y0) / LEG_SPACING + 1e-9) + 1
    return [
        (x0 + i * LEG_SPACING, side * (y0 + j * LEG_SPACING))
        for side in (1, -1)
        for j in range(rows)
        for i in range(cols)
    ]


def capacity(size: tuple[float, float]) -> int:
    """How many legs a tabletop of ``size`` holds: bolts on its edge and slots beside it."""
    w, d = size
    a, b = w / 2 - BOLT_INSET, d / 2 - BOLT_INSET
    bolts = 4 + 2 * max(int(2 * a / BOLT_SPACING + 1e-9) - 1, 0)
    bolts += 2 * max(int(2 * b / BOLT_SPACING + 1e-9) - 1, 0)
    return min(bolts, len(leg_slots(size)))


def tabletop_for(legs: int) -> str | None:
    """The smallest square tabletop (in 5 cm steps) that holds ``legs`` legs, as WIDTHxDEPTH."""
    _lo, hi = TABLETOP_LIMITS_M
    for k in range(3, int(hi / 0.05 + 1e-9) + 1):  # bounded: at most 100 sizes
        side = round(0.05 * k, 2)
        if capacity((side, side)) >= legs:
            return f"{side:g}x{side:g}"
    return None


def build_graph(legs: int = 4) -> HierarchicalGraph:
    """The FOL AND/OR graph for ``legs`` legs (single layer, four paths per leg)."""
    if isinstance(legs, bool) or not isinstance(legs, int):
        raise ScenarioError("legs", f"must be a whole number, got {legs!r}")
    if legs < 1:
        raise ScenarioError("legs", f"must be at least 1, got {legs}")
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


def load_domain(human: bool = True, file: str = "domain.yaml") -> Domain:
    """Agents (human, left, right) and action schemas, from the packaged YAML ``file``
    (``domain.yaml``: the legs fix; ``task_domain.yaml``: the whole task)."""
    text = resources.files("flexhrc.scenario.builtin").joinpath(f"data/table_assembly/{file}")
    data = yaml.safe_load(text.read_text(encoding="utf-8"))
    if not human:  # the human's actions stay in the domain, with nobody to do them
        data["agents"].pop("human")
    return Domain.from_dict(data, f"table_assembly/{file}")


@dataclass
class TableLayout:
    """The objects of one table: how many legs, the tabletop, the legs' length and where they
    lie, the bolts no arm reaches. :meth:`world` builds the knowledge base of the legs fix (the
    tabletop already placed); :func:`table_assembly` turns a layout into a
    :class:`~flexhrc.scenario.Scenario`."""

    legs: int = 4
    tabletop: str = "large"
    leg_length: str = "long"
    seed: int = 0
    human: bool = True
    unreachable_bolts: tuple[int, ...] = ()  # bolts no arm can reach (e.g. an obstacle)
    reachable_only_by: dict[str, str] = field(default_factory=dict)  # object -> arm
    leg_positions: list[tuple[float, float, float]] | None = None

    def __post_init__(self) -> None:
        if isinstance(self.legs, bool) or not isinstance(self.legs, int):
            raise ScenarioError("legs", f"must be a whole number, got {self.legs!r}")
        if self.legs < 1:
            raise ScenarioError("legs", f"must be at least 1, got {self.legs}")
        self.size = parse_tabletop(self.tabletop)
        if self.leg_length not in LEG_LENGTHS:
            raise ScenarioError(
                "leg_length", f"{self.leg_length!r} is unknown; choose {', '.join(LEG_LENGTHS)}"
            )
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ScenarioError("seed", f"must be a whole number >= 0, got {self.seed!r}")
        for b in self.unreachable_bolts:
            if isinstance(b, bool) or not isinstance(b, int) or not 1 <= b <= self.legs:
                raise ScenarioError(
                    "unreachable_bolts", f"{b!r} is not one of the bolts 1..{self.legs}"
                )

        def is_leg(name: object) -> bool:  # leg1..legN, without listing N names (legs: 1e30)
            digits = name[3:] if isinstance(name, str) and name.startswith("leg") else ""
            return digits.isdigit() and digits[0] != "0" and 1 <= int(digits) <= self.legs

        for leg, arm in self.reachable_only_by.items():
            if not is_leg(leg):
                raise ScenarioError(
                    "reachable_only_by", f"{leg!r} is not one of the legs leg1..leg{self.legs}"
                )
            if arm not in ARMS:
                raise ScenarioError(
                    "reachable_only_by", f"{leg}: {arm!r} is not an arm; choose left or right"
                )
        if self.leg_positions is not None:
            self._check_leg_positions(self.leg_positions)
        else:
            cap = capacity(self.size)
            if self.legs > cap:
                w, d = self.size
                bigger = tabletop_for(self.legs)
                raise ScenarioError(
                    "legs",
                    f"{self.legs}: too many for a {w:g} x {d:g} m tabletop, which holds at most "
                    f"{cap} legs (bolts {BOLT_SPACING * 100:.0f} cm apart on its edge, legs "
                    f"{LEG_SPACING * 100:.0f} cm apart beside it)"
                    + (
                        "" if bigger else f"; no tabletop up to {TABLETOP_LIMITS_M[1]} m holds them"
                    ),
                    fix=("tabletop", bigger) if bigger else None,
                )
        if bolt_slots(self.size, self.legs) is None:
            w, d = self.size
            raise ScenarioError(
                "legs", f"{self.legs} bolts do not fit on the edge of a {w:g} x {d:g} m tabletop"
            )

    def _check_leg_positions(self, positions: Sequence[tuple[float, float, float]]) -> None:
        if len(positions) != self.legs:
            raise ScenarioError(
                "leg_positions",
                f"gives {len(positions)} positions for {self.legs} legs; give one per leg",
            )
        for i, p in enumerate(positions, 1):
            if len(p) != 3 or not all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in p
            ):
                raise ScenarioError(
                    "leg_positions", f"leg{i}: expected [x, y, z] finite numbers, got {p!r}"
                )
            for j, q in enumerate(positions[: i - 1], 1):
                if math.dist(p, q) < LEG_CLEARANCE:
                    raise ScenarioError(
                        "leg_positions",
                        f"leg{j} and leg{i} are at the same place "
                        f"(less than {LEG_CLEARANCE * 100:.0f} cm apart)",
                    )

    def bolt_positions(self) -> list[tuple[float, float, float]]:
        """Bolts at the tabletop corners (inset 4 cm), then spread along the edges."""
        slots = bolt_slots(self.size, self.legs)
        assert slots is not None  # checked in __post_init__
        return slots

    def world(self) -> KnowledgeBase:
        """A fresh knowledge base of the legs fix: the tabletop placed, the legs on the table."""
        kb = KnowledgeBase()
        w, d = self.size
        kb.add_object("tabletop", "tabletop", tabletop_centre(self.size), {"width": w, "depth": d})
        kb.assert_fact("placed", "tabletop")
        domain = load_domain(self.human)
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
        """Legs scattered on the table beside the tabletop, within reach (seeded): the seed
        picks ``legs`` of the :func:`leg_slots` and an offset of up to :data:`LEG_JITTER` in
        each — no search, so it never loops, and legs stay >= 5 cm apart."""
        rng = random.Random(self.seed)
        slots = rng.sample(leg_slots(self.size), self.legs)
        return [
            (
                round(x + rng.uniform(-LEG_JITTER, LEG_JITTER), 3),
                round(y + rng.uniform(-LEG_JITTER, LEG_JITTER), 3),
                0.0,
            )
            for x, y in slots
        ]


# ------------------------------------------------------------------ the whole task: segments --
#: The segments of the paper's table assembly (VI-D), in the order they run: the tabletop
#: placement by both arms (Fig. 8), the legs fix (Figs. 9-12), the operator's check (Fig. 13).
SEGMENTS = ("tabletop", "legs", "check")

#: Where the tabletop waits before the robot places it: on a stand 25 cm above its assembly pose
#: (metres), out of the way of anything on the table (the fixtures of --unreachable-bolt).
STAND_OFFSET = (0.0, 0.0, 0.25)


def parse_segments(segments: str | Sequence[str] | None, *, human: bool = True) -> tuple[str, ...]:
    """The segments ``segments`` selects, in task order: ``all`` (or None) is every segment
    (without an operator the check is left out, nobody would do it), else a comma-separated
    list (``legs``, ``tabletop,legs``) or a sequence of names. Raises :class:`ScenarioError`
    (key ``segments``) naming the segments there are."""
    if segments is None or segments == "all" or segments == ("all",):
        return tuple(s for s in SEGMENTS if human or s != "check")
    names = segments.split(",") if isinstance(segments, str) else list(segments)
    chosen = {n.strip() for n in names if n.strip()}
    for n in sorted(chosen):
        if n not in SEGMENTS:
            raise ScenarioError(
                "segments",
                f"{n!r} is not a segment of table_assembly; it has {', '.join(SEGMENTS)} (or all)",
            )
    if not chosen:
        raise ScenarioError("segments", f"names none; choose from {', '.join(SEGMENTS)} or all")
    if "check" in chosen and "legs" not in chosen:
        raise ScenarioError("segments", "check needs legs: the operator checks the bolts")
    if "check" in chosen and not human:
        raise ScenarioError("segments", "check needs an operator (human is false)")
    return tuple(s for s in SEGMENTS if s in chosen)


#: The tabletop placement of Fig. 8 as the hyper-arc ``place_tabletop`` (a-e: pick it from its
#: stand, turn it flat, place it at the assembly pose) and, once the process ``hold(?top)`` of
#: ``tabletop_placed`` has ended, ``arms_to_rest`` (f: both arms back to rest).
PLACE_TABLETOP = (
    "pick_tabletop(?top)",
    "reorient_tabletop(?top)",
    "place_tabletop(?top, assembly_pose)",
)
ARMS_TO_REST = ("return_to_rest()",)


def task_graph(
    legs: int = 4,
    segments: Sequence[str] = SEGMENTS,
    *,
    operator_places_tabletop: bool = False,
) -> HierarchicalGraph:
    """The graph of the chosen segments as one first-order graph: the legs fix alone is
    :func:`build_graph`'s; with ``tabletop`` the robot first places the tabletop (Fig. 8:
    :data:`PLACE_TABLETOP`, the node ``tabletop_placed`` with the process ``hold(?top)``, then
    :data:`ARMS_TO_REST`); with ``check`` the operator's check closes the task. In the
    paper the robot always places the tabletop: ``operator_places_tabletop`` adds the
    operator's alternative ``human_places_tabletop`` (cost 3; needs the check segment's
    operator)."""
    if tuple(segments) == ("legs",):
        return build_graph(legs)
    tabletop = "tabletop" in segments
    check = "check" in segments
    fix = build_graph(legs).top_graph
    fix_root = str(fix.root)
    root = "checked" if check else fix_root if "legs" in segments else "tabletop"
    g = AndOrGraph("TableAssembly", root=root)
    if tabletop:
        g.add_node(
            Node("tabletop_on_stand", 0, parse_conjunction("tabletop(?top) & on_table(?top)"))
        )
        placed = parse_conjunction("tabletop(?top) & placed(?top)")
        g.add_node(Node("tabletop_placed", 0, placed, ("hold(?top)",)))
    for n in fix.nodes.values():
        if n.name == "tabletop" or "legs" in segments:
            g.add_node(Node(n.name, n.weight, n.formula, n.processes))
    if tabletop:
        g.add_hyperarc(
            Hyperarc("place_tabletop", ("tabletop_on_stand",), "tabletop_placed", 1, PLACE_TABLETOP)
        )
        g.add_hyperarc(Hyperarc("arms_to_rest", ("tabletop_placed",), "tabletop", 0, ARMS_TO_REST))
        if operator_places_tabletop:  # the robot's way is cheaper; the operator's when it fails
            g.add_hyperarc(
                Hyperarc(
                    "human_places_tabletop",
                    ("tabletop_on_stand",),
                    "tabletop",
                    3,
                    ("place_by_hand(human, ?top, assembly_pose)",),
                )
            )
    if "legs" in segments:
        for h in fix.hyperarcs.values():
            g.add_hyperarc(Hyperarc(h.name, h.children, h.parent, h.weight, h.actions))
    if check:
        bolts = [f"bolt_{k}" for k in range(1, legs + 1)]
        g.add_node(
            Node("checked", 0, parse_conjunction(" & ".join(f"checked({b})" for b in bolts)))
        )
        g.add_hyperarc(
            Hyperarc(
                "check_connections",
                (fix_root,),
                "checked",
                0,
                tuple(f"check(human, {b})" for b in bolts),
            )
        )
    hierarchy = HierarchicalGraph.single(g)
    hierarchy.validate()
    return hierarchy


def task_domain(human: bool = True) -> Domain:
    """The domain of the whole task: the legs fix's actions, the tabletop placement and the
    check."""
    return load_domain(human, "task_domain.yaml")


def _task_world(layout: TableLayout, segments: tuple[str, ...]) -> KnowledgeBase:
    kb = layout.world()
    if "tabletop" not in segments:
        return kb
    centre = tabletop_centre(layout.size)
    kb.retract_fact("placed", "tabletop")
    kb.assert_fact("on_table", "tabletop")
    kb.move("tabletop", tuple(c + o for c, o in zip(centre, STAND_OFFSET, strict=True)))
    kb.add_object("assembly_pose", "place", centre)
    return kb


DESCRIPTION = (
    "The FlexHRC+ table assembly in three segments (paper 000, VI-D): the robot picks the "
    "tabletop from its stand with both arms, turns it flat, places and holds it, then rests "
    "(Fig. 8), robot and operator fix four legs "
    "(Figs. 9-12), the operator checks every connection (Fig. 13)."
)


def table_assembly(
    legs: int = 4,
    *,
    tabletop: str | Sequence[float] = "large",
    leg_length: str = "long",
    seed: int = 0,
    human: bool = True,
    unreachable_bolts: Sequence[int] = (),
    reachable_only_by: dict[str, str] | None = None,
    leg_positions: Sequence[tuple[float, float, float]] | None = None,
    segments: str | Sequence[str] | None = "all",
    profile: str = "passive",
    name: str = "table_assembly",
    operator_places_tabletop: bool = False,
) -> Scenario:
    """The paper's table assembly (000, VI-D) as a :class:`~flexhrc.scenario.Scenario`.

    ``segments`` picks parts of it (:func:`parse_segments`): ``all`` (default) is the task of
    the shipped ``table_assembly`` file — tabletop placement, legs fix, check; ``legs`` is the
    legs fix alone (Figs. 9-12, the older ``scenario: table_assembly`` files). The other
    arguments describe the table (:class:`TableLayout`); ``profile`` is the operator's;
    ``operator_places_tabletop`` gives the operator a way to place the tabletop beside the
    robot's (in the paper only the robot does, Fig. 8). Bad settings raise
    :class:`ScenarioError` naming the setting.
    """
    from flexhrc.scenario.model import HumanSpec, Scenario, WorldSpec

    layout = TableLayout(
        legs=legs,
        tabletop=tabletop if isinstance(tabletop, str) else "x".join(str(v) for v in tabletop),
        leg_length=leg_length,
        seed=seed,
        human=human,
        unreachable_bolts=tuple(unreachable_bolts),
        reachable_only_by=dict(reachable_only_by or {}),
        leg_positions=[tuple(p) for p in leg_positions] if leg_positions is not None else None,  # type: ignore[misc]
    )
    chosen = parse_segments(segments, human=human)
    if not isinstance(operator_places_tabletop, bool):
        raise ScenarioError(
            "operator_places_tabletop", f"must be true or false, got {operator_places_tabletop!r}"
        )
    if operator_places_tabletop and not (human and "tabletop" in chosen):
        raise ScenarioError(
            "operator_places_tabletop", "needs an operator and the tabletop segment"
        )
    if chosen == ("legs",):
        domain = load_domain(human)
        description = "The legs fix of the FlexHRC+ table assembly (paper 000, Figs. 9-12)."
    else:
        domain = task_domain(human)
        description = DESCRIPTION
    return Scenario(
        name,
        description,
        task_graph(legs, chosen, operator_places_tabletop=operator_places_tabletop),
        domain,
        WorldSpec(),
        (HumanSpec("human", profile),) if human else (),
        "analytic",
        world_factory=lambda: _task_world(layout, chosen),
        segments=chosen,
    )


# ----------------------------------------------------------------------------- shipped file --
def shipped_documents(scenario: Scenario | None = None) -> tuple[str, str]:
    """(scenario file, graph file) of the shipped ``table_assembly`` scenario, as YAML text."""
    from flexhrc.representation.formats.yaml_format import dump_yaml

    task = scenario or table_assembly()
    kb = task.world()
    objects: dict[str, Any] = {}
    places: dict[str, Any] = {}
    for o in kb.objects.values():
        if o.id in task.domain.agents:
            continue
        if o.type == "place" and not o.attrs:
            places[o.id] = [round(v, 4) for v in o.position]
            continue
        spec: dict[str, Any] = {"type": o.type, "position": [round(v, 4) for v in o.position]}
        if o.size:
            spec["size"] = {k: round(v, 4) for k, v in o.size.items()}
        if o.fixed:
            spec["fixed"] = True
        if "reachable_by" in o.attrs:
            spec["reachable_by"] = list(o.attrs["reachable_by"])
        rest = {k: v for k, v in o.attrs.items() if k != "reachable_by"}
        if rest:
            spec["attrs"] = rest
        objects[o.id] = spec
    facts = sorted(
        f"{f[0]}({', '.join(f[1:])})"
        for f in kb.facts
        if len(f) > 1
        and not (
            len(f) == 2
            and kb.objects.get(f[1]) is not None
            and f[0] in kb.type_chain(kb.objects[f[1]].type)
        )
    )
    doc = {
        "flexhrc": 1,
        "name": "table_assembly",
        "description": DESCRIPTION,
        "graph": "table_assembly.graph.yaml",
        "domain": "task_domain.yaml",
        "world": {"objects": objects, "places": places, "facts": facts},
        "humans": [{"name": "human", "profile": "passive", "speed": 1.0}],
        "simulator": "analytic",
    }
    head = (
        "# The shipped table assembly (generated by flexhrc.scenario.builtin.table.write_shipped;"
        "\n# `flexhrc demo table` runs the same task for any number of legs and table size).\n"
    )
    body = yaml.safe_dump(doc, sort_keys=False, width=100, default_flow_style=None)
    return head + body, dump_yaml(task.graph)


def write_shipped(folder: str | Path) -> None:
    """Write ``table_assembly.yaml`` and ``table_assembly.graph.yaml`` into ``folder``."""
    scenario_text, graph_text = shipped_documents()
    folder = Path(folder)
    (folder / "table_assembly.yaml").write_text(scenario_text, encoding="utf-8")
    (folder / "table_assembly.graph.yaml").write_text(graph_text, encoding="utf-8")
