"""A saved cooperation, checked and summarised again (``flexhrc replay``).

:func:`replay` reads the JSON-lines event log a run streamed (``flexhrc run --log``) or a cell's
SQLite event store (``flexhrc cell --store``), checks every event against the catalogue
(:func:`flexhrc.taskmanager.replay.check_log`) and returns a :class:`ReplayReport`: the summary
``flexhrc replay --json`` prints, the text (the paper's Table I and the outcome line), and a
warning when the run was cut short. ``flexhrc replay`` prints that report and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError, OptionalDependencyError

#: The formats a timeline is drawn in (``--plot``).
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


@dataclass
class ReplayReport:
    """What :func:`replay` found: ``json`` (the summary of
    :func:`~flexhrc.taskmanager.replay.summarise_log`), ``text`` (Table I and the outcome
    line), ``warnings`` (a log cut short) and the checked ``events``."""

    json: dict[str, Any]
    text: str
    warnings: list[str] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)


def need_matplotlib(option: str = "--plot") -> None:
    """Refuse a plot before any work when the ``viz`` extra is missing."""
    import importlib.util

    if importlib.util.find_spec("matplotlib") is None:
        raise OptionalDependencyError(option, "viz", "matplotlib")


def read_log(path: str | Path) -> list[dict[str, Any]]:
    """The events of a JSON-lines log or a cell store, every one checked (one
    :class:`~flexhrc.errors.FormatError` naming the line of the first bad one)."""
    from flexhrc.cell.store import is_store, store_log
    from flexhrc.jsonl import read_jsonl_lines
    from flexhrc.taskmanager.replay import check_log

    path = Path(path)
    if is_store(path):  # a cell's SQLite event store (flexhrc cell --store FILE.db)
        return store_log(path)
    lines = read_jsonl_lines(path, required=("t", "type"))
    if not lines:
        raise FormatError("empty log", path)
    check_log(lines, path)
    return [ev for _, ev in lines]


def replay(log: str | Path, *, plot: str | Path | None = None) -> ReplayReport:
    """Check and summarise the saved cooperation ``log``; ``plot`` draws its timeline (.png,
    .svg or .pdf), checked before the log is read."""
    from flexhrc.files import check_output
    from flexhrc.taskmanager.replay import outcome_line, summarise_log, table_i

    if plot is not None:
        check_output(plot, option="--plot", suffixes=PLOT_SUFFIXES, inputs=[log])
        need_matplotlib()
    events = read_log(log)
    data = summarise_log(events)
    if plot is not None:
        from flexhrc.files import atomic_output
        from flexhrc.taskmanager.timeline import plot_timeline

        with atomic_output(plot) as tmp:
            plot_timeline(events, tmp, f"replay of {log}")
    warnings = [] if data["complete"] else [f"warning: {Path(log)}: {data['reason']}"]
    return ReplayReport(data, "\n".join([table_i(data), "", outcome_line(data)]), warnings, events)
