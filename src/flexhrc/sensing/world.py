"""The simulated workspace as it really is: the truth the robot's sensors look at.

With perception on, the Task Manager's knowledge base holds *beliefs*: where perception last saw
each part, moved by the predicted effects of the actions done since. :class:`SimulatedWorkspace`
is the other side — the parts as they physically are (shape, pose, who holds them), changed only
by what the agents physically do: an arm closes its gripper on whatever part lies where it
grasps (nothing, if the part is not there any more), carries it, releases it; the operator picks
a part up, screws it, puts it down, or nudges it aside. Names are the workspace's own
(``part1`` ...) and never reach the manager: it knows parts only through perception.

Shapes come from the knowledge base's sizes: an object with a ``length`` and a ``diameter`` is a
cylinder lying on the table (a leg), one with a ``width`` and a ``depth`` a board (``height``,
default 3 cm). A part fixed to another (a screwed leg) stands upright on it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.knowledge import KnowledgeBase

Vec3 = tuple[float, float, float]
BOARD_HEIGHT_M = 0.03
#: Gap between two parts that the head camera still sees as two (its clustering joins points
#: closer than about 2 cm).
SEPARATION_M = 0.03
#: How a rod is laid when its yaw is not given: along x, else along y, else turned by 15 degree
#: steps — the first way that keeps it clear of the other parts.
_YAWS = (0.0, math.pi / 2, *(math.radians(a) for a in range(15, 180, 15) if a != 90))


@dataclass(frozen=True)
class Part:
    """One physical part. ``dims``: box ``(lx, ly, lz)``; cylinder ``(length, radius)``.

    ``position`` is the centre; a lying cylinder runs along ``yaw``, an upright one (``upright``)
    stands on its end. ``holder`` is the agent holding it, if any.
    """

    name: str
    type: str
    shape: str
    dims: tuple[float, ...]
    position: Vec3
    yaw: float = 0.0
    upright: bool = False
    holder: str | None = None
    fixed: bool = False  # screwed to another part
    home: Vec3 | None = None  # where it lay when it was taken

    @property
    def resting_height(self) -> float:
        """Height of the centre above its support when it lies there."""
        if self.shape == "box":
            return self.dims[2] / 2
        return self.dims[0] / 2 if self.upright else self.dims[1]

    @property
    def extents(self) -> tuple[float, float, float]:
        """Extents sorted in decreasing order (as scene perception reports them)."""
        if self.shape == "box":
            e = list(self.dims)
        else:
            e = [self.dims[0], 2 * self.dims[1], 2 * self.dims[1]]
        a, b, c = sorted(e, reverse=True)
        return (a, b, c)


def shape_of(size: Mapping[str, float]) -> tuple[str, tuple[float, ...]] | None:
    """The primitive of an object from its knowledge-base size, None if it has no body."""
    if "length" in size and "diameter" in size:
        return "cylinder", (float(size["length"]), float(size["diameter"]) / 2)
    if "width" in size and "depth" in size:
        h = float(size.get("height", BOARD_HEIGHT_M))
        return "box", (float(size["width"]), float(size["depth"]), h)
    return None


class SimulatedWorkspace:
    """The parts on the table as they physically are (see the module docstring)."""

    def __init__(
        self,
        parts: Iterable[Part] = (),
        *,
        table: tuple[float, float, float, float] = (-0.05, 1.25, -0.65, 0.65),
        grasp_tolerance_m: float = 0.03,
        hand: Vec3 = (1.10, 0.0, 0.10),
    ):
        self.parts: dict[str, Part] = {}
        for p in parts:
            if p.name in self.parts:
                raise FlexhrcError(f"two parts named {p.name!r}")
            self.parts[p.name] = p
        self.table = table  # x0, x1, y0, y1 of the table surface (z = 0)
        self.grasp_tolerance_m = grasp_tolerance_m
        self.hand = hand
        self.version = 0  # bumped on every change: a renderer redraws only then

    @classmethod
    def from_knowledge(
        cls,
        kb: KnowledgeBase,
        types: Iterable[str] | None = None,
        *,
        destinations: Mapping[str, Iterable[str]] | None = None,
        **kw: Any,
    ) -> tuple[SimulatedWorkspace, dict[str, str]]:
        """The workspace of a scenario's full knowledge base (the truth), and which part each
        of its objects is (object id -> part name; for tests and pictures only).

        ``destinations``: object id -> places it will be moved to (a tabletop placed at the
        assembly pose); rods are laid clear of those spots too, when they can be."""
        wanted = set(types) if types is not None else None
        world = cls((), **kw)
        names: dict[str, str] = {}
        todo: list[tuple[str, Part, list[float]]] = []
        for rec in kb.objects.values():
            if wanted is not None and not (set(kb.type_chain(rec.type)) & wanted):
                continue
            shape = shape_of(rec.size)
            if shape is None:
                continue
            name = f"part{len(todo) + 1}"
            kind, dims = shape
            x, y, _ = rec.position
            part = Part(name, rec.type, kind, dims, (0.0, 0.0, 0.0))
            part = replace(part, position=(x, y, part.resting_height))
            given = rec.attrs.get("yaw")
            yaws = [float(given)] if given is not None else list(_YAWS)
            todo.append((rec.id, part, yaws if kind != "box" else [float(given or 0.0)]))
            names[rec.id] = name
        # boards first, then each rod turned so that no two bodies overlap (a small search:
        # turning one rod may be what makes room for the next)
        todo.sort(key=lambda t: t[1].shape != "box")
        ghosts: list[Part] = []  # boards where they will be moved to
        for oid, part, _ in todo:
            for spot in (destinations or {}).get(oid, ()):
                if spot in kb.objects and part.shape == "box":
                    x, y, _ = kb.position(spot)
                    ghosts.append(replace(part, name=f"~{part.name}@{spot}", position=(x, y, 0)))
        deepest = [0]

        def place(i: int, avoid: list[Part]) -> bool:
            deepest[0] = max(deepest[0], i)
            if i == len(todo):
                return True
            _, part, yaws = todo[i]
            for yaw in yaws:
                mine = world.parts[part.name] = replace(part, yaw=yaw)
                clear = world.clear_at(part.name, part.position[:2], gap_m=gap) and not any(
                    _overlap(_rect(mine), _rect(g), gap) for g in avoid
                )
                if clear and place(i + 1, avoid):
                    return True
            del world.parts[part.name]
            return False

        # best: clear by a gap a camera resolves, of where boards go too; else merely apart
        gap = SEPARATION_M
        ok = place(0, ghosts) or place(0, [])
        if not ok:
            gap = 0.005
            ok = place(0, [])
        if not ok:
            bad = todo[min(deepest[0], len(todo) - 1)][0]
            rec = kb.object(bad)
            raise FlexhrcError(
                f"{bad} at ({rec.position[0]:.3f}, {rec.position[1]:.3f}): the parts overlap "
                "or leave the table whichever way they are turned; place them farther apart"
            )
        world.version += 1
        return world, names

    # -- queries --------------------------------------------------------------------------
    def part(self, name: str) -> Part:
        try:
            return self.parts[name]
        except KeyError:
            raise UnknownNameError(
                f"no part {name!r} in the workspace (parts: {', '.join(self.parts)})"
            ) from None

    def held_by(self, agent: str) -> Part | None:
        return next((p for p in self.parts.values() if p.holder == agent), None)

    def nearest(
        self, xy: Iterable[float], *, within: float | None = None, free: bool = True
    ) -> Part | None:
        """The part whose centre is horizontally nearest ``xy`` (only parts nobody holds and
        not fixed upright, with ``free``), or None when none lies ``within`` that distance."""
        x, y = list(xy)[:2]
        best: tuple[float, Part] | None = None
        for p in self.parts.values():
            if free and (p.holder is not None or p.fixed):
                continue
            d = math.hypot(p.position[0] - x, p.position[1] - y)
            if (within is None or d <= within) and (best is None or d < best[0]):
                best = (d, p)
        return best[1] if best else None

    def _set(self, part: Part) -> Part:
        self.parts[part.name] = part
        self.version += 1
        return part

    # -- what agents physically do ------------------------------------------------------------
    def grasp(self, agent: str, at: Iterable[float]) -> Part | None:
        """``agent`` closes its hand at ``at``: it now holds the part lying there, if any."""
        if self.held_by(agent) is not None:
            return None
        p = self.nearest(at, within=self.grasp_tolerance_m)
        if p is None:
            return None
        return self._set(replace(p, holder=agent, home=p.position))

    def carry(self, agent: str, to: Iterable[float], *, upright: bool = False) -> Part | None:
        """The part ``agent`` holds is now centred at ``to``, lying, or ``upright`` (a leg
        held above its bolt, ready to be screwed in)."""
        p = self.held_by(agent)
        if p is None:
            return None
        x, y, z = (float(v) for v in to)
        return self._set(replace(p, position=(x, y, z), upright=upright))

    def release(self, agent: str) -> Part | None:
        """``agent`` lets go: a part it held drops onto the table below (unless fixed)."""
        p = self.held_by(agent)
        if p is None:
            return None
        if p.fixed:
            return self._set(replace(p, holder=None))
        lying = replace(p, holder=None, upright=False)
        x, y, _ = p.position
        board = self.over_board((x, y)) if p.shape != "box" else None
        base = board.position[2] + board.dims[2] / 2 if board is not None else 0.0
        return self._set(replace(lying, position=(x, y, base + lying.resting_height)))

    def put_back(self, agent: str) -> Part | None:
        """``agent`` is stopped while holding a part: it lays it back where it took it from
        (if that spot is still free; else it lets go where it is)."""
        p = self.held_by(agent)
        if p is None:
            return None
        if p.fixed or p.home is None or not self.clear_at(p.name, p.home[:2]):
            return self.release(agent)
        return self._set(replace(p, holder=None, upright=False, position=p.home))

    def attach(self, agent: str, at: Iterable[float], on: str | None = None) -> Part | None:
        """The part ``agent`` holds is screwed at ``at`` (x, y): it stands upright on the board
        ``on`` (a part name; the table if None) and stays there (nobody holds it any more)."""
        p = self.held_by(agent)
        if p is None:
            return None
        x, y = list(at)[:2]
        base = 0.0
        if on is not None:
            board = self.part(on)
            base = board.position[2] + board.dims[2] / 2 if board.shape == "box" else 0.0
        up = replace(p, upright=True, holder=None, fixed=True)
        return self._set(replace(up, position=(x, y, base + up.resting_height)))

    def over_board(self, xy: Iterable[float]) -> Part | None:
        """The board (a box part lying flat) whose footprint contains ``xy``, if any."""
        x, y = list(xy)[:2]
        for p in self.parts.values():
            if p.shape != "box" or p.holder is not None:
                continue
            hx, hy = p.dims[0] / 2, p.dims[1] / 2
            c, s = math.cos(p.yaw), math.sin(p.yaw)
            dx, dy = x - p.position[0], y - p.position[1]
            if abs(c * dx + s * dy) <= hx and abs(-s * dx + c * dy) <= hy:
                return p
        return None

    def pick_up(self, agent: str, at: Iterable[float]) -> Part | None:
        """The operator takes the part lying nearest ``at`` (within 5 cm) into the hand."""
        if self.held_by(agent) is not None:
            return None
        p = self.nearest(at, within=0.05)
        if p is None:
            return None
        # held across the body, in front of the operator
        return self._set(
            replace(p, holder=agent, position=self.hand, yaw=math.pi / 2, home=p.position)
        )

    def put_down(self, agent: str) -> Part | None:
        return self.release(agent)

    def clear_at(self, name: str, xy: Iterable[float], gap_m: float = 0.03) -> bool:
        """Would part ``name`` lying at ``xy`` be on the table, off any board and ``gap_m``
        clear of every other part's footprint?"""
        p = self.part(name)
        x, y = list(xy)[:2]
        x0, x1, y0, y1 = self.table
        half = _half(p)
        if not (x0 + half[0] <= x <= x1 - half[0] and y0 + half[1] <= y <= y1 - half[1]):
            return False
        mine = (x, y, p.yaw, _extent(p))
        for q in self.parts.values():
            if q.name == name or q.holder is not None:
                continue
            if _overlap(mine, (q.position[0], q.position[1], q.yaw, _extent(q)), gap_m):
                return False
        return True

    def relocate(self, name: str, to: Iterable[float]) -> Part:
        """A part nobody holds is put at ``to`` (x, y), lying (e.g. both arms place a board).
        Loose parts lying where it lands are pushed aside (away from its centre, until clear)."""
        p = self.part(name)
        x, y = list(to)[:2]
        lying = replace(p, holder=None, upright=False)
        placed = self._set(replace(lying, position=(float(x), float(y), lying.resting_height)))
        for q in list(self.parts.values()):
            if q.name == name or q.holder is not None or q.fixed:
                continue
            if not _overlap(_rect(placed), _rect(q), 0.0):
                continue
            side = 1.0 if q.position[1] >= placed.position[1] else -1.0
            for k in range(1, 61):
                spot = (q.position[0], q.position[1] + side * 0.01 * k)
                if self.clear_at(q.name, spot, gap_m=SEPARATION_M):
                    self._set(replace(q, position=(spot[0], spot[1], q.position[2])))
                    break
        return placed

    def displace(self, name: str, offset: Iterable[float]) -> Part:
        """Someone nudges a part lying on the table by ``offset`` (dx, dy)."""
        p = self.part(name)
        if p.holder is not None or p.fixed:
            raise FlexhrcError(f"part {name!r} is held or fixed: it cannot be nudged")
        dx, dy = list(offset)[:2]
        x, y, z = p.position
        return self._set(replace(p, position=(x + float(dx), y + float(dy), z)))


