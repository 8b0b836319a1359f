"""The truth of the simulated workspace, changed by what the agents physically do.

:class:`WorkspaceTruth` is the simulated workspace (:class:`~flexhrc.sensing.world.
SimulatedWorkspace`) as the in-process agents of a cell change it: each agent reports what it
carries out (its ``on_executed`` observer, :class:`~flexhrc.cell.components.Executed`) and the
truth applies the physical effect (:func:`physical_effect`) at the action's end on the cell's
clock, where the agent *believed* things were. The operator's nudges (:class:`Nudge`) are the
only changes nobody reports: the camera looks at them when they happen.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from flexhrc.cell.components import Executed
from flexhrc.errors import FlexhrcError
from flexhrc.sensing.world import SimulatedWorkspace
from flexhrc.taskmanager.domain import GroundAction

#: Actions after which the world looks different (approach and rest only move an arm).
WORLD_CHANGING = ("grasp", "transport", "screw", "ungrasp", "pick_up", "put_down")
HOLD_HEIGHT_M = 0.10


@dataclass
class Nudge:
    """The operator moves the part the ``nth`` robot ``action`` goes for, by ``offset`` (m),
    ``at_fraction`` of the way through that action."""

    action: str = "approach"
    nth: int = 1
    offset: tuple[float, float] = (0.0, 0.08)
    at_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.nth < 1 or not 0.0 <= self.at_fraction <= 1.0:
            raise FlexhrcError("a nudge needs nth >= 1 and at_fraction in [0, 1]")
        if not all(math.isfinite(v) for v in self.offset):
            raise FlexhrcError(f"a nudge offset must be finite, got {self.offset}")


@dataclass(order=True)
class _Effect:
    at: float
    seq: int
    key: Any = field(compare=False)
    kind: str = field(compare=False)  # effect | nudge
    apply: Callable[[], str | None] = field(compare=False)
    cancelled: bool = field(default=False, compare=False)


class WorkspaceTruth:
    """The simulated workspace as it really is, changed by the agents' actions at their ends on
    the cell's clock (see the module docstring). Give :meth:`on_executed` to every in-process
    agent; :meth:`advance` brings it to a time before anyone looks."""

    def __init__(self, world: SimulatedWorkspace, nudges: Iterable[Nudge] = ()) -> None:
        self.world = world
        tops = [p.name for p in world.parts.values() if p.shape == "box"]
        self.board = tops[0] if tops else None
        self.nudges = list(nudges)
        self.now = 0.0
        self.events: list[dict[str, Any]] = []  # what the operator did that nobody reports
        self.whys: list[str] = []  # what changed the world since the last look
        self.ends: list[tuple[float, str, int | str]] = []  # (end, robot kind, command) done
        self._queue: list[_Effect] = []
        self._seq = itertools.count()
        self._by_key: dict[Any, _Effect] = {}
        self._counts: dict[str, int] = {}

    # -- the agents' observer -------------------------------------------------------------
    def on_executed(self, ex: Executed) -> str | None:
        """An agent carries out ``ex`` now (``ex.start``): a robot's grasp closes on what lies
        where it believes the part is (nothing there: the action fails); the effect lands at
        ``ex.end``; a nudge planned on this action is scheduled."""
        self.advance(ex.start)
        action, kind = ex.action, ex.action.schema.kind
        believed = _believed(ex.believed)
        robot = isinstance(ex.command, int)
        if robot:
            n = self._counts[kind] = self._counts.get(kind, 0) + 1
            for nudge in self.nudges:
                if nudge.action == kind and nudge.nth == n and len(action.args) > 1:
                    target = self.world.nearest(believed(action.args[1]), within=0.05)
                    if target is not None:
                        at = ex.start + nudge.at_fraction * (ex.end - ex.start)
                        self._push(at, None, "nudge", self._nudge(target.name, nudge.offset))
        if ex.status != "done":
            return None
        if robot and kind == "grasp":
            spot = believed(action.args[1])
            if self.world.nearest(spot, within=self.world.grasp_tolerance_m) is None:
                obj = action.args[1]
                return f"nothing to grasp at ({spot[0]:.3f}, {spot[1]:.3f}): {obj} is not there"

        def effect() -> str | None:
            physical_effect(self.world, action, ex.agent, believed, self.board)
            return f"after {action}" if _changes_world(action) or not robot else None

        self._push(ex.end, ex.command, "effect", effect)
        if robot:
            self.ends.append((ex.end, kind, ex.command))
        return None

    def stop(self, command: int, agent: str, t: float) -> None:
        """The manager stopped ``command``: it never ends; the arm lays what it holds back where
        it took it (the manager believes it released where the arm is: perception sees
        otherwise and re-anchors it)."""
        self.advance(t)
        eff = self._by_key.pop(command, None)
        if eff is not None:
            eff.cancelled = True
        self.ends = [e for e in self.ends if e[2] != command]
        if self.world.put_back(agent) is not None:
            self.whys.append(f"{agent} stopped")

    def advance(self, t: float) -> None:
        """Apply every effect due by ``t``, in time order."""
        while self._queue and self._queue[0].at <= t:
            eff = heapq.heappop(self._queue)
            if eff.cancelled:
                continue
            self._by_key.pop(eff.key, None)
            self.now = max(self.now, eff.at)
            why = eff.apply()
            if why:
                self.whys.append(why)
        self.now = max(self.now, t)

    def next_wake(self) -> float | None:
        """When the operator nudges a part next (nobody reports it: the camera looks then)."""
        due = [e.at for e in self._queue if e.kind == "nudge" and not e.cancelled]
        return min(due) if due else None

    # -- internals ------------------------------------------------------------------------
    def _push(self, at: float, key: Any, kind: str, fn: Callable[[], str | None]) -> None:
        eff = _Effect(at, next(self._seq), key, kind, fn)
        heapq.heappush(self._queue, eff)
        if key is not None:
            self._by_key[key] = eff

    def _nudge(self, name: str, offset: tuple[float, float]) -> Callable[[], str | None]:
        def nudge() -> str | None:
            part = self.world.parts.get(name)
            if part is None or part.holder is not None or part.upright:
                return None  # already taken: nothing to nudge
            dx, dy = offset
            # dy points away from the middle of the table; where that spot is taken, the
            # operator puts the part in the first free spot as far away in another direction
            side = 1.0 if part.position[1] >= 0 else -1.0
            size = math.hypot(dx, dy)
            options = [(dx, side * dy), (size, 0.0), (-size, 0.0), (dx, -side * dy)]
            x, y, _ = part.position
            chosen = next(
                (o for o in options if self.world.clear_at(name, (x + o[0], y + o[1]))), None
            )
            t = round(self.now, 6)
            if chosen is None:
                self.events.append(
                    {"t": t, "type": "operator_nudge_skipped", "part": name,
                     "reason": "no free spot"}
                )  # fmt: skip
                return None
            self.world.displace(name, chosen)
            self.events.append(
                {"t": t, "type": "operator_nudges", "part": name, "offset": list(chosen)}
            )
            return "the operator moved a part"

        return nudge


def _believed(
    positions: dict[str, tuple[float, float, float]],
) -> Callable[[str], tuple[float, float, float]]:
    def where(name: str) -> tuple[float, float, float]:
        p = positions.get(name)
        if p is None:
            raise FlexhrcError(f"no believed position of {name!r}")
        return (float(p[0]), float(p[1]), float(p[2]))

    return where


def _changes_world(action: GroundAction) -> bool:
    schema = action.schema
    return schema.kind in WORLD_CHANGING or bool(
        getattr(schema, "carries", None) or getattr(schema, "fixes", None)
    )


def physical_effect(
    world: SimulatedWorkspace,
    action: GroundAction,
    agent: str,
    believed: Callable[[str], tuple[float, float, float]],
    board: str | None,
) -> None:
    """What ``action`` by ``agent`` does to the truth. Robot and operator act where they
    *believe* things are (``believed(name)``: a position): a grasp closes on whatever lies at
    the believed place, a leg carried above a bolt of ``board`` is held upright, a screwed one
    stands upright on it; a part the domain ``carries`` to a ``moves_to`` place without a hand
    (both arms placing the tabletop) is put there."""
    schema = action.schema
    kind, args, binding = schema.kind, action.args, action.binding
    carries = binding.get(getattr(schema, "carries", None) or "")
    moves_to = binding.get(getattr(schema, "moves_to", None) or "")
    if len(action.agents) > 1:
        # a joint action (the tabletop in both hands, Fig. 8): a part here has one holder, so
        # only where the domain puts it counts — picking, turning and letting go move nothing
        kind = "joint"
    if kind == "grasp":
        world.grasp(agent, believed(args[1]))
    elif kind == "transport":
        x, y, _ = believed(moves_to or args[2])
        over = world.over_board((x, y))
        held = world.held_by(agent)
        if over is not None and held is not None and held.shape == "cylinder":
            # above a bolt the leg is held upright, its foot just above the board
            top = over.position[2] + over.dims[2] / 2
            world.carry(agent, (x, y, top + 0.01 + held.dims[0] / 2), upright=True)
        else:
            world.carry(agent, (x, y, HOLD_HEIGHT_M))
    elif kind == "screw":
        world.attach(agent, believed(args[2]), on=board)
    elif kind in ("ungrasp", "put_down"):
        world.release(agent)
    elif kind == "pick_up":
        world.pick_up(agent, believed(args[1]))
    elif carries and moves_to:
        part = world.nearest(believed(carries), within=0.05)
        if part is not None:
            world.relocate(part.name, believed(moves_to))


__all__ = ["HOLD_HEIGHT_M", "WORLD_CHANGING", "Nudge", "WorkspaceTruth", "physical_effect"]
