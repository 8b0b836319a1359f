"""What-if from the store as one call: ``flexhrc replay STORE --fork-at K`` (issue 22, item 5).

:func:`what_if` loads the stored run's scenario (the shipped one its ``start`` names, or the
file or name given), forks the store (:func:`flexhrc.cell.fork.fork_store`) and draws both
timelines one above the other when asked.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from flexhrc.cell.components import ScenarioLike
from flexhrc.cell.fork import ForkReport, fork_store, profiles_text
from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.files import check_output

__all__ = ["ForkReport", "what_if"]


def what_if(
    source: str | Path,
    at: int,
    out: str | Path | None = None,
    *,
    human: str | None = None,
    on_failure: str | None = None,
    operators: str | Path | None = None,
    utility: str | Path | None = None,
    scenario: str | Path | None = None,
    force: bool = False,
    plot: str | Path | None = None,
    progress: Callable[[str], None] | None = None,
) -> ForkReport:
    """``flexhrc replay STORE --fork-at K``: :func:`~flexhrc.cell.fork.fork_store`, and with
    ``plot`` both timelines one above the other (.png, .svg or .pdf; checked before any work,
    written atomically). ``scenario``: the stored run's scenario file or name (None: the one
    its ``start`` names), loaded with the stored seed."""
    import flexhrc.planning.policies  # noqa: F401  (a stored lookahead run forks with it)
    from flexhrc.cell.replay import PLOT_SUFFIXES, need_matplotlib
    from flexhrc.files import atomic_output

    block = read_utility(utility) if utility is not None else None
    if plot is not None:
        inputs = [source] + ([out] if out is not None else [])
        check_output(plot, option="--plot", suffixes=PLOT_SUFFIXES, inputs=inputs)
        need_matplotlib()
    report = fork_store(
        source,
        at,
        out,
        human=human,
        on_failure=on_failure,
        operators=operators,
        utility=block,
        scenario=lambda name, seed: _load(source, scenario, name, seed),
        force=force,
        progress=progress,
    )
    if plot is not None:
        from flexhrc.taskmanager.timeline import plot_timelines

        pa, pb = report.profiles.get("original", {}), report.profiles.get("fork", {})
        with atomic_output(plot) as tmp:
            plot_timelines(
                [
                    (report.original_events, f"stored run {source} ({profiles_text(pa)})"),
                    (report.fork_events, f"what-if from event {at} ({profiles_text(pb)})"),
                ],
                tmp,
                marks=[(report.at_t, f"event {at}")],
            )
    return report


def read_utility(path: str | Path) -> dict[str, Any]:
    """A what-if's utility file (``--utility FILE``): a YAML file with the block the scenario
    key ``utility:`` takes, at its top or under ``utility:``. A bad file is one error naming
    the file and line (names in it are checked against the scenario when the fork starts)."""
    from flexhrc.representation.formats.yaml_format import _line, read_yaml
    from flexhrc.taskmanager.utility import parse_utility

    doc = read_yaml(path)
    block = doc.get("utility") if isinstance(doc, Mapping) and "utility" in doc else doc
    if not isinstance(block, Mapping):
        raise FlexhrcError(
            f"--utility {path}: give a utility block (success, time, preference, workload, ...)"
        )
    _, problems = parse_utility(block, None)
    if problems:
        message, key = problems[0]
        line = _line(block, key) if key is not None else _line(block)
        raise FlexhrcError(f"--utility {path}{f':{line}' if line else ''}: {message}")
    return dict(block)


def _load(source: str | Path, given: str | Path | None, name: str, seed: int) -> ScenarioLike:
    """The stored run's scenario: ``given`` (``--scenario``), else the shipped one named
    ``name`` in the store; a scenario from a file is not known by its name alone."""
    from flexhrc.scenario import load_scenario

    if given is not None:
        return load_scenario(given, seed=seed)
    try:
        return load_scenario(name, seed=seed)
    except UnknownNameError:
        raise FlexhrcError(
            f"{source}: the stored run's scenario {name!r} is not a shipped one: give its file "
            "with --scenario FILE"
        ) from None
