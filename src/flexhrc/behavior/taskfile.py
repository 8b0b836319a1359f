"""The YAML task file: a task, and optionally the world it runs in.

::

    name: table setting            # optional
    task:                          # a goal mapping, a behaviour name, or the prefix string
      THEN:
        - placemat
        - AND:
            - THEN: [plate, bowl]
            - fork
            - OR: [wineglass, cup, soda_can]
    world:                         # optional: without it a default world is generated
      arms:                        # optional: default one arm at (0.15, 0, 0.95), 0.25 m/s
        - {name: arm, home: [0.15, 0.0, 0.95], speed: 0.25}
      grasp_time: 2.0              # optional, seconds
      place_time: 1.5
      objects:
        placemat: {position: [0.5, 0.1, 0.75], target: [0.8, 0.0, 0.75]}
      moves:                       # optional: the experimenter moves objects
        - {object: fork, to: [0.6, 0.4, 0.75], during_grasp: 1.0}
        - {object: cup, to: [0.5, 0.3, 0.75], at: 12.0}
    types:                         # optional: behaviour types declared from existing ones
      inspect: {base: visit, offset: [0, 0, 0.25], dwell: 1.5}
    behaviors:                     # optional: leaves that are not a PickAndPlace of their name
      look: {type: inspect, object: cup}

(see :mod:`flexhrc.behavior.types` for the built-in types and types declared in Python).

Every error names the file and the line (``file:line: message``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.behavior.task import Task, build_task, parse_prefix, task_spec_from_yaml_node
from flexhrc.behavior.types import BehaviorFactory, BehaviorTypeBuilder, behavior_type, derived_type
from flexhrc.behavior.world import Arm, MoveRule, TabletopWorld, WorldObject, default_arms
from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import WORKSPACE_M


@dataclass
class TaskDocument:
    task: Task
    world: TabletopWorld | None
    name: str | None = None
    #: Leaf name -> factory of its behaviour node, for leaves given a ``type:``.
    behaviors: dict[str, BehaviorFactory] = field(default_factory=dict)


def _line(node: Any) -> int:
    return int(node.start_mark.line) + 1


def _mapping(node: Any, what: str, source: str) -> dict[str, Any]:
    import yaml

    if not isinstance(node, yaml.MappingNode):
        raise FormatError(f"{what} must be a mapping", source, _line(node))
    out: dict[str, Any] = {}
    for k, v in node.value:
        key = str(k.value)
        if key in out:
            raise FormatError(f"{what}: key {key!r} given twice", source, _line(k))
        out[key] = v
    return out


def _vec(node: Any, what: str, source: str) -> tuple[float, float, float]:
    import yaml

    if not isinstance(node, yaml.SequenceNode) or len(node.value) != 3:
        raise FormatError(f"{what} must be a list of 3 numbers [x, y, z]", source, _line(node))
    try:
        x, y, z = (float(v.value) for v in node.value)
    except (TypeError, ValueError):
        raise FormatError(
            f"{what} must be a list of 3 numbers [x, y, z]", source, _line(node)
        ) from None
    if not all(math.isfinite(v) for v in (x, y, z)):
        raise FormatError(f"{what} must be 3 finite numbers [x, y, z]", source, _line(node))
    if any(abs(v) > WORKSPACE_M for v in (x, y, z)):
        # an arm would take for ever to get there (the tick loop ran to its timeout, B21)
        raise FormatError(
            f"{what} [{x:g}, {y:g}, {z:g}] is outside the workspace (within "
            f"{WORKSPACE_M:g} m of the origin on every axis)",
            source,
            _line(node),
        )
    return (x, y, z)


def _number(node: Any, what: str, source: str) -> float:
    try:
        return float(node.value)
    except (TypeError, ValueError, AttributeError):
        raise FormatError(f"{what} must be a number", source, _line(node)) from None


def _check_keys(fields: dict[str, Any], allowed: set[str], what: str, source: str) -> None:
    for key, node in fields.items():
        if key not in allowed:
            raise FormatError(
                f"{what}: unknown key {key!r} (expected one of {', '.join(sorted(allowed))})",
                source,
                _line(node),
            )


def _fields(
    node: Any, what: str, source: str, allowed: set[str], required: tuple[str, ...] = ()
) -> dict[str, Any]:
    """A mapping with only ``allowed`` keys and every ``required`` one: key -> value node."""
    fields = _mapping(node, what, source)
    _check_keys(fields, allowed, what, source)
    missing = [repr(key) for key in required if key not in fields]
    if missing:
        raise FormatError(f"{what}: missing {' and '.join(missing)}", source, _line(node))
    return fields


def _sequence(node: Any, message: str, source: str, *, empty: bool = True) -> list[Any]:
    """The items of a list node (none for a key not given)."""
    import yaml

    if node is None:
        return []
    if not isinstance(node, yaml.SequenceNode) or not (empty or node.value):
        raise FormatError(message, source, _line(node))
    return list(node.value)


@contextmanager
def _at(source: str, node: Any) -> Iterator[None]:
    """A :class:`FlexhrcError` of the world's own checks, with the file and line of ``node``."""
    try:
        yield
    except FlexhrcError as exc:
        raise FormatError(str(exc), source, _line(node)) from None


