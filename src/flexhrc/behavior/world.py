"""A simulated tabletop world: objects with 3D positions, one or two arms, timed pick-and-place.

This is the environment the behaviour nodes of paper 002 sense and act on. It is deliberately
simple and deterministic (no physics, no randomness after construction):

* an object has a position, an optional place target, and is either free or held by an arm;
* an arm has a home pose and a Cartesian speed (m/s). A pick-and-place is a straight-line
  *reach* to the object, a fixed *grasp* time, a *carry* to the target, a fixed *place* time and a
  *return* home — so its duration follows from the distances (``distance / speed``);
* objects can be moved by the experimenter: at a given time (``MoveRule.at``) or a given delay
  after an arm starts reaching for them (``MoveRule.during_grasp``) — the robustness run of the
  paper's Fig. 6, where objects were moved while the robot was trying to grasp them.

Sensing is what PickAndPlace needs for its activation potential (Algorithm 8: one over the
distance arm–object) and for ObjectInView (Algorithm 9). :meth:`TabletopWorld.step` is called
once per tick with the simulated time; nothing here reads a wall clock.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

from flexhrc.errors import FlexhrcError, UnknownNameError

Vec = tuple[float, float, float]

#: The phases of a :class:`PickAndPlaceMotion`, in order (then ``finished``).
PHASES = ("reach", "grasp", "carry", "place", "return")

#: Table height and reach region used by generated default worlds (metres, robot base frame).
TABLE_Z = 0.75
DEFAULT_REGION = ((0.35, 0.85), (-0.45, 0.45))


def vec(values: Iterable[float]) -> Vec:
    v = tuple(float(x) for x in values)
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise FlexhrcError(f"expected 3 finite coordinates, got {list(v)}")
    return (v[0], v[1], v[2])


@dataclass
class Arm:
    """A robot arm: where it rests, how fast it moves, where it is now."""

    name: str
    home: Vec
    speed: float = 0.25
    position: Vec = None  # type: ignore[assignment]  # set to home in __post_init__
    motion: PickAndPlaceMotion | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if not self.speed > 0:
            raise FlexhrcError(f"arm {self.name!r}: speed must be > 0")
        if self.position is None:
            self.position = self.home

    @property
    def free_position(self) -> Vec:
        """Where the arm will be when it is next free: the end of its current motion (its rest
        pose), or where it is now when idle. Activation potentials are measured from here."""
        return self.motion.home if self.motion is not None else self.position


@dataclass
class WorldObject:
    name: str
    position: Vec
    target: Vec | None = None
    visible: bool = True
    held_by: str | None = None


@dataclass(frozen=True)
class MoveRule:
    """The experimenter moves ``object`` to ``to`` at time ``at`` or ``during_grasp`` seconds
    after an arm starts a pick-and-place of it (only while it is still on the table)."""

    object: str
    to: Vec
    at: float | None = None
    during_grasp: float | None = None

    def __post_init__(self) -> None:
        if (self.at is None) == (self.during_grasp is None):
            raise FlexhrcError(
                f"move of {self.object!r}: give exactly one of 'at' or 'during_grasp'"
            )


@dataclass(frozen=True)
class PickAndPlaceMotion:
    """Time-parametrised straight-line pick-and-place: reach → grasp → carry → place → return."""

    arm: str
    object: str | None  # None: a move to a pose that carries nothing (start_move)
    start: float
    start_pos: Vec
    grasp_pos: Vec
    target: Vec
    home: Vec
    t_reach: float
    t_grasp: float
    t_carry: float
    t_place: float
    t_end: float

    def phase_at(self, t: float) -> str:
        ends = (self.t_reach, self.t_grasp, self.t_carry, self.t_place, self.t_end)
        return next((phase for phase, end in zip(PHASES, ends, strict=True) if t < end), "finished")

    def grasped(self, t: float) -> bool:
        """True once the gripper has closed on the object (validity checking stops then)."""
        return t >= self.t_grasp

    def position_at(self, t: float) -> Vec:
        """Straight lines between the poses of the phases: the arm's position at time ``t``."""
        if t <= self.start:
            return self.start_pos
        poses = (
            (self.start, self.start_pos),
            (self.t_reach, self.grasp_pos),
            (self.t_grasp, self.grasp_pos),
            (self.t_carry, self.target),
            (self.t_place, self.target),
            (self.t_end, self.home),
        )
        for (t0, p0), (t1, p1) in pairwise(poses):
            if t < t1:
                return p0 if p0 is p1 else _lerp(p0, p1, (t - t0) / (t1 - t0))
        return self.home

    @property
    def duration(self) -> float:
        return self.t_end - self.start


