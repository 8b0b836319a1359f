"""flexhrc behave: run the activation-spreading behaviour network of paper 002 (Fraser et al.).

TASK_OR_SCENARIO is a scenario name (table-setting, table-setting-robustness, abstract), a task
file (.yaml/.yml with an optional world, or .txt with the prefix form), or an inline prefix
string such as "(THEN a (AND b c))". A task without a world runs in a generated default world:
one object per behaviour at a random position on the table, drawn with --seed.

Actions on a task or a log (the first argument names the action):

  flexhrc behave replay LOG [--plot gantt.png]       summary (and Gantt chart) from a --log
  flexhrc behave render TASK -o OUT.svg [--log LOG --at SECONDS]
                                                     the network, coloured by node state
  flexhrc behave compile TASK -o graph.yaml          the task as a flexhrc AND/OR graph
"""

from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import time
from pathlib import Path
from typing import Any

from flexhrc.cli.behave_common import (
    check_plot,
    is_file,
    live_line,
    resolve,
    resolve_document,
    summary_lines,
    trace_line,
)
from flexhrc.cli.common import add_json_flag, emit, log
from flexhrc.errors import FlexhrcError

RENDER_SUFFIXES = (".dot", ".gv", ".svg", ".png", ".pdf")
GRAPH_SUFFIXES = (".yaml", ".yml")
ACTIONS = ("replay", "render", "compile")
MAX_SEED = 2**63 - 1
MAX_TICKS = 10**9


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = subparsers.add_parser(
        "behave",
        help="run a THEN/AND/OR behaviour network (activation spreading, arm mutex, "
        "validity checks); replay, render or compile one",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "target",
        metavar="TASK_OR_SCENARIO",
        help="scenario name, task file, or inline '(THEN ...)'; or an action: "
        + ", ".join(ACTIONS),
    )
    p.add_argument(
        "operand",
        nargs="?",
        metavar="FILE_OR_TASK",
        help="for replay: the log file; for render and compile: the task (as above)",
    )
    p.add_argument(
        "--layout", type=int, metavar="K", help="object layout 1..3 of the table-setting scenario"
    )
    p.add_argument(
        "--arms",
        type=int,
        choices=(1, 2),
        help="number of arms, each with its own mutex (default 1)",
    )
    p.add_argument(
        "--seed", type=int, default=0, help="seed for OR ties and generated worlds (default 0)"
    )
    add_json_flag(p)
    p.add_argument(
        "--plot", metavar="FILE", help="write a Gantt chart of behaviour states (PNG/SVG/PDF)"
    )
    p.add_argument(
        "--render", choices=("ascii", "dot"), help="print the network (ascii tree or DOT) and exit"
    )
    p.add_argument(
        "--log",
        metavar="FILE",
        help="stream the event log as JSON lines while running (for render: read states from it)",
    )
    p.add_argument(
        "--max-ticks",
        type=int,
        metavar="N",
        help="stop after N ticks (default: 50000 + 1000 per behaviour)",
    )
    p.add_argument(
        "--realtime",
        type=float,
        nargs="?",
        const=1.0,
        metavar="SPEED",
        help="run at SPEED x wall-clock time (default 1) and print state changes as they happen",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="output file of render (.dot/.svg/.png/.pdf) and compile (.yaml)",
    )
    p.add_argument(
        "--at",
        type=float,
        metavar="SECONDS",
        help="render: node states at this time of the --log run (default: its end)",
    )
    p.add_argument(
        "--types",
        action="append",
        metavar="MODULE",
        help="import a Python module (a name, or a path to a .py file) that registers behaviour "
        "types the task file names (register_behavior_type); repeatable",
    )
    p.add_argument(
        "--robots",
        type=int,
        metavar="N",
        help="N robots (1..4, one arm each) share the task: each runs its own copy of the "
        "network, claims and progress go between them (default 1)",
    )
    p.add_argument(
        "--transport",
        choices=("inprocess", "zenoh"),
        help="with --robots: all robots in this process on the in-process peer bus (default), "
        "or one process per robot over Zenoh on 127.0.0.1",
    )
    p.add_argument(
        "--robot",
        metavar="NAME",
        help="internal, with --transport zenoh: run as this one robot of the team (robot1 ...)",
    )
    p.add_argument(
        "--peer-port",
        type=int,
        metavar="PORT",
        help="internal, with --robot: the loopback TCP port robot1 listens on for its peers",
    )
    p.set_defaults(func=run)


