"""What ``flexhrc behave`` and ``flexhrc behave --robots N`` (:mod:`.behave_team`) share: finding
the task and its world, the trace lines and the end of the report, the ``--plot`` check.

Its own module so that the two commands import it and not each other.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, UnknownNameError

TASK_SUFFIXES = (".yaml", ".yml", ".txt")
PLOT_SUFFIXES = (".png", ".svg", ".pdf")


def is_file(name: str) -> bool:
    """Whether ``name`` is an existing file (an inline task is not, however long)."""
    try:
        return Path(name).is_file()
    except OSError:  # e.g. an inline task longer than a file name may be
        return False


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except OSError:
        return False


def resolve(target: str, layout: int | None, arms: int | None, seed: int) -> tuple[str, Any, Any]:
    """(label, task, world) for a scenario name, a task file or an inline prefix string."""
    label, task, world, _behaviors = resolve_document(target, layout, arms, seed)
    return label, task, world


def resolve_document(
    target: str, layout: int | None, arms: int | None, seed: int
) -> tuple[str, Any, Any, dict[str, Any]]:
    """(label, task, world, behaviour factories of typed leaves) — see :func:`resolve`."""
    from flexhrc.behavior.task import parse_prefix
    from flexhrc.behavior.taskfile import load_task_document
    from flexhrc.behavior.world import random_world
    from flexhrc.files import read_text
    from flexhrc.scenario.builtin.table_setting import SCENARIOS, load_scenario

    if target in SCENARIOS:
        sc = load_scenario(target, layout, arms or 1, seed)
        label = f"{sc.name}" + (f" (layout {sc.layout})" if sc.layout else "")
        return label, sc.task, sc.world, {}
    if layout is not None:
        raise FlexhrcError("--layout only applies to the table-setting scenario")
    if target.lstrip().startswith("("):
        task = parse_prefix(target, "<inline task>")
        return "inline task", task, random_world(task.behaviors, seed, arms or 1), {}
    path = Path(target)
    if path.suffix.lower() in TASK_SUFFIXES or _exists(path):
        text = read_text(path)
        stripped = "\n".join(line.split("#", 1)[0] for line in text.splitlines()).strip()
        behaviors: dict[str, Any] = {}
        if stripped.startswith("("):
            task, world = parse_prefix(text, str(path)), None
        else:
            doc = load_task_document(text, str(path), arms)
            task, world, behaviors = doc.task, doc.world, doc.behaviors
        if world is None:
            world = random_world(task.behaviors, seed, arms or 1)
        return str(path), task, world, behaviors
    raise UnknownNameError(
        f"unknown scenario {target!r} (known: {', '.join(SCENARIOS)}); "
        "or give a task file (.yaml/.txt) or an inline task such as '(THEN a (AND b c))'"
    )


def trace_line(ev: Any) -> str | None:
    """One line of the run's trace for a start, done, reset, move or choice; else None."""
    d = ev.data
    t = f"{ev.t:7.1f}s"
    if ev.kind == "start":
        return f"{t}  start  {ev.source:<10} on {d['arm']} ({d.get('duration', 0):.1f} s)"
    if ev.kind == "done":
        return f"{t}  done   {ev.source:<10} on {d['arm']}"
    if ev.kind == "reset":
        return (
            f"{t}  RESET  {ev.source:<10} on {d['arm']}: {d.get('reason', '')} "
            f"{d.get('moved', 0):.2f} m, mutex released"
        )
    if ev.kind == "move":
        to = [round(x, 3) for x in d["to"]]
        return f"{t}  move   {d['object']:<10} moved by the experimenter to {to}"
    if ev.kind == "choose":
        return f"{t}  choose {ev.source:<10} activates {d['child']}"
    return None


def live_line(ev: Any, behaviors: set[str]) -> str | None:
    """A trace line, or a state change of a behaviour (``--realtime``)."""
    line = trace_line(ev)
    if (
        line is None
        and ev.kind == "state"
        and ev.source in behaviors
        and ev.data.get("to") in ("active", "inactive")
        and not ev.data.get("reset")
    ):
        line = f"{ev.t:7.1f}s  state  {ev.source:<10} {ev.data.get('frm')} -> {ev.data['to']}"
    return line


def summary_lines(result: Any, violations: list[str], plot: str | None = None) -> list[str]:
    """The end of a run's report: the same for a live run and for ``behave replay``."""
    lines = [
        f"outcome: {result.outcome} after {result.time:.1f} s ({result.ticks} ticks), "
        f"resets: {result.resets}",
        f"order: {', '.join(result.order)}",
    ]
    if violations:
        lines.append("constraint violations:")
        lines += [f"  - {v}" for v in violations]
    else:
        lines.append(
            "constraints: respected (THEN order, every AND child, one alternative per OR, "
            "one behaviour per arm)"
        )
    if plot:
        lines.append(f"gantt chart: {plot}")
    return lines


def check_plot(path: str | None, inputs: tuple[str, ...] = ()) -> None:
    """Refuse a bad ``--plot`` path, or a missing plotting extra, before the run starts."""
    if path is None:
        return
    from flexhrc.behavior.plot import _pyplot
    from flexhrc.files import check_output

    check_output(path, option="--plot", suffixes=PLOT_SUFFIXES, inputs=inputs)
    _pyplot()  # a missing extra is reported before the run, not after it
