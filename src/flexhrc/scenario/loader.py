"""Finding and loading scenario files: shipped names, paths, validation."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.scenario.format import Fault, check, parse
from flexhrc.scenario.model import Scenario

#: The scenarios shipped with flexhrc (package data ``scenario/builtin/data/NAME/NAME.yaml``).
SHIPPED = ("table_assembly", "ball_in_box", "kitchen_drawer", "table_two_arms")


def shipped_path(name: str) -> Path:
    """The file of a shipped scenario."""
    if name not in SHIPPED:
        raise UnknownNameError(
            f"unknown scenario {name!r}; shipped: {', '.join(SHIPPED)} (or give a .yaml file)"
        )
    ref = resources.files("flexhrc.scenario.builtin").joinpath(f"data/{name}/{name}.yaml")
    return Path(str(ref))


def resolve(path_or_name: str | Path) -> Path:
    """A scenario file from a path or a shipped name."""
    p = Path(path_or_name)
    if p.suffix.lower() in (".yaml", ".yml") or p.exists() or "/" in str(path_or_name):
        return p
    return shipped_path(str(path_or_name))


def load(path_or_name: str | Path) -> Scenario:
    """Load a scenario file (or a shipped scenario by name); raises :class:`ScenarioError`
    (a :class:`~flexhrc.errors.FormatError` naming file and line) when it has errors."""
    return parse(resolve(path_or_name))


def validate(path_or_name: str | Path) -> list[Fault]:
    """Every fault of a scenario file (errors and warnings), each with its file and line."""
    try:
        return check(resolve(path_or_name))[1]
    except FlexhrcError as exc:
        return [Fault(str(path_or_name), None, str(exc))]


def validation(path_or_name: str | Path) -> dict[str, Any]:
    """What ``flexhrc scenario validate --json`` prints: the file, whether it is valid (no
    error), every fault (``source``, ``line``, ``severity``, ``message``) and the summary line
    of a valid scenario. Unlike :func:`validate`, an unknown name raises."""
    path = resolve(path_or_name)
    scenario, faults = check(path)
    return {
        "file": str(path),
        "valid": scenario is not None and all(f.severity != "error" for f in faults),
        "faults": [
            {"source": f.source, "line": f.line, "severity": f.severity, "message": f.message}
            for f in faults
        ],
        "summary": scenario.summary_line() if scenario is not None else None,
    }


def describe_shipped() -> list[tuple[str, str]]:
    """(name, one-line description) of every shipped scenario."""
    out = []
    for name in SHIPPED:
        sc = load(name)
        out.append((name, sc.description.strip().splitlines()[0] if sc.description else ""))
    return out