def _dist(a: Vec, b: Vec) -> float:
    # numpy's sqrt(sum of squares), so an incremental refresh gives the same float as a full one
    dx, dy, dz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return math.sqrt(dx * dx + dy * dy + dz * dz)


def _lerp(a: Vec, b: Vec, s: float) -> Vec:
    return (a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s)


class TabletopWorld:
    """Objects, arms and the experimenter's scheduled moves; advanced by :meth:`step`."""

    def __init__(
        self,
        objects: Iterable[WorldObject],
        arms: Sequence[Arm],
        moves: Iterable[MoveRule] = (),
        grasp_time: float = 2.0,
        place_time: float = 1.5,
    ) -> None:
        self.objects: dict[str, WorldObject] = {}
        for obj in objects:
            if obj.name in self.objects:
                raise FlexhrcError(f"object {obj.name!r} defined twice")
            self.objects[obj.name] = obj
        if not arms:
            raise FlexhrcError("the world needs at least one arm")
        self.arms: dict[str, Arm] = {}
        for arm in arms:
            if arm.name in self.arms:
                raise FlexhrcError(f"arm {arm.name!r} defined twice")
            self.arms[arm.name] = arm
        self.moves: list[MoveRule] = list(moves)
        for rule in self.moves:
            self._object(rule.object)
        self._fired = [False] * len(self.moves)
        self.grasp_time = float(grasp_time)
        self.place_time = float(place_time)
        #: Incremented by :meth:`step` when something the activation potentials depend on changed
        #: (an object position, an arm's free position), so behaviours can cache their sensing.
        self.sensing_version = 0
        self._free = self._free_positions()
        self._listeners: list[Callable[[set[str] | None], None]] = []
        self._index = {name: i for i, name in enumerate(self.objects)}
        self.min_distance = 1e-3  # distances below this count as this, so 1/distance stays finite
        self._pending: set[str] = set()
        self._pending_all = (
            True  # the first step senses everything (positions may be edited before)
        )
        self._pot_best: list[float] = []
        self._pot_arm: list[list[float]] = []
        #: Per object, the sensing version at which its potential last changed; and the version
        #: at which every potential changed (an arm's free position). A behaviour whose object
        #: has not changed since it last looked need not look again.
        self.sensing_stamps: list[int] = [0] * len(self.objects)
        self.sensing_stamp_all = 0
        self._refresh_potentials()

    # -- sensing -------------------------------------------------------------------------------
    @property
    def arm_names(self) -> list[str]:
        return list(self.arms)

    def object_position(self, name: str) -> Vec:
        return self._object(name).position

    def arm_position(self, arm: str) -> Vec:
        return self._arm(arm).position

    def object_index(self, name: str) -> int:
        """Stable index of an object, for :meth:`potentials`."""
        self._object(name)
        return self._index[name]

    def potentials(self) -> tuple[list[float], list[list[float]]]:
        """``1 / distance`` arm–object for every object (Algorithm 8) as sensed at the last
        :meth:`step`: ``(best over arms, per arm)``, indexed by :meth:`object_index`.

        Sensing is sampled once per tick, at the end of :meth:`step`: a change a behaviour makes
        during the tick (an arm stopped by a reset) is sensed by every node at the next tick,
        whatever the order in which nodes run. All distances are computed in one vectorised
        numpy step per change — what keeps a 10 000-node tick cheap.
        """
        return self._pot_best, self._pot_arm

    def _refresh_potentials(self) -> None:
        import numpy as np

        objs = np.array([o.position for o in self.objects.values()], dtype=float).reshape(-1, 3)
        arms = np.array(self._free_positions(), dtype=float).reshape(-1, 3)
        d = np.sqrt(((objs[None, :, :] - arms[:, None, :]) ** 2).sum(axis=2))
        pot = 1.0 / np.maximum(d, self.min_distance)
        self._pot_arm = pot.tolist()
        self._pot_best = pot.max(axis=0).tolist() if len(self.objects) else []

    def _refresh_objects(self, names: set[str]) -> None:
        """Recompute the potentials of a few objects only (the arms did not move): the common
        case of one object being carried, at O(changed) instead of O(objects) per tick."""
        free = self._free_positions()
        best = self._pot_best
        per_arm = self._pot_arm
        floor = self.min_distance
        for name in names:
            i = self._index[name]
            pos = self.objects[name].position
            top = 0.0
            for k, arm_pos in enumerate(free):
                p = 1.0 / max(_dist(pos, arm_pos), floor)
                per_arm[k][i] = p
                top = p if p > top else top
            best[i] = top

    def _free_positions(self) -> list[Vec]:
        return [a.free_position for a in self.arms.values()]

    def add_sensing_listener(self, callback: Callable[[set[str] | None], None]) -> None:
        """``callback(objects)`` at the end of a :meth:`step` that changed what is sensed: the set
        of objects whose activation potential may have changed, or ``None`` for all (an arm's
        free position changed). An executor uses it to wake only the behaviours concerned."""
        self._listeners.append(callback)

    def _sensing_changed(self, objects: set[str] | None = None) -> None:
        if self._free != self._free_positions():
            objects = None
            self._free = self._free_positions()
        if objects is None:
            self._pending_all = True
        else:
            self._pending.update(objects)

    def _publish_sensing(self) -> None:
        if not self._pending_all and not self._pending:
            return
        changed: set[str] | None = None if self._pending_all else set(self._pending)
        self._pending_all = False
        self._pending.clear()
        if changed is None or 4 * len(changed) > len(self.objects):
            self._refresh_potentials()
        else:
            self._refresh_objects(changed)
        self.sensing_version += 1
        if changed is None:
            self.sensing_stamp_all = self.sensing_version
        else:
            for name in changed:
                self.sensing_stamps[self._index[name]] = self.sensing_version
        for callback in self._listeners:
            callback(changed)

    def object_in_view(self, name: str) -> bool:
        """Algorithm 9's ObjectInView(): the object exists, is visible and nobody holds it."""
        obj = self.objects.get(name)
        return obj is not None and obj.visible and obj.held_by is None

    def has_object(self, name: str) -> bool:
        return name in self.objects

    # -- acting --------------------------------------------------------------------------------
    def start_pick_and_place(self, arm: str, obj: str, now: float) -> PickAndPlaceMotion:
        o = self._object(obj)
        target = o.target if o.target is not None else o.position
        return self._start(arm, obj, o.position, target, self.grasp_time, self.place_time, now)

    def start_move(self, arm: str, pose: Vec, dwell: float, now: float) -> PickAndPlaceMotion:
        """Move ``arm`` to ``pose``, hold it there ``dwell`` seconds, and return home — for
        behaviours that carry nothing (look at an object, point, wait for a hand-over). The
        motion's phases are ``reach``, ``grasp`` (the dwell) and ``return``."""
        if not (math.isfinite(dwell) and dwell >= 0):
            raise FlexhrcError(f"dwell must be a finite number >= 0, got {dwell}")
        pose = vec(pose)
        return self._start(arm, None, pose, pose, dwell, 0.0, now)

    def _start(
        self, arm: str, obj: str | None, at: Vec, to: Vec, hold: float, place: float, now: float
    ) -> PickAndPlaceMotion:
        """Reach ``at``, hold ``hold`` s, carry to ``to``, hold ``place`` s, return home: the
        straight-line motion of every behaviour, at the arm's speed."""
        a = self._arm(arm)
        if a.motion is not None:
            raise FlexhrcError(f"arm {arm!r} is busy with {a.motion.object!r}")
        t_reach = now + math.dist(a.position, at) / a.speed
        t_grasp = t_reach + hold
        t_carry = t_grasp + math.dist(at, to) / a.speed
        t_place = t_carry + place
        t_end = t_place + math.dist(to, a.home) / a.speed
        a.motion = PickAndPlaceMotion(
            arm, obj, now, a.position, at, to, a.home, t_reach, t_grasp, t_carry, t_place, t_end
        )
        self._sensing_changed(set())
        return a.motion

    def abort(self, arm: str, now: float) -> None:
        """Stop the arm where it is (the behaviour was reset by validity checking)."""
        a = self._arm(arm)
        if a.motion is not None:
            a.position = a.motion.position_at(now)
            o = self.objects.get(a.motion.object) if a.motion.object else None
            if o is not None and o.held_by == arm:
                o.held_by = None
            a.motion = None
            self._sensing_changed()

    def move_object(self, name: str, to: Vec) -> None:
        self._object(name).position = to
        self._sensing_changed({name})

    def step(self, now: float) -> list[dict[str, Any]]:
        """Advance to time ``now``: fire due moves, move arms and held objects. Returns events."""
        events: list[dict[str, Any]] = []
        for i, rule in enumerate(self.moves):
            if self._fired[i]:
                continue
            obj = self.objects[rule.object]
            if obj.held_by is not None:
                continue
            due = False
            if rule.at is not None:
                due = now >= rule.at
            else:
                for a in self.arms.values():
                    m = a.motion
                    if m is not None and m.object == rule.object and not m.grasped(now):
                        due = now - m.start >= rule.during_grasp  # type: ignore[operator]
                        break
            if due:
                self._fired[i] = True
                events.append(
                    {
                        "kind": "move",
                        "object": rule.object,
                        "from": list(obj.position),
                        "to": list(rule.to),
                    }
                )
                self.move_object(rule.object, rule.to)
        for a in self.arms.values():
            m = a.motion
            if m is None:
                continue
            a.position = m.position_at(now)
            phase = m.phase_at(now)
            if m.object is None:  # a move to a pose (start_move): no object is carried
                if phase == "finished":
                    a.motion = None
                    a.position = a.home
                    self._sensing_changed(set())
                continue
            obj = self.objects[m.object]
            moved_object = False
            if phase in ("carry", "place"):
                # taking hold counts as a change even where the position stays: ObjectInView
                moved_object = obj.held_by != a.name or obj.position != a.position
                obj.held_by = a.name
                obj.position = a.position
            elif phase in ("return", "finished"):
                obj.held_by = None
                moved_object = obj.position != m.target
                obj.position = m.target
            if phase == "finished":
                a.motion = None
                a.position = a.home
            if phase == "finished" or moved_object:
                self._sensing_changed({obj.name} if moved_object else set())
        self._publish_sensing()
        return events

    # -- helpers -------------------------------------------------------------------------------
    def _object(self, name: str) -> WorldObject:
        try:
            return self.objects[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown object {name!r} (known: {', '.join(sorted(self.objects)) or 'none'})"
            ) from None

    def _arm(self, name: str) -> Arm:
        try:
            return self.arms[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown arm {name!r} (known: {', '.join(self.arms)})"
            ) from None

    def snapshot(self) -> dict[str, Any]:
        return {
            "objects": {n: list(o.position) for n, o in self.objects.items()},
            "arms": {n: list(a.position) for n, a in self.arms.items()},
        }


