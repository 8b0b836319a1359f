"""What ``flexhrc cell SCENARIO`` and ``flexhrc agent ... SCENARIO`` accept: a name or a file.

:func:`load_scenario` reads every form a task comes in, for every front end alike:

* ``table_assembly`` (alias ``table``): the FlexHRC+ table assembly — the scenario file shipped
  with :mod:`flexhrc.scenario` (as ``flexhrc run table_assembly``), else the legs fix of
  :class:`~flexhrc.scenarios.table_assembly.TableScenario`; the other names shipped with
  :mod:`flexhrc.scenario` (``ball_in_box``, ``kitchen_drawer`` ...) too;
* ``parallel_assembly``: independent legs for many arms and operators (benchmarks);
* a YAML file with the keys of ``flexhrc run`` (``scenario: table_assembly``, ``legs``,
  ``unreachable_bolts`` ...) or ``scenario: parallel_assembly`` with ``arms``, ``humans``,
  ``legs``.

The result is a :class:`CellScenario`: ``graph()``, ``domain()``, ``knowledge()``,
``make_simulator(choice)`` and a ``name``; every process of a cell loads the same one and so
starts from the same knowledge base. When :mod:`flexhrc.scenario` offers ``load`` (scenario files
``flexhrc: 1`` and the scenarios shipped with it), names and files it knows go through it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.scenario.loader import SHIPPED, load

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


class CellScenario:
    """What every process of a cell needs of a scenario, whoever defined it: fresh ``graph()``,
    ``domain()`` and ``knowledge()``, and ``make_simulator(choice)`` (the branch simulator of
    the manager, the simulated world of an agent; ``choice`` is ``auto``, ``analytic`` or
    ``kinematic``)."""

    def __init__(self, name: str, source: Any, *, simulator: str | None = None) -> None:
        self.name = name
        self.source = source
        self.forced = simulator  # e.g. "analytic" for many arms (the kinematic model has two)

    def graph(self) -> Any:
        g = self.source.graph
        return g() if callable(g) else g

    def domain(self) -> Any:
        d = self.source.domain
        return d() if callable(d) else d

    def knowledge(self) -> Any:
        make = getattr(self.source, "world", None) or self.source.knowledge
        return make()

    def make_simulator(self, choice: str = "auto") -> Any:
        from flexhrc.scenarios.simulators import choose_simulator

        if self.forced is not None:
            choice = self.forced
        own = getattr(self.source, "make_simulator", None)
        if own is not None:  # a flexhrc.scenario file: its simulator, unless told otherwise
            return own(None if choice == "auto" else choice)
        return choose_simulator(choice)[1]


def load_scenario(spec: str, *, seed: int = 0) -> CellScenario:
    """The scenario named ``spec``, or read from the YAML file ``spec``."""
    from flexhrc.scenarios.parallel_assembly import ParallelScenario

    text = str(spec)
    if text in ("table_assembly", "table"):
        # the shipped scenario file, as `flexhrc run table_assembly`
        return CellScenario("table_assembly", load("table_assembly"))
    if text == "parallel_assembly":
        return CellScenario("parallel_assembly", ParallelScenario(seed=seed), simulator="analytic")
    path = Path(text)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        if text not in SHIPPED:
            names = ", ".join(sorted({*NAMES, *SHIPPED}))
            raise UnknownNameError(
                f"unknown scenario {text!r}: give one of {names} or a scenario file"
            )
        sc = load(text)
        return CellScenario(sc.name, sc)
    if _is_scenario_file(path):
        sc = load(path)
        return CellScenario(sc.name, sc)
    return _from_file(path, seed)


def _is_scenario_file(path: Path) -> bool:
    """A ``flexhrc: 1`` scenario file (rather than the keys of ``flexhrc run``)."""
    from flexhrc.files import read_text

    return any(line.strip().startswith("flexhrc:") for line in read_text(path).splitlines())


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
            par = ParallelScenario(
                arms=int(doc.get("arms", 6)),
                humans=int(doc.get("humans", 3)),
                legs=int(doc.get("legs", 12)),
                human_legs=int(doc.get("human_legs", 0)),
                chain=bool(doc.get("chain", False)),
                seed=int(doc.get("seed", seed)),
            )
            scenario = CellScenario("parallel_assembly", par, simulator="analytic")
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
            scenario = CellScenario("table_assembly", scenario)
    except (TypeError, ValueError) as exc:
        raise FormatError(f"bad value: {exc}", path) from None
    return scenario


def _xyz(p: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in p)
    return (x, y, z)
