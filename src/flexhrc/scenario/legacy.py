"""The older scenario files (``scenario: table_assembly``, ``scenario: parallel_assembly``),
translated into a :class:`~flexhrc.scenario.Scenario` by one function, :func:`from_legacy`.

Such a file names a ready-made task and sets its options::

    scenario: table_assembly      # the legs fix of one table (paper 000, Figs. 9-12)
    legs: 6
    tabletop: [0.6, 0.6]          # large, small, WIDTHxDEPTH or [width, depth]
    unreachable_bolts: [2]

    scenario: parallel_assembly   # independent sockets for many arms and operators
    arms: 4
    humans: 2
    legs: 8

Every bad value is one :class:`~flexhrc.errors.FormatError` naming the file and the line of its
key. ``flexhrc run``, ``flexhrc demo``, ``flexhrc cell``, the agents and ROS 2 all read these
files through here (:func:`flexhrc.scenario.load_scenario`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import PROFILES
from flexhrc.scenario.builtin.parallel import parallel_assembly
from flexhrc.scenario.builtin.table import ScenarioError, table_assembly
from flexhrc.scenario.model import Scenario

#: The keys each kind of older file may have.
KEYS: dict[str, frozenset[str]] = {
    "table_assembly": frozenset(
        {
            "scenario",
            "legs",
            "tabletop",
            "leg_length",
            "seed",
            "human",
            "unreachable_bolts",
            "leg_positions",
            "profile",
            "reachable_only_by",
        }
    ),
    "parallel_assembly": frozenset(
        {"scenario", "arms", "humans", "legs", "human_legs", "chain", "seed", "profile"}
    ),
}


def is_legacy(doc: Any) -> bool:
    """An older file: a mapping with ``scenario:`` and without ``flexhrc:``."""
    return isinstance(doc, Mapping) and "scenario" in doc and "flexhrc" not in doc


def read_legacy(
    path: str | Path, *, seed: int = 0, segments: str | Sequence[str] | None = None
) -> Scenario:
    """Read the older scenario file ``path`` (see :func:`from_legacy`)."""
    return from_legacy(path, read_document(path), seed=seed, segments=segments)


def read_document(path: str | Path) -> dict[str, Any]:
    """The mapping a scenario file holds, of either format (its ``lines`` attribute: the line
    of each top-level key); one clear error for a missing, binary or unreadable file."""
    from flexhrc.files import read_text
    from flexhrc.representation.formats.yaml_format import read_yaml

    path = Path(path)
    read_text(path)
    try:
        doc = read_yaml(path)
    except RecursionError:
        raise FormatError("nested too deeply to be a scenario file", path) from None
    if not isinstance(doc, dict):
        raise FormatError("a scenario file must be a mapping", path, 1)
    return doc


def from_legacy(
    path: str | Path,
    doc: Mapping[str, Any],
    *,
    seed: int = 0,
    segments: str | Sequence[str] | None = None,
) -> Scenario:
    """The :class:`Scenario` an older file ``doc`` (read from ``path``) describes.

    ``seed`` places the legs when the file gives no ``seed``. A ``table_assembly`` file is the
    legs fix alone, as it always was, unless ``segments`` selects others (``--segments all``:
    tabletop placement, legs fix and check on that table); its ``profile`` is the operator's.
    A ``parallel_assembly`` file has no segments.
    """
    path = Path(path)
    lines: dict[str, int] = getattr(doc, "lines", {})

    def line(key: str) -> int | None:
        return lines.get(key)

    def bad(key: str, message: str) -> FormatError:
        return FormatError(f"{key}: {message}", path, line(key))

    kind = doc.get("scenario")
    allowed = KEYS.get(kind) if isinstance(kind, str) else None
    if allowed is None:
        raise FormatError(
            f"unknown scenario {kind!r}; supported: {', '.join(KEYS)}",
            path,
            line("scenario") or 1,
        )
    for key in doc:
        if key not in allowed:
            raise FormatError(
                f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})", path, line(key)
            )

    def integer(key: str, default: int) -> int:
        v = doc.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int):
            raise bad(key, f"expected a whole number, got {v!r}")
        return v

    def boolean(key: str, default: bool) -> bool:
        v = doc.get(key, default)
        if not isinstance(v, bool):
            raise bad(key, f"expected true or false, got {v!r}")
        return v

    def name(key: str, default: str, choices: tuple[str, ...]) -> str:
        v = doc.get(key, default)
        if not isinstance(v, str) or v not in choices:
            raise bad(key, f"expected one of {', '.join(choices)}, got {v!r}")
        return v

    if kind == "parallel_assembly":
        if segments is not None and segments != "all":
            raise FlexhrcError(
                f"--segments: scenario parallel_assembly ({path}) has no segments "
                "(table_assembly has tabletop, legs, check)"
            )
        profile = name("profile", "passive", PROFILES)
        return _built(
            lambda: parallel_assembly(
                integer("arms", 6),
                integer("humans", 3),
                integer("legs", 12),
                seed=integer("seed", seed),
                human_legs=integer("human_legs", 0),
                chain=boolean("chain", False),
                profile=profile,
            ),
            path,
            line,
        )

    legs = integer("legs", 4)
    layout_seed = integer("seed", seed)
    human = boolean("human", True)
    leg_length = name("leg_length", "long", ("long", "short"))
    profile = name("profile", "passive", PROFILES)
    top = doc.get("tabletop", "large")
    if isinstance(top, list) and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in top
    ):
        top = "x".join(str(v) for v in top)
    if not isinstance(top, str):
        raise bad("tabletop", f"expected large, small, WIDTHxDEPTH or [width, depth], got {top!r}")
    bolts = doc.get("unreachable_bolts", [])
    if not isinstance(bolts, list) or not all(
        isinstance(b, int) and not isinstance(b, bool) for b in bolts
    ):
        raise bad("unreachable_bolts", f"expected a list of bolt numbers, got {bolts!r}")
    only = doc.get("reachable_only_by", {})
    if not isinstance(only, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in only.items()
    ):
        raise bad("reachable_only_by", f"expected a mapping leg: arm, got {only!r}")
    positions = None
    if "leg_positions" in doc:
        raw = doc["leg_positions"]
        if not isinstance(raw, list):
            raise bad("leg_positions", "expected a list of [x, y, z]")
        positions = []
        for i, p in enumerate(raw, 1):
            if (
                not isinstance(p, list)
                or len(p) != 3
                or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in p)
            ):
                raise bad("leg_positions", f"leg{i}: expected [x, y, z] numbers, got {p!r}")
            positions.append((float(p[0]), float(p[1]), float(p[2])))
    if segments is None:
        segments = "legs"  # what the older files meant
    if "profile" in doc and not human and profile != "passive":
        raise bad("profile", f"{profile} needs a human, but the file says human: false")
    return _built(
        lambda: table_assembly(
            legs,
            tabletop=top,
            leg_length=leg_length,
            seed=layout_seed,
            human=human,
            unreachable_bolts=tuple(bolts),
            reachable_only_by=dict(only),
            leg_positions=positions,
            segments=segments,
            profile=profile,
        ),
        path,
        line,
    )


def _built(
    build: Callable[[], Scenario], path: Path, line: Callable[[str], int | None]
) -> Scenario:
    """``build()``, its errors in the file's words (the key and its line)."""
    try:
        sc = build()
    except ScenarioError as exc:
        message = f"{exc.key}: {exc.detail}"
        if exc.fix is not None:
            message += f"; {exc.fix[0]}: {exc.fix[1]} holds them"
        raise FormatError(message, path, line(exc.key)) from None
    except FormatError:
        raise  # a value of the file, already located (chain: 'no')
    except FlexhrcError as exc:  # the bench's settings: the message names the setting
        key = str(exc).split(" ", 1)[0]
        raise FormatError(str(exc), path, line(key)) from None
    sc.path = path
    return sc
