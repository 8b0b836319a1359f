"""``flexhrc behave`` as functions: a config in, a report out.

* :func:`run_behave` — run a :class:`~flexhrc.behavior.command.BehaveConfig`: the task on one
  robot's network (or only its network printed, ``render``), or shared by a team of robots
  (:mod:`flexhrc.behavior.team`);
* :class:`ReplayConfig` / :func:`replay` — the report of a run read back from its ``--log``;
* :class:`RenderConfig` / :func:`render` — the network as DOT or an image, coloured by the node
  states of a logged run at a time;
* :class:`CompileConfig` / :func:`compile_to_file` — the task written as a flexhrc AND/OR graph.

Each returns a :class:`~flexhrc.behavior.command.BehaveReport` that holds what the command prints
(its ``--json`` document, its text, its exit code); ``flexhrc behave`` translates its arguments
into a config, calls the function and prints the report, nothing more. Bad input is one
:class:`~flexhrc.errors.FlexhrcError` naming the option, raised before anything runs; output
paths are checked before the run too.

>>> from flexhrc.behavior.behave import BehaveConfig, run_behave
>>> report = run_behave(BehaveConfig("(THEN a (AND b c))", seed=1))
>>> report.data["outcome"], report.data["order"][0], report.exit_code
('done', 'a', 0)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.behavior.command import (
    BehaveConfig,
    BehaveReport,
    LineSink,
    LoadedTask,
    check_plot,
    check_task,
    import_types,
    input_files,
    live_trace,
    load_target,
    summary_lines,
    tick_loop,
    trace_line,
)
from flexhrc.behavior.logfile import end_record, stream_log
from flexhrc.behavior.network import BehaviorNetwork
from flexhrc.errors import FlexhrcError

RENDER_SUFFIXES = (".dot", ".gv", ".svg", ".png", ".pdf")
GRAPH_SUFFIXES = (".yaml", ".yml")


def run_behave(config: BehaveConfig, on_line: LineSink = lambda line: None) -> BehaveReport:
    """Run ``config`` (``flexhrc behave TASK ...``); ``on_line`` gets the live lines of a
    ``realtime`` run and the progress of a team (by default nothing is printed). Ctrl-C (and
    SIGTERM, in the main thread) ends the run with :class:`KeyboardInterrupt` after the log's
    last line is written."""
    import_types(config.types)
    if config.team:
        from flexhrc.behavior.team import run_team_config

        return run_team_config(config, on_line)
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.render import to_ascii, to_dot
    from flexhrc.behavior.validate import check_run
    from flexhrc.files import check_output

    inputs = input_files(config.target)
    if config.log:
        check_output(config.log, option="--log", inputs=inputs)
    check_plot(config.plot, inputs)
    if config.log and config.plot and Path(config.log).resolve() == Path(config.plot).resolve():
        raise FlexhrcError("--log and --plot name the same file")
    loaded = load_target(config.target, config.arms, config.seed)
    label, task, world = loaded.label, loaded.task, loaded.world
    if config.render:
        rendered = to_ascii(task) if config.render == "ascii" else to_dot(task)
        return BehaveReport({"task": task.to_prefix(), "render": rendered}, rendered)
    net = BehaviorNetwork(task, world, NetworkParams(seed=config.seed), behaviors=loaded.behaviors)
    writer = stream_log(net, config.log, label, config.seed) if config.log else None
    realtime = config.realtime
    try:
        if realtime is not None:
            on_line(f"{label}: {task.to_prefix()} (real time x{realtime:g})")
            live_trace(net, on_line)
        tick_loop(net, config.max_ticks, realtime)
        result = net.result()
        violations = check_run(task, result.runs)
        if writer is not None:
            writer.write(end_record(result, violations))
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the log says so in its last line
        if writer is not None:
            writer.write(end_record(net.result(), [], outcome="interrupted"))
        raise
    finally:
        if writer is not None:
            writer.close()
    plot = _gantt(result, config.plot, label)
    data = result.to_dict()
    data.update(
        target=label,
        task=task.to_prefix(),
        seed=config.seed,
        violations=violations,
        plot=plot,
        log=config.log,
    )

    def text() -> str:
        lines = [f"{label}: {task.to_prefix()}", to_ascii(task), ""]
        lines.append(f"world: {len(world.objects)} objects; arms: {', '.join(world.arm_names)}")
        if realtime is None:
            lines.append("trace:")
            lines += [s for s in (trace_line(ev) for ev in result.log) if s]
        lines.append("")
        lines += summary_lines(data)
        if config.log:
            lines.append(f"event log: {config.log}")
        return "\n".join(lines)

    return BehaveReport(data, text)


def _gantt(result: Any, path: str | None, label: str) -> str | None:
    """The ``--plot`` Gantt chart of ``result``, titled with its order; its path or None."""
    if not path:
        return None
    from flexhrc.behavior.plot import gantt

    return str(gantt(result, path, title=f"{label}: {', '.join(result.order)}"))


# ----------------------------------------------------------------------------- replay


@dataclass(frozen=True)
class ReplayConfig:
    """``flexhrc behave replay LOG [--plot FILE]``: the report of the run a ``--log`` holds."""

    log: str
    plot: str | None = None

    def __post_init__(self) -> None:
        check_task(self.log)


def replay(config: ReplayConfig) -> BehaveReport:
    """The live run's report (its summary, order, runs, violations) from its log alone; a log
    without its end line (a killed run) says it was cut short. A robot's log of a team counts
    what the other robots completed."""
    from flexhrc.behavior.logfile import CUT_SHORT, read_log
    from flexhrc.behavior.network import Run
    from flexhrc.behavior.task import parse_prefix
    from flexhrc.behavior.validate import check_run

    check_plot(config.plot, (config.log,))
    blog = read_log(config.log)
    task = parse_prefix(str(blog.header["task"]), f"{config.log}:1")
    result = blog.result()
    elsewhere = [
        Run(ev.source, f"{ev.data.get('by')}/elsewhere", ev.t, ev.t, "done")
        for ev in blog.events
        if ev.kind == "done_elsewhere"
    ]
    violations = check_run(task, sorted([*result.runs, *elsewhere], key=lambda r: r.start))
    label = blog.header.get("target")
    plot = _gantt(result, config.plot, str(label or "replay"))
    data = result.to_dict()
    data.update(
        target=label,
        task=task.to_prefix(),
        seed=blog.header.get("seed"),
        violations=violations,
        plot=plot,
        events=len(blog.events),
        cut_short=blog.end is None,
        robot=blog.header.get("robot"),
        done_elsewhere=[{"behavior": r.behavior, "by": r.arm.split("/")[0]} for r in elsewhere],
    )

    def text() -> str:
        lines = [f"{blog.header.get('target', 'replay')}: {task.to_prefix()}"]
        lines.append(f"log: {config.log}, {len(blog.events)} events")
        if blog.end is None:
            lines.append(
                f"warning: the run was {CUT_SHORT}: the log ends after {result.time:.1f} s "
                "without its end line (killed?)"
            )
        if elsewhere:
            others = ", ".join(f"{r.behavior} ({r.arm.split('/')[0]})" for r in elsewhere)
            lines.append(f"done by other robots: {others}")
        lines.append("")
        lines += summary_lines(data)
        return "\n".join(lines)

    return BehaveReport(data, text)


# ----------------------------------------------------------------------------- render, compile


@dataclass(frozen=True)
class RenderConfig:
    """``flexhrc behave render TASK -o OUT [--log LOG --at SECONDS]``: ``output`` is ``.dot``/
    ``.gv`` (DOT text) or ``.svg``/``.png``/``.pdf`` (Graphviz); with ``log`` the nodes are
    coloured by their states at ``at`` seconds of that run (default: its end)."""

    target: str | LoadedTask
    output: str
    log: str | None = None
    at: float | None = None
    arms: int | None = None
    seed: int = 0
    types: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        check_task(self.target, self.seed)
        if self.at is not None and not (math.isfinite(self.at) and self.at >= 0):
            raise FlexhrcError(f"--at must be a finite number of seconds >= 0, got {self.at}")
        if self.at is not None and self.log is None:
            raise FlexhrcError("--at needs --log (the run whose states to show)")


def _load_for(
    config: RenderConfig | CompileConfig, suffixes: tuple[str, ...], *inputs: str | None
) -> LoadedTask:
    """Import the types, check the ``-o`` output (it may not overwrite an input), load the task."""
    from flexhrc.files import check_output

    import_types(config.types)
    files = input_files(config.target, *inputs)
    check_output(config.output, option="-o", suffixes=suffixes, inputs=files)
    return load_target(config.target, config.arms, config.seed)


def render(config: RenderConfig) -> BehaveReport:
    """Draw the task's network into ``config.output`` (written atomically)."""
    from flexhrc.behavior.render import to_dot
    from flexhrc.files import atomic_output, atomic_write_text

    loaded = _load_for(config, RENDER_SUFFIXES, config.log)
    task, label = loaded.task, loaded.label
    snapshots = None
    at = None
    if config.log:
        from flexhrc.behavior.logfile import read_log

        blog = read_log(config.log)
        if str(blog.header["task"]) != task.to_prefix():
            raise FlexhrcError(
                f"{config.log}: the log is of another task ({blog.header['task']}), "
                f"not {task.to_prefix()}"
            )
        at = blog.time if config.at is None else config.at
        states = blog.states_at(at)
        snapshots = {n.name: {"state": states.get(n.name, "inactive")} for n in task.walk()}
    caption = label if at is None else f"{label} at {at:.1f} s"
    dot = to_dot(task, snapshots, legend=snapshots is not None, caption=caption)
    out = Path(config.output)
    if out.suffix.lower() in (".dot", ".gv"):
        atomic_write_text(out, dot)
    else:
        from flexhrc.representation.formats.dot import render as render_dot

        with atomic_output(out) as tmp:
            render_dot(dot, tmp)
    return BehaveReport({"output": str(out), "task": task.to_prefix(), "at": at}, f"wrote {out}")