def world_from_yaml_node(node: Any, source: str, arms: int | None = None) -> TabletopWorld:
    """Build a :class:`TabletopWorld` from a composed YAML ``world:`` node."""
    keys = {"arms", "objects", "moves", "grasp_time", "place_time"}
    fields = _fields(node, "world", source, keys, ("objects",))
    objects = []
    for k, v in _mapping(fields["objects"], "world.objects", source).items():
        spec = _fields(v, f"object {k!r}", source, {"position", "target"}, ("position",))
        target = _vec(spec["target"], f"object {k!r} target", source) if "target" in spec else None
        objects.append(
            WorldObject(k, _vec(spec["position"], f"object {k!r} position", source), target)
        )
    arm_list: list[Arm] = []
    if "arms" in fields and arms is None:
        listed = _sequence(
            fields["arms"], "world.arms must be a non-empty list", source, empty=False
        )
        for a in listed:
            spec = _fields(a, "arm", source, {"name", "home", "speed"}, ("name", "home"))
            speed = _number(spec["speed"], "arm speed", source) if "speed" in spec else 0.25
            with _at(source, a):
                arm_list.append(
                    Arm(str(spec["name"].value), _vec(spec["home"], "arm home", source), speed)
                )
    else:
        arm_list = default_arms(arms or 1)
    moves = []
    for m in _sequence(fields.get("moves"), "world.moves must be a list", source):
        spec = _fields(m, "move", source, {"object", "to", "at", "during_grasp"}, ("object", "to"))
        at, dg = (
            _number(spec[k], f"move {k!r}", source) if k in spec else None
            for k in ("at", "during_grasp")
        )
        with _at(source, m):
            moves.append(
                MoveRule(str(spec["object"].value), _vec(spec["to"], "move 'to'", source), at, dg)
            )
    times = {k: _number(fields[k], k, source) for k in ("grasp_time", "place_time") if k in fields}
    with _at(source, node):
        return TabletopWorld(objects, arm_list, moves, **times)


def compose(text: str, source: str) -> Any:
    import yaml

    try:
        return yaml.compose(text, Loader=yaml.SafeLoader)
    except RecursionError:
        raise FormatError("invalid YAML: nested too deeply", source) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise FormatError(f"invalid YAML: {problem}", source, line) from None


def load_task_document(text: str, source: str = "<task>", arms: int | None = None) -> TaskDocument:
    """Parse a YAML task document (see the module docstring)."""
    import yaml

    root = compose(text, source)
    if root is None:
        raise FormatError("empty task file", source, 1)
    if isinstance(root, yaml.ScalarNode):
        return TaskDocument(build_task(task_spec_from_yaml_node(root, source), source), None)
    keys = {"name", "task", "world", "description", "types", "behaviors"}
    fields = _fields(root, "task file", source, keys)
    if "task" not in fields:
        raise FormatError("missing 'task' (e.g. task: {THEN: [a, b]})", source, _line(root))
    task = build_task(task_spec_from_yaml_node(fields["task"], source), source)
    world = world_from_yaml_node(fields["world"], source, arms) if "world" in fields else None
    name = str(fields["name"].value) if "name" in fields else None
    types = _types(fields["types"], source) if "types" in fields else {}
    behaviors = (
        _behaviors(fields["behaviors"], task, types, source) if "behaviors" in fields else {}
    )
    return TaskDocument(task, world, name, behaviors)


def parse_task(text: str, source: str = "<task>") -> Task:
    """Parse a task given either as prefix text (first significant character ``(``) or as a YAML
    document (a ``task:`` key, optionally a ``world:``; see the module docstring)."""
    significant = re.sub(r"#[^\n]*", "", text).strip()
    if significant.startswith("("):
        return parse_prefix(text, source)
    return load_task_document(text, source).task


def load_task(path: str | Path) -> Task:
    """Read a task file, prefix text or YAML (:func:`parse_task`)."""
    from flexhrc.files import read_text

    return parse_task(read_text(path), str(path))


def _plain(node: Any) -> Any:
    """A composed YAML node as plain Python values (safe constructors only)."""
    import yaml

    loader = yaml.SafeLoader("")
    try:
        return loader.construct_object(node, deep=True)
    finally:
        loader.dispose()


def _types(node: Any, source: str) -> dict[str, BehaviorTypeBuilder]:
    out: dict[str, BehaviorTypeBuilder] = {}
    for key, spec_node in _mapping(node, "types", source).items():
        spec = _mapping(spec_node, f"type {key!r}", source)
        if "base" not in spec:
            raise FormatError(
                f"type {key!r}: missing 'base' (e.g. base: visit)", source, _line(spec_node)
            )
        base = str(spec["base"].value)
        defaults = {k: _plain(v) for k, v in spec.items() if k != "base"}
        with _at(source, spec["base"]):  # a base declared earlier in this file, or registered
            out[key] = derived_type(out.get(base, base), defaults)
    return out


def _behaviors(
    node: Any, task: Task, types: dict[str, BehaviorTypeBuilder], source: str
) -> dict[str, BehaviorFactory]:
    leaves = set(task.behaviors)
    out: dict[str, BehaviorFactory] = {}
    for key, spec_node in _mapping(node, "behaviors", source).items():
        line = _line(spec_node)
        if key not in leaves:
            raise FormatError(
                f"behaviors: {key!r} is not a behaviour of the task "
                f"(behaviours: {', '.join(task.behaviors)})",
                source,
                line,
            )
        spec = _mapping(spec_node, f"behaviour {key!r}", source)
        if "type" not in spec:
            raise FormatError(f"behaviour {key!r}: missing 'type'", source, line)
        type_name = str(spec["type"].value)
        params = {k: _plain(v) for k, v in spec.items() if k != "type"}
        try:
            builder = types[type_name] if type_name in types else behavior_type(type_name)
            out[key] = builder(key, params)
        except FlexhrcError as exc:
            raise FormatError(f"behaviour {key!r}: {exc}", source, line) from None
    return out