# ----------------------------------------------------------------------------- checks


def _check_args(args: argparse.Namespace) -> None:
    """Numbers and option combinations, before anything is loaded or run."""
    if args.target == "" or (args.target in ACTIONS and args.operand == ""):
        raise FlexhrcError(
            "TASK_OR_SCENARIO is empty: give a scenario name (table-setting, "
            "table-setting-robustness, abstract), a task file or an inline task such as "
            "'(THEN a (AND b c))'"
        )
    if not 0 <= args.seed <= MAX_SEED:
        raise FlexhrcError(f"--seed must be an integer in 0..2**63-1, got {args.seed}")
    if args.max_ticks is not None and not 1 <= args.max_ticks <= MAX_TICKS:
        raise FlexhrcError(f"--max-ticks must be in 1..{MAX_TICKS}, got {args.max_ticks}")
    if args.realtime is not None and not (math.isfinite(args.realtime) and args.realtime > 0):
        raise FlexhrcError(f"--realtime SPEED must be a finite number > 0, got {args.realtime}")
    if args.at is not None and not (math.isfinite(args.at) and args.at >= 0):
        raise FlexhrcError(f"--at must be a finite number of seconds >= 0, got {args.at}")
    action = args.target if args.target in ACTIONS else None
    if action is None and args.operand is not None:
        raise FlexhrcError(
            f"unexpected argument {args.operand!r}: one task or scenario at a time "
            f"(or an action: {', '.join(ACTIONS)})"
        )
    if action is not None and args.operand is None:
        what = "LOG" if action == "replay" else "TASK"
        raise FlexhrcError(f"behave {action} needs a {what}")
    if args.robots is not None and not 1 <= args.robots <= 4:
        raise FlexhrcError(f"--robots must be in 1..4, got {args.robots}")
    team = args.robots is not None and args.robots > 1
    if args.transport is not None and not team:
        raise FlexhrcError("--transport needs --robots 2 (or more)")
    if (args.robot is not None or args.peer_port is not None) and args.transport != "zenoh":
        raise FlexhrcError("--robot and --peer-port are for --robots N --transport zenoh")
    if args.robot is not None and args.peer_port is None:
        raise FlexhrcError("--robot needs --peer-port")
    if args.peer_port is not None and not 1 <= args.peer_port <= 65535:
        raise FlexhrcError(f"--peer-port must be in 1..65535, got {args.peer_port}")
    if team:
        for name, flag in (("arms", "--arms"), ("render", "--render")):
            if getattr(args, name) is not None:
                raise FlexhrcError(f"{flag} does not apply with --robots (each robot has one arm)")
    allowed = {
        None: {
            "layout",
            "arms",
            "seed",
            "plot",
            "render",
            "log",
            "max_ticks",
            "realtime",
            "robots",
            "transport",
        },
        "replay": {"plot"},
        "render": {"layout", "arms", "seed", "log", "at", "output"},
        "compile": {"layout", "arms", "seed", "output"},
    }[action]
    defaults = {"seed": 0}
    for name in (
        "layout",
        "arms",
        "seed",
        "plot",
        "render",
        "log",
        "max_ticks",
        "realtime",
        "robots",
        "transport",
    ):
        value = getattr(args, name)
        if name not in allowed and value is not None and value != defaults.get(name):
            flag = "--" + name.replace("_", "-")
            where = f"behave {action}" if action else "a run"
            raise FlexhrcError(f"{flag} does not apply to {where}")
    for name, flag in (("output", "-o"), ("at", "--at")):
        if getattr(args, name) is not None and name not in allowed:
            raise FlexhrcError(
                f"{flag} only applies to behave render"
                + (" and behave compile" if name == "output" else "")
            )
    if args.render is not None:
        for name in ("log", "plot", "max_ticks", "realtime"):
            if getattr(args, name) is not None:
                flag = "--" + name.replace("_", "-")
                raise FlexhrcError(
                    f"{flag} does not apply with --render (it prints the network and exits)"
                )
    if action in ("render", "compile") and args.output is None:
        raise FlexhrcError(f"behave {action} needs -o OUT")
    if args.at is not None and args.log is None:
        raise FlexhrcError("--at needs --log (the run whose states to show)")


