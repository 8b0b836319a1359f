"""flexhrc behave: run the activation-spreading behaviour network of paper 002 (Fraser et al.).

TASK_OR_SCENARIO is a scenario name (table-setting, table-setting-robustness, abstract), a task
file (.yaml/.yml with an optional world, or .txt with the prefix form), or an inline prefix
string such as "(THEN a (AND b c))". A task without a world runs in a generated default world:
one object per behaviour at a random position on the table, drawn with --seed.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from flexhrc.cli.common import add_json_flag, emit, log
from flexhrc.errors import FlexhrcError, UnknownNameError

TASK_SUFFIXES = (".yaml", ".yml", ".txt")


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = subparsers.add_parser(
        "behave",
        help="run a THEN/AND/OR behaviour network (activation spreading, arm mutex, "
        "validity checks)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "target",
        metavar="TASK_OR_SCENARIO",
        help="scenario name, task file, or inline '(THEN ...)'",
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
    p.add_argument("--log", metavar="FILE", help="write the full event log as JSON lines")
    p.add_argument(
        "--max-ticks", type=int, default=50_000, help="stop after this many ticks (default 50000)"
    )
    p.set_defaults(func=run)


def resolve(target: str, layout: int | None, arms: int | None, seed: int) -> tuple[str, Any, Any]:
    """(label, task, world) for a scenario name, a task file or an inline prefix string."""
    from flexhrc.behavior.task import parse_prefix
    from flexhrc.behavior.taskfile import load_task_document
    from flexhrc.behavior.world import random_world
    from flexhrc.scenarios.table_setting import SCENARIOS, load_scenario

    if target in SCENARIOS:
        sc = load_scenario(target, layout, arms or 1, seed)
        label = f"{sc.name}" + (f" (layout {sc.layout})" if sc.layout else "")
        return label, sc.task, sc.world
    if layout is not None:
        raise FlexhrcError("--layout only applies to the table-setting scenario")
    if target.lstrip().startswith("("):
        task = parse_prefix(target, "<inline task>")
        return "inline task", task, random_world(task.behaviors, seed, arms or 1)
    path = Path(target)
    if path.suffix.lower() in TASK_SUFFIXES or path.exists():
        if not path.is_file():
            raise FlexhrcError(f"{target}: no such file")
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise FlexhrcError(f"{target}: cannot read: {exc}") from None
        stripped = "\n".join(line.split("#", 1)[0] for line in text.splitlines()).strip()
        if stripped.startswith("("):
            task, world = parse_prefix(text, str(path)), None
        else:
            doc = load_task_document(text, str(path), arms)
            task, world = doc.task, doc.world
        if world is None:
            world = random_world(task.behaviors, seed, arms or 1)
        return str(path), task, world
    raise UnknownNameError(
        f"unknown scenario {target!r} (known: {', '.join(SCENARIOS)}); "
        "or give a task file (.yaml/.txt) or an inline task such as '(THEN a (AND b c))'"
    )


def _trace_line(ev: Any) -> str | None:
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


def run(args: argparse.Namespace) -> int:
    from flexhrc.behavior.network import BehaviorNetwork
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.render import to_ascii, to_dot
    from flexhrc.behavior.validate import check_run

    label, task, world = resolve(args.target, args.layout, args.arms, args.seed)
    if args.render:
        rendered = to_ascii(task) if args.render == "ascii" else to_dot(task)
        emit(args, {"task": task.to_prefix(), "render": rendered}, rendered)
        return 0
    net = BehaviorNetwork(task, world, NetworkParams(seed=args.seed))
    result = net.run(args.max_ticks)
    violations = check_run(task, result.runs)
    if args.log:
        with open(args.log, "w", encoding="utf-8") as fh:
            for ev in result.log:
                fh.write(json.dumps(ev.to_dict()) + "\n")
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
    )

    def text() -> str:
        lines = [f"{label}: {task.to_prefix()}", to_ascii(task), ""]
        lines.append(f"world: {len(world.objects)} objects; arms: {', '.join(world.arm_names)}")
        lines.append("trace:")
        lines += [s for s in (_trace_line(ev) for ev in result.log) if s]
        lines.append("")
        lines.append(
            f"outcome: {result.outcome} after {result.time:.1f} s ({result.ticks} ticks), "
            f"resets: {result.resets}"
        )
        lines.append(f"order: {', '.join(result.order)}")
        if violations:
            lines.append("constraint violations:")
            lines += [f"  - {v}" for v in violations]
        else:
            lines.append(
                "constraints: respected (THEN order, every AND child, one alternative per OR, "
                "one behaviour per arm)"
            )
        if plot_path:
            lines.append(f"gantt chart: {plot_path}")
        return "\n".join(lines)

    emit(args, data, text)
    if args.json and plot_path:
        log(args, f"gantt chart: {plot_path}")
    return 0 if result.outcome == "done" and not violations else 1
