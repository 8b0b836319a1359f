"""What ``flexhrc cell SCENARIO`` and ``flexhrc agent ... SCENARIO`` accept: a name or a file.

One small function, :func:`load_scenario`, so the cell can later delegate to the loader of
:mod:`flexhrc.scenario` (scenario files, issue 10) without touching anything else. Today:

* ``table_assembly`` (alias ``table``): the FlexHRC+ table assembly, 4 legs, seed 0;
* ``parallel_assembly``: independent legs for many arms and operators (benchmarks);
* a YAML file with the keys of ``flexhrc run`` (``scenario: table_assembly``, ``legs``,
  ``unreachable_bolts`` ...) or ``scenario: parallel_assembly`` with ``arms``, ``humans``,
  ``legs``.

A scenario object has ``graph()``, ``domain()``, ``knowledge()`` and a ``name``; every process
of a cell loads the same one and so starts from the same knowledge base.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError, UnknownNameError

NAMES = ("table_assembly", "table", "parallel_assembly")

_TABLE_KEYS = {
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
_PARALLEL_KEYS = {"scenario", "arms", "humans", "legs", "human_legs", "chain", "seed"}


def load_scenario(spec: str, *, seed: int = 0) -> Any:
    """The scenario named ``spec``, or read from the YAML file ``spec``."""
    from flexhrc.scenarios.parallel_assembly import ParallelScenario
    from flexhrc.scenarios.table_assembly import TableScenario

    text = str(spec)
    if text in ("table_assembly", "table"):
        scenario: Any = TableScenario(seed=seed)
        scenario.name = "table_assembly"
        return scenario
    if text == "parallel_assembly":
        return ParallelScenario(seed=seed)
    path = Path(text)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        raise UnknownNameError(
            f"unknown scenario {text!r}: give one of {', '.join(NAMES)} or a scenario file"
        )
    return _from_file(path, seed)


def _from_file(path: Path, seed: int) -> Any:
    from flexhrc.files import read_text
    from flexhrc.representation.formats.yaml_format import read_yaml
    from flexhrc.scenarios.parallel_assembly import ParallelScenario
    from flexhrc.scenarios.table_assembly import TableScenario

    read_text(path)  # one clear error for a missing, binary or unreadable file
    doc = read_yaml(path)
    if not isinstance(doc, dict):
        raise FormatError("a scenario file must be a mapping", path, 1)
    lines = getattr(doc, "lines", {})
    kind = doc.get("scenario")
    allowed = {"table_assembly": _TABLE_KEYS, "parallel_assembly": _PARALLEL_KEYS}.get(str(kind))
    if allowed is None:
        raise FormatError(
            f"unknown scenario {kind!r}; supported: table_assembly, parallel_assembly",
            path,
            lines.get("scenario", 1),
        )
    for key in doc:
        if key not in allowed:
            raise FormatError(
                f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})",
                path,
                lines.get(key),
            )
    try:
        scenario: Any
        if kind == "parallel_assembly":
            scenario = ParallelScenario(
                arms=int(doc.get("arms", 6)),
                humans=int(doc.get("humans", 3)),
                legs=int(doc.get("legs", 12)),
                human_legs=int(doc.get("human_legs", 0)),
                chain=bool(doc.get("chain", False)),
                seed=int(doc.get("seed", seed)),
            )
        else:
            scenario = TableScenario(
                legs=int(doc.get("legs", 4)),
                tabletop=str(doc.get("tabletop", "large")),
                leg_length=str(doc.get("leg_length", "long")),
                seed=int(doc.get("seed", seed)),
                human=bool(doc.get("human", True)),
                unreachable_bolts=tuple(int(b) for b in doc.get("unreachable_bolts", [])),
                reachable_only_by=dict(doc.get("reachable_only_by", {})),
                leg_positions=[_xyz(p) for p in doc["leg_positions"]]
                if "leg_positions" in doc
                else None,
            )
            scenario.name = "table_assembly"
    except (TypeError, ValueError) as exc:
        raise FormatError(f"bad value: {exc}", path) from None
    return scenario


def _xyz(p: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in p)
    return (x, y, z)
