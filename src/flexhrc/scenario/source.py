"""What every command that takes a scenario accepts — a name or a file — as one
:class:`~flexhrc.scenario.Scenario`.

:func:`load_scenario` reads every form a task comes in, for every front end alike (``run``,
``demo``, ``cell``, ``agent``, ``ros2``, ``panel``), so that one name means one task everywhere:

* ``table_assembly`` (alias ``table``): the FlexHRC+ table assembly in three segments — the
  scenario file shipped with :mod:`flexhrc.scenario`; ``segments="legs"`` (``--segments legs``)
  is the legs fix alone (built by :func:`flexhrc.scenario.builtin.table_assembly`);
* the other names shipped with :mod:`flexhrc.scenario` (``ball_in_box``, ``kitchen_drawer``);
* ``parallel_assembly``: independent sockets for many arms and operators (benchmarks);
* a scenario file (``flexhrc: 1``), or an older file (``scenario: table_assembly`` with
  ``legs``, ``unreachable_bolts`` ...; ``scenario: parallel_assembly`` with ``arms``,
  ``humans``, ``legs``), translated by :func:`flexhrc.scenario.legacy.from_legacy`.

Every process of a cell loads the same one and so starts from the same knowledge base.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.scenario.builtin.parallel import parallel_assembly
from flexhrc.scenario.builtin.table import SEGMENTS, ScenarioError, table_assembly
from flexhrc.scenario.legacy import is_legacy, read_legacy
from flexhrc.scenario.loader import SHIPPED, load
from flexhrc.scenario.model import Scenario

#: Names that are not shipped files: the table's short name, the bench of many arms.
NAMES = ("table_assembly", "table", "parallel_assembly")

#: Which tasks come in segments, and which these are.
SEGMENTED = {"table_assembly": SEGMENTS}


def load_scenario(
    spec: str | Path, *, seed: int = 0, segments: str | Sequence[str] | None = None
) -> Scenario:
    """The scenario named ``spec``, or read from the file ``spec``.

    ``seed`` places the objects of a generated task (the legs of an older table file without
    ``seed``, the bench of ``parallel_assembly``). ``segments`` selects parts of a task that
    comes in segments (``"legs"``, ``"tabletop,legs"``, ``"all"``; None: as the task is);
    a task without segments, or an unknown segment, is one :class:`FlexhrcError` naming the
    segments there are.
    """
    text = str(spec)
    if text in ("table_assembly", "table") or _is_shipped_table(text):
        if segments is None or segments == "all":
            return load("table_assembly")  # the shipped file, as `flexhrc run table_assembly`
        return _table(segments)
    if text == "parallel_assembly":
        sc = parallel_assembly(seed=seed)
        return select(sc, segments)
    path = Path(text)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        if text not in SHIPPED:
            names = ", ".join(sorted({*NAMES, *SHIPPED}))
            raise UnknownNameError(
                f"unknown scenario {text!r}: give one of {names} or a scenario file"
            )
        return select(load(text), segments)
    if _is_legacy_file(path):
        return read_legacy(path, seed=seed, segments=segments)
    return select(load(path), segments)


def select(scenario: Scenario, segments: str | Sequence[str] | None) -> Scenario:
    """``scenario`` as it is when ``segments`` is None or ``all``, or when it holds exactly
    those segments; else one :class:`FlexhrcError`: a task without segments says which tasks
    have them (a task that comes in segments is cut where it is built: :func:`load_scenario`
    with its name or its older file, :func:`~flexhrc.scenario.builtin.table_assembly`)."""
    if segments is None or segments == "all":
        return scenario
    wanted = tuple(
        s.strip() for s in (segments.split(",") if isinstance(segments, str) else segments)
    )
    if scenario.segments and wanted == scenario.segments:
        return scenario
    if not scenario.segments:
        raise FlexhrcError(
            f"--segments {','.join(wanted)}: scenario {scenario.name!r} has no segments ("
            + "; ".join(f"{n} has {', '.join(s)}" for n, s in SEGMENTED.items())
            + ")"
        )
    raise FlexhrcError(
        f"--segments {','.join(wanted)}: scenario {scenario.name!r} holds "
        f"{', '.join(scenario.segments)}"
    )


def _table(segments: str | Sequence[str]) -> Scenario:
    try:
        return table_assembly(segments=segments)
    except ScenarioError as exc:
        raise FlexhrcError(f"--segments {exc.detail}") from None


def _is_shipped_table(text: str) -> bool:
    """The shipped ``table_assembly`` file given by its path: the same task as the name."""
    from flexhrc.scenario.loader import shipped_path

    p = Path(text)
    return p.exists() and p.resolve() == shipped_path("table_assembly").resolve()


def _is_legacy_file(path: Path) -> bool:
    """An older file (``scenario:`` without ``flexhrc:``) rather than a scenario file."""
    from flexhrc.files import read_text
    from flexhrc.representation.formats.yaml_format import read_yaml

    text = read_text(path)  # one clear error for a missing, binary or unreadable file
    if any(line.strip().startswith("flexhrc:") for line in text.splitlines()):
        return False
    try:
        return is_legacy(read_yaml(path))
    except (FlexhrcError, RecursionError):
        return False  # the scenario loader reports what is wrong with it