def default_arms(count: int = 1, speed: float = 0.25) -> list[Arm]:
    """One arm in the middle, or a left and a right arm, resting above the table edge."""
    if count == 1:
        return [Arm("arm", (0.15, 0.0, 0.95), speed)]
    if count == 2:
        return [Arm("left", (0.15, 0.3, 0.95), speed), Arm("right", (0.15, -0.3, 0.95), speed)]
    raise FlexhrcError(f"--arms must be 1 or 2, got {count}")


def random_world(objects: Sequence[str], seed: int = 0, arms: int = 1) -> TabletopWorld:
    """The default world for a task given without one: each behaviour's object at a seeded random
    position on the table (x in 0.35..0.85 m, y in -0.45..0.45 m, z = 0.75 m) and a place target
    in a row at the far edge (x = 1.0 m)."""
    import numpy as np

    rng = np.random.default_rng(seed)
    (x0, x1), (y0, y1) = DEFAULT_REGION
    n = len(objects)
    objs = []
    for i, name in enumerate(objects):
        x = float(rng.uniform(x0, x1))
        y = float(rng.uniform(y0, y1))
        ty = y0 + (y1 - y0) * (i + 0.5) / max(n, 1)
        objs.append(
            WorldObject(name, (round(x, 4), round(y, 4), TABLE_Z), (1.0, round(ty, 4), TABLE_Z))
        )
    return TabletopWorld(objs, default_arms(arms))