# ----------------------------------------------------------------------------- commands


def import_types(modules: list[str] | None) -> None:
    """Import the ``--types`` modules (they register behaviour types when imported)."""
    import importlib
    import importlib.util

    for name in modules or ():
        try:
            if name.endswith(".py") or "/" in name:
                path = Path(name)
                if not path.is_file():
                    raise FlexhrcError(f"--types {name}: no such file")
                spec = importlib.util.spec_from_file_location(f"flexhrc_types_{path.stem}", path)
                if spec is None or spec.loader is None:
                    raise FlexhrcError(f"--types {name}: not a Python module")
                module = importlib.util.module_from_spec(spec)
                sys.modules[spec.name] = module
                spec.loader.exec_module(module)
            else:
                importlib.import_module(name)
        except FlexhrcError:
            raise
        except Exception as exc:  # the user's module failed: say which and how
            raise FlexhrcError(f"--types {name}: {type(exc).__name__}: {exc}") from None


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    import_types(args.types)
    if args.target == "replay":
        return _replay(args)
    if args.target == "render":
        return _render(args)
    if args.target == "compile":
        return _compile(args)
    if args.robots is not None and args.robots > 1:
        from flexhrc.cli.behave_team import run_team_command

        return run_team_command(args)
    return _run(args)


class _Terminated(Exception):
    """SIGTERM during a run: finish the log, then exit like an interrupt."""


def _run(args: argparse.Namespace) -> int:
    from flexhrc.behavior.logfile import end_record, event_record, header_record
    from flexhrc.behavior.network import BehaviorNetwork, default_max_ticks
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.render import to_ascii, to_dot
    from flexhrc.behavior.validate import check_run
    from flexhrc.files import EventLogWriter, check_output

    inputs = (args.target,) if is_file(args.target) else ()
    if args.log:
        check_output(args.log, option="--log", inputs=inputs)
    check_plot(args.plot, inputs)
    if args.log and args.plot and Path(args.log).resolve() == Path(args.plot).resolve():
        raise FlexhrcError("--log and --plot name the same file")
    label, task, world, factories = resolve_document(args.target, args.layout, args.arms, args.seed)
    if args.render:
        rendered = to_ascii(task) if args.render == "ascii" else to_dot(task)
        emit(args, {"task": task.to_prefix(), "render": rendered}, rendered)
        return 0
    params = NetworkParams(seed=args.seed)
    net = BehaviorNetwork(task, world, params, behaviors=factories)
    max_ticks = args.max_ticks if args.max_ticks is not None else default_max_ticks(task)
    writer = EventLogWriter(args.log) if args.log else None
    realtime = args.realtime
    behaviors = set(task.behaviors)
    try:
        if writer is not None:
            writer.write(
                header_record(
                    label,
                    task.to_prefix(),
                    task.behaviors,
                    world.arm_names,
                    args.seed,
                    params.tick_period,
                )
            )
            net.listeners.append(lambda ev: writer.write(event_record(ev)))
        if realtime is not None:
            log(args, f"{label}: {task.to_prefix()} (real time x{realtime:g})")

            def live(ev: Any) -> None:
                line = live_line(ev, behaviors)
                if line:
                    log(args, line)

            net.listeners.append(live)
        _tick_loop(net, max_ticks, realtime)
        result = net.result()
        violations = check_run(task, result.runs)
        if writer is not None:
            writer.write(end_record(result, violations))
    except (KeyboardInterrupt, _Terminated):
        if writer is not None:
            result = net.result()
            writer.write(end_record(result, [], outcome="interrupted"))
            writer.close()
        raise KeyboardInterrupt from None
    finally:
        if writer is not None:
            writer.close()
    plot_path = None
    if args.plot:
        from flexhrc.behavior.plot import gantt

        plot_path = gantt(result, args.plot, title=f"{label}: {', '.join(result.order)}")
    data = result.to_dict()
    data.update(
        target=label,
        task=task.to_prefix(),
        seed=args.seed,
        violations=violations,
        plot=str(plot_path) if plot_path else None,
        log=args.log,
    )

    def text() -> str:
        lines = [f"{label}: {task.to_prefix()}", to_ascii(task), ""]
        lines.append(f"world: {len(world.objects)} objects; arms: {', '.join(world.arm_names)}")
        if realtime is None:
            lines.append("trace:")
            lines += [s for s in (trace_line(ev) for ev in result.log) if s]
        lines.append("")
        lines += summary_lines(result, violations, str(plot_path) if plot_path else None)
        if args.log:
            lines.append(f"event log: {args.log}")
        return "\n".join(lines)

    emit(args, data, text)
    if args.json and plot_path:
        log(args, f"gantt chart: {plot_path}")
    return 0 if result.outcome == "done" and not violations else 1


