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

Each only translates its arguments into a config of flexhrc.behavior.behave, calls it and prints
the report (a scenario name becomes the task it names here).
"""

from __future__ import annotations

import argparse
import json
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from flexhrc.cli.common import add_json_flag, add_seed_option, emit, log
from flexhrc.errors import FlexhrcError, UnknownNameError

ACTIONS = ("replay", "render", "compile")


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
    add_seed_option(p, "seed for OR ties and generated worlds (default 0)")
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
        help="internal, with --robot: the loopback TCP port robot1 listens on for its peers "
        "(0: robot1 takes a port the system picks and writes it to --ready-file)",
    )
    p.add_argument(
        "--ready-file",
        metavar="PATH",
        help="internal, with --robot robot1: once it listens, JSON with its endpoints "
        '({"listen": ["tcp/127.0.0.1:PORT"], ...}) is written here',
    )
    p.set_defaults(func=run)


# ----------------------------------------------------------------------------- translation

#: The options each action takes (a run: ``--layout`` and those of BehaveConfig).
OPTIONS = {
    "replay": {"plot"},
    "render": {"layout", "arms", "seed", "log", "at", "output"},
    "compile": {"layout", "arms", "seed", "output"},
}


def _action(args: argparse.Namespace) -> str | None:
    """The action, once the operand and the options fit it (the values are the configs' to
    check)."""
    action = args.target if args.target in ACTIONS else None
    if action is None and args.operand is not None:
        raise FlexhrcError(
            f"unexpected argument {args.operand!r}: one task or scenario at a time "
            f"(or an action: {', '.join(ACTIONS)})"
        )
    if action is not None and args.operand is None:
        what = "LOG" if action == "replay" else "TASK"
        raise FlexhrcError(f"behave {action} needs a {what}")
    from flexhrc.behavior.command import BehaveConfig

    given_anywhere = ("target", "types", "child_args")  # the task itself, --types; internal
    run_options = [
        "layout",
        *(f.name for f in fields(BehaveConfig) if f.name not in given_anywhere),
    ]
    allowed = OPTIONS[action] if action else set(run_options)
    for name in run_options:
        value = getattr(args, name)
        if name not in allowed and value is not None and not (name == "seed" and value == 0):
            where = f"behave {action}" if action else "a run"
            raise FlexhrcError(f"--{name.replace('_', '-')} does not apply to {where}")
    for name, flag in (("output", "-o"), ("at", "--at")):
        if getattr(args, name) is not None and name not in allowed:
            also = " and behave compile" if name == "output" else ""
            raise FlexhrcError(f"{flag} only applies to behave render{also}")
    if action in ("render", "compile") and args.output is None:
        raise FlexhrcError(f"behave {action} needs -o OUT")
    return action


def _task(args: argparse.Namespace, text: str) -> Any:
    """A scenario name as the task it names (``--layout``, ``--arms``, ``--seed``); a task file
    or an inline task as it is, for the library to read."""
    from flexhrc.behavior.command import LoadedTask, is_task_text
    from flexhrc.scenario.builtin.table_setting import SCENARIOS, load_scenario

    if text in SCENARIOS:
        sc = load_scenario(text, args.layout, args.arms or 1, args.seed)
        label = sc.name + (f" (layout {sc.layout})" if sc.layout else "")
        return LoadedTask(label, sc.task, sc.world)
    if args.layout is not None:
        raise FlexhrcError("--layout only applies to the table-setting scenario")
    if not is_task_text(text):
        raise UnknownNameError(
            f"unknown scenario {text!r} (known: {', '.join(SCENARIOS)}); "
            "or give a task file (.yaml/.txt) or an inline task such as '(THEN a (AND b c))'"
        )
    return text


def _config(cls: Any, args: argparse.Namespace, **given: Any) -> Any:
    """A ``cls`` config: ``given``, and the options of the same names that were given."""
    names = {f.name for f in fields(cls)} - set(given)
    return cls(
        **{n: getattr(args, n) for n in names if getattr(args, n, None) is not None}, **given
    )


def run(args: argparse.Namespace) -> int:
    from flexhrc.behavior import behave

    action = _action(args)
    text = args.operand if action else args.target
    types = tuple(args.types or ())
    if action == "replay":
        report = behave.replay(_config(behave.ReplayConfig, args, log=text))
    elif action == "render":
        config = _config(behave.RenderConfig, args, target=text, types=types)
        report = behave.render(replace(config, target=_task(args, text)))
    elif action == "compile":
        config = _config(behave.CompileConfig, args, target=text, types=types)
        report = behave.compile_to_file(replace(config, target=_task(args, text)))
    else:
        layout = () if args.layout is None else ("--layout", str(args.layout))
        config = _config(behave.BehaveConfig, args, target=text, types=types)
        config = replace(config, target=_task(args, text), child_args=(text, *layout))
        report = behave.run_behave(config, on_line=lambda line: log(args, line))
    emit(args, report.data, report.text)
    if args.json and report.plot and action is None and not config.team:
        log(args, f"gantt chart: {report.plot}")
    return report.exit_code


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