def _rect(p: Part) -> tuple[float, float, float, tuple[float, float]]:
    return (p.position[0], p.position[1], p.yaw, _extent(p))


def _extent(p: Part) -> tuple[float, float]:
    """Half extents of a part's footprint in its own frame (along its yaw, across)."""
    if p.shape == "box":
        return (p.dims[0] / 2, p.dims[1] / 2)
    if p.upright:
        return (p.dims[1], p.dims[1])
    return (p.dims[0] / 2, p.dims[1])


def _overlap(
    a: tuple[float, float, float, tuple[float, float]],
    b: tuple[float, float, float, tuple[float, float]],
    gap: float,
) -> bool:
    """Do two oriented rectangles (x, y, yaw, half extents) come closer than ``gap``?
    (separating-axis test)"""
    ax, ay, ayaw, ah = a
    bx, by, byaw, bh = b
    axes = [
        (math.cos(ayaw), math.sin(ayaw)),
        (-math.sin(ayaw), math.cos(ayaw)),
        (math.cos(byaw), math.sin(byaw)),
        (-math.sin(byaw), math.cos(byaw)),
    ]
    dx, dy = bx - ax, by - ay
    for ux, uy in axes:
        ra = _radius(ayaw, ah, ux, uy)
        rb = _radius(byaw, bh, ux, uy)
        if abs(dx * ux + dy * uy) >= ra + rb + gap:
            return False
    return True


def _radius(yaw: float, half: tuple[float, float], ux: float, uy: float) -> float:
    """Half the width of a rectangle (yaw, half extents) projected on the unit axis (ux, uy)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return half[0] * abs(c * ux + s * uy) + half[1] * abs(-s * ux + c * uy)


def _half(p: Part) -> tuple[float, float]:
    """Half extents of a part's footprint along x and y (axis-aligned bound)."""
    if p.shape == "box":
        a, b = p.dims[0] / 2, p.dims[1] / 2
    elif p.upright:
        a = b = p.dims[1]
    else:
        a, b = p.dims[0] / 2, p.dims[1]
    c, s = abs(math.cos(p.yaw)), abs(math.sin(p.yaw))
    return (c * a + s * b, s * a + c * b)


__all__ = ["Part", "SimulatedWorkspace", "shape_of"]