def _tick_loop(net: Any, max_ticks: int, realtime: float | None) -> None:
    """Tick to the end; with ``realtime`` keep simulated time at SPEED x wall time. SIGTERM
    stops the loop like Ctrl-C (the caller writes the log's last line)."""

    def on_term(signum: int, frame: Any) -> None:
        raise _Terminated

    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, on_term)
    except ValueError:  # not the main thread (an embedding application): leave it alone
        previous = None
    try:
        start = time.monotonic()
        while not net.finished and net.clock.tick < max_ticks:
            net.tick()
            if realtime is not None:
                delay = start + net.clock.now() / realtime - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _replay(args: argparse.Namespace) -> int:
    from flexhrc.behavior.logfile import CUT_SHORT, read_log
    from flexhrc.behavior.network import Run
    from flexhrc.behavior.task import parse_prefix
    from flexhrc.behavior.validate import check_run

    check_plot(args.plot, (args.operand,))
    blog = read_log(args.operand)
    task = parse_prefix(str(blog.header["task"]), f"{args.operand}:1")
    result = blog.result()
    # a robot of a team: what the others completed counts (learned at the time of the event)
    elsewhere = [
        Run(ev.source, f"{ev.data.get('by')}/elsewhere", ev.t, ev.t, "done")
        for ev in blog.events
        if ev.kind == "done_elsewhere"
    ]
    violations = check_run(task, sorted([*result.runs, *elsewhere], key=lambda r: r.start))
    plot_path = None
    if args.plot:
        from flexhrc.behavior.plot import gantt

        label = str(blog.header.get("target", "replay"))
        plot_path = gantt(result, args.plot, title=f"{label}: {', '.join(result.order)}")
    data = result.to_dict()
    data.update(
        target=blog.header.get("target"),
        task=task.to_prefix(),
        seed=blog.header.get("seed"),
        violations=violations,
        plot=str(plot_path) if plot_path else None,
        events=len(blog.events),
        cut_short=blog.end is None,
        robot=blog.header.get("robot"),
        done_elsewhere=[{"behavior": r.behavior, "by": r.arm.split("/")[0]} for r in elsewhere],
    )

    def text() -> str:
        lines = [f"{blog.header.get('target', 'replay')}: {task.to_prefix()}"]
        lines.append(f"log: {args.operand}, {len(blog.events)} events")
        if blog.end is None:
            lines.append(
                f"warning: the run was {CUT_SHORT}: the log ends after {result.time:.1f} s "
                "without its end line (killed?)"
            )
        if elsewhere:
            others = ", ".join(f"{r.behavior} ({r.arm.split('/')[0]})" for r in elsewhere)
            lines.append(f"done by other robots: {others}")
        lines.append("")
        lines += summary_lines(result, violations, str(plot_path) if plot_path else None)
        return "\n".join(lines)

    emit(args, data, text)
    return 0 if result.outcome == "done" and not violations else 1


