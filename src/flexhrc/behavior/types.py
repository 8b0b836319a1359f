"""Behaviour types: the kinds of leaf a task file can name, declared in Python or in YAML.

Every leaf of a task is a behaviour. By default it is a
:class:`~flexhrc.behavior.behaviors.PickAndPlace` of the object with its name. A YAML task file
can give a leaf another *type* in its ``behaviors:`` section, and declare new types from
existing ones in its ``types:`` section::

    task: {THEN: [mug, look_at_mug]}
    types:
      inspect: {base: visit, offset: [0, 0, 0.25], dwell: 1.5}   # a type declared in YAML
    behaviors:
      look_at_mug: {type: inspect, object: mug}

Built-in types:

* ``pick_and_place`` — ``object`` (default: the leaf's name);
* ``visit`` — move an arm to a pose, hold it ``dwell`` seconds (default 1), return home:
  ``pose: [x, y, z]``, or ``object`` plus ``offset`` (default ``[0, 0, 0.2]``: above it). With
  an object, validity checking watches it until the dwell ends, and the potential is
  ``1 / distance`` from the arm to the pose.

A type declared in Python is a function ``builder(leaf, params) -> factory`` registered with
:func:`register_behavior_type`; ``factory(name, world, transport, params)`` makes the node (any
:class:`~flexhrc.behavior.behaviors.BehaviorNode` subclass). See
``examples/custom_behavior.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from flexhrc.behavior.behaviors import BehaviorNode, MotionBehavior, PickAndPlace
from flexhrc.behavior.params import NetworkParams
from flexhrc.behavior.validity import ValidityCheck
from flexhrc.behavior.world import TabletopWorld, Vec, vec
from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.transport.base import Transport

#: ``factory(name, world, transport, params)`` -> the behaviour node of one leaf.
BehaviorFactory = Callable[[str, TabletopWorld, Transport, NetworkParams], BehaviorNode]
#: ``builder(leaf name, parameters from the task file)`` -> a factory (raise FlexhrcError on
#: bad parameters; the task file loader adds the file and line).
BehaviorTypeBuilder = Callable[[str, Mapping[str, Any]], BehaviorFactory]

_TYPES: dict[str, BehaviorTypeBuilder] = {}


def register_behavior_type(name: str, builder: BehaviorTypeBuilder) -> None:
    """Make ``name`` usable as ``type:`` in task files (replaces an earlier registration)."""
    if not name or not name.replace("_", "").isalnum():
        raise FlexhrcError(f"behaviour type name {name!r}: use letters, digits and '_'")
    _TYPES[name] = builder


def behavior_types() -> list[str]:
    return sorted(_TYPES)


def behavior_type(name: str) -> BehaviorTypeBuilder:
    try:
        return _TYPES[name]
    except KeyError:
        raise UnknownNameError(
            f"unknown behaviour type {name!r} (known: {', '.join(behavior_types())})"
        ) from None


def derived_type(
    base: str | BehaviorTypeBuilder, defaults: Mapping[str, Any]
) -> BehaviorTypeBuilder:
    """A type declared in YAML: ``base`` (a registered name, or a type itself) with default
    parameters."""
    parent = behavior_type(base) if isinstance(base, str) else base

    def builder(leaf: str, params: Mapping[str, Any]) -> BehaviorFactory:
        return parent(leaf, {**defaults, **params})

    return builder


def _check_keys(params: Mapping[str, Any], allowed: set[str], what: str) -> None:
    unknown = sorted(set(params) - allowed)
    if unknown:
        raise FlexhrcError(
            f"{what}: unknown parameter {unknown[0]!r} (expected: {', '.join(sorted(allowed))})"
        )


def _pick_and_place(leaf: str, params: Mapping[str, Any]) -> BehaviorFactory:
    _check_keys(params, {"object"}, "pick_and_place")
    obj = str(params.get("object", leaf))

    def make(
        name: str, world: TabletopWorld, transport: Transport, p: NetworkParams
    ) -> BehaviorNode:
        world.object_index(obj)  # a clear error for an unknown object
        return PickAndPlace(name, obj, world, transport, p)

    return make


class Visit(MotionBehavior):
    """Move an arm to a pose (absolute, or relative to an object), hold, return (type ``visit``)."""

    def __init__(
        self,
        name: str,
        world: TabletopWorld,
        transport: Transport,
        params: NetworkParams,
        *,
        obj: str | None = None,
        pose: Vec | None = None,
        offset: Vec = (0.0, 0.0, 0.2),
        dwell: float = 1.0,
    ) -> None:
        super().__init__(name, world, transport, params, obj)
        if obj is not None:
            world.object_index(obj)
        self._pose = pose
        self._offset = offset
        self.dwell = dwell

    def pose(self) -> Vec:
        if self._pose is not None:
            return self._pose
        assert self.object is not None
        x, y, z = self._world.object_position(self.object)
        dx, dy, dz = self._offset
        return (x + dx, y + dy, z + dz)

    def bid(self, arm: str) -> float:
        d = math.dist(self._world.arms[arm].free_position, self.pose())
        return 1.0 / max(d, self._world.min_distance)

    def ready(self) -> bool:
        return self.object is None or self._world.object_in_view(self.object)

    def start_action(self, arm: str) -> dict[str, object]:
        self._motion = self._world.start_move(arm, self.pose(), self.dwell, self.now)
        if self.object is not None:
            self._check = ValidityCheck.watch(
                self._world, self.object, self._params.validity_threshold
            )
        return {"pose": [round(v, 3) for v in self.pose()], "duration": self._motion.duration}


def _vec_param(value: Any, what: str) -> Vec:
    if not isinstance(value, list | tuple):
        raise FlexhrcError(f"{what} must be a list of 3 numbers [x, y, z]")
    try:
        return vec(float(v) for v in value)
    except (TypeError, ValueError, FlexhrcError):
        raise FlexhrcError(f"{what} must be a list of 3 finite numbers [x, y, z]") from None


def _visit(leaf: str, params: Mapping[str, Any]) -> BehaviorFactory:
    _check_keys(params, {"object", "pose", "offset", "dwell"}, "visit")
    obj = params.get("object")
    if "pose" in params and "offset" in params:
        raise FlexhrcError("visit: give 'pose' or 'offset', not both")
    if obj is None and "pose" not in params:
        raise FlexhrcError("visit: needs 'object' (with an optional 'offset') or 'pose'")
    pose = _vec_param(params["pose"], "visit pose") if "pose" in params else None
    offset = _vec_param(params.get("offset", [0.0, 0.0, 0.2]), "visit offset")
    dwell = params.get("dwell", 1.0)
    if isinstance(dwell, bool) or not isinstance(dwell, int | float):
        raise FlexhrcError(f"visit dwell must be a number of seconds, got {dwell!r}")
    if not (math.isfinite(dwell) and 0 <= dwell <= 3600):
        raise FlexhrcError(f"visit dwell must be in 0..3600 s, got {dwell}")

    def make(
        name: str, world: TabletopWorld, transport: Transport, p: NetworkParams
    ) -> BehaviorNode:
        return Visit(
            name,
            world,
            transport,
            p,
            obj=None if obj is None else str(obj),
            pose=pose,
            offset=offset,
            dwell=float(dwell),
        )

    return make


register_behavior_type("pick_and_place", _pick_and_place)
register_behavior_type("visit", _visit)