@dataclass(frozen=True)
class CompileConfig:
    """``flexhrc behave compile TASK -o graph.yaml``: the task as a flexhrc AND/OR graph."""

    target: str | LoadedTask
    output: str
    arms: int | None = None
    seed: int = 0
    types: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        check_task(self.target, self.seed)


def compile_to_file(config: CompileConfig) -> BehaveReport:
    """Write :func:`~flexhrc.behavior.compile.compile_task` of the task to ``config.output``."""
    from flexhrc.behavior.compile import compile_task
    from flexhrc.files import atomic_write_text
    from flexhrc.representation.formats.yaml_format import dump_yaml

    task = _load_for(config, GRAPH_SUFFIXES).task
    hierarchy = compile_task(task)
    atomic_write_text(config.output, dump_yaml(hierarchy))
    st = hierarchy.stats()
    data = {
        "output": config.output,
        "task": task.to_prefix(),
        "behaviors": len(task.behaviors),
        "graphs": st["graphs"],
        "nodes": st["nodes"],
        "hyperarcs": st["hyperarcs"],
    }
    text = (
        f"wrote {config.output}: {st['graphs']} graph(s), {st['nodes']} nodes, "
        f"{st['hyperarcs']} hyper-arcs for {len(task.behaviors)} behaviours"
    )
    return BehaveReport(data, text)


__all__ = [
    "BehaveConfig",
    "BehaveReport",
    "CompileConfig",
    "LoadedTask",
    "RenderConfig",
    "ReplayConfig",
    "compile_to_file",
    "render",
    "replay",
    "run_behave",
]