def _render(args: argparse.Namespace) -> int:
    from flexhrc.behavior.render import to_dot
    from flexhrc.files import atomic_output, check_output

    inputs = tuple(p for p in (args.operand, args.log) if p and is_file(p))
    check_output(args.output, option="-o", suffixes=RENDER_SUFFIXES, inputs=inputs)
    label, task, _world = resolve(args.operand, args.layout, args.arms, args.seed)
    snapshots = None
    at = None
    if args.log:
        from flexhrc.behavior.logfile import read_log

        blog = read_log(args.log)
        if str(blog.header["task"]) != task.to_prefix():
            raise FlexhrcError(
                f"{args.log}: the log is of another task ({blog.header['task']}), "
                f"not {task.to_prefix()}"
            )
        at = blog.time if args.at is None else args.at
        states = blog.states_at(at)
        snapshots = {n.name: {"state": states.get(n.name, "inactive")} for n in task.walk()}
    dot = to_dot(task, snapshots, legend=snapshots is not None, caption=_caption(label, at))
    out = Path(args.output)
    if out.suffix.lower() in (".dot", ".gv"):
        from flexhrc.files import atomic_write_text

        atomic_write_text(out, dot)
    else:
        from flexhrc.representation.formats.dot import render

        with atomic_output(out) as tmp:
            render(dot, tmp)
    emit(args, {"output": str(out), "task": task.to_prefix(), "at": at}, f"wrote {out}")
    return 0


def _caption(label: str, at: float | None) -> str:
    return label if at is None else f"{label} at {at:.1f} s"


def _compile(args: argparse.Namespace) -> int:
    from flexhrc.behavior.compile import compile_task
    from flexhrc.files import atomic_write_text, check_output
    from flexhrc.representation.formats.yaml_format import dump_yaml

    inputs = (args.operand,) if is_file(args.operand) else ()
    check_output(args.output, option="-o", suffixes=GRAPH_SUFFIXES, inputs=inputs)
    _label, task, _world = resolve(args.operand, args.layout, args.arms, args.seed)
    hierarchy = compile_task(task)
    atomic_write_text(args.output, dump_yaml(hierarchy))
    st = hierarchy.stats()
    data = {
        "output": args.output,
        "task": task.to_prefix(),
        "behaviors": len(task.behaviors),
        "graphs": st["graphs"],
        "nodes": st["nodes"],
        "hyperarcs": st["hyperarcs"],
    }
    emit(
        args,
        data,
        f"wrote {args.output}: {st['graphs']} graph(s), {st['nodes']} nodes, "
        f"{st['hyperarcs']} hyper-arcs for {len(task.behaviors)} behaviours",
    )
    return 0


# ----------------------------------------------------------------------------- graph to-task


def register_graph_to_task(gsub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    """``flexhrc graph to-task GRAPH``: registered by :mod:`flexhrc.cli.graph`."""
    t = gsub.add_parser(
        "to-task",
        help="convert a series-parallel AND/OR graph into a THEN/AND/OR task (flexhrc behave)",
    )
    t.add_argument(
        "file", help="the AND/OR graph (.yaml or ANDOR .txt), or a scenario file: its graph"
    )
    t.add_argument(
        "-o", "--output", metavar="OUT", help="write the task here (.txt prefix form or .yaml)"
    )
    add_json_flag(t)
    t.set_defaults(func=cmd_graph_to_task)


def cmd_graph_to_task(args: argparse.Namespace) -> int:
    from flexhrc.behavior.compile import task_from_graph
    from flexhrc.files import atomic_write_text, check_output
    from flexhrc.scenario import graph_of

    if args.output:
        suffixes = (".txt", ".yaml", ".yml")
        check_output(args.output, option="-o", suffixes=suffixes, inputs=(args.file,))
    task = task_from_graph(graph_of(args.file), str(args.file))
    prefix = task.to_prefix()
    if args.output:
        if Path(args.output).suffix.lower() == ".txt":
            atomic_write_text(args.output, prefix + "\n")
        else:
            atomic_write_text(args.output, f"task: {json.dumps(prefix)}\n")
    data = {"task": prefix, "behaviors": task.behaviors, "output": args.output}
    emit(args, data, prefix + (f"\nwrote {args.output}" if args.output else ""))
    return 0
