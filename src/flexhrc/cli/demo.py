"""``flexhrc demo table``, ``flexhrc run FILE|NAME`` and ``flexhrc replay LOG``.

``demo table`` runs the shipped table scenario (:func:`flexhrc.scenario.builtin.table_assembly`:
tabletop placement, legs fix, check; ``--segments legs`` the legs fix alone) for the table its
options describe; ``run`` runs any scenario file
(``flexhrc: 1``, :mod:`flexhrc.scenario`) or shipped scenario by name, and still accepts the
older ``scenario: table_assembly`` files. Each translates its arguments into a
:class:`flexhrc.app.RunConfig` (``replay``: a path) and prints the report of
:func:`flexhrc.app.run_scenario` (:func:`flexhrc.app.replay`); the live trace is printed here.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from flexhrc.cli.common import (
    ANSWER_TIMEOUT_OPTION,
    ON_FAILURE_OPTION,
    POLICY_OPTION,
    add_json_flag,
    add_segments_option,
    config_of,
    emit,
    float_range,
    int_range,
    progress,
    quiet_library_logs,
    seed_type,
    trace_printer,
)
from flexhrc.errors import FlexhrcError
from flexhrc.events import PROFILES

#: name -> (help, description) of the commands of this module.
COMMANDS = {
    "table": (
        "the cooperative table assembly (dual-arm robot + human operator)",
        "A dual-arm robot and a simulated human fix legs to a tabletop (FlexHRC+ paper, VI-D). "
        "Prints a live trace and the paper's Table I.",
    ),
    "run": (
        "run a scenario: a file (YAML) or a shipped one by name",
        "Run the cooperation a scenario describes, end to end: Task Manager, simulator, "
        "simulated operators, log, plots (format: docs/scenarios.md; shipped: flexhrc scenario "
        "list).",
    ),
    "replay": (
        "print the summary of a saved cooperation log (JSONL) or cell store (.db)",
        "Check every event of a cooperation log and print its summary (Table I); says so when "
        "the run was cut short (no outcome event). With --fork-at K (a cell's store): what if "
        "the cooperation had gone on otherwise from event K (docs/cell.md, What-if).",
    ),
}
#: The options of ``demo table`` that describe the table (:class:`flexhrc.app.TableDemo`).
TABLE_OPTIONS: dict[str, dict[str, Any]] = {
    "--legs": dict(
        type=int_range(None, 10_000), default=4,
        help="number of legs (default 4; as many as the tabletop holds, see --tabletop)",
    ),
    "--tabletop": dict(
        default="large", metavar="large|small|WxD",
        help="tabletop: large (0.30x0.40 m, 20 legs at most), small (0.26x0.34 m) or its "
        "width x depth in metres, e.g. 0.9x0.9 for 60 legs (default large)",
    ),
    "--leg-length": dict(
        choices=["long", "short"], default="long",
        help="length of the legs: long (0.40 m) or short (0.30 m)",
    ),
    "--unreachable-bolt": dict(
        type=int, action="append", default=[], metavar="K",
        help="bolt K cannot be reached by either arm (the robot asks the human, paper Fig. 12)",
    ),
    "--no-human": dict(action="store_true", help="the robot works alone"),
}  # fmt: skip
#: The options of ``run`` and ``demo table`` after ``--segments``: each is the field of
#: :class:`flexhrc.app.RunConfig` of the same name, with its default.
RUN_OPTIONS: dict[str, dict[str, Any]] = {
    "--human": dict(
        choices=PROFILES,
        help="human operator profile: passive (acts when asked), takeover, cooperative, random",
    ),
    "--seed": dict(
        type=seed_type, default=0,
        help="seed of the leg layout and of the operator's choices (default 0)",
    ),
    "--human-takes": dict(
        type=int, action="append", metavar="K",
        help="script the operator: it takes the K-th cooperation step it could do (for the "
        "table: bolt K; repeatable), whatever the profile",
    ),
    "--fail": dict(
        action="append", default=[], metavar="ACTION[:N]",
        help="inject a failure of the N-th robot ACTION (e.g. transport:1)",
    ),
    "--reaction": dict(
        choices=["conflicts", "paper"], default="conflicts",
        help="when the operator does something not suggested: stop only the robot actions "
        "that conflict with it (conflicts, default) or every robot action, arms to rest "
        "(paper, V-B)",
    ),
    "--on-failure": ON_FAILURE_OPTION,
    "--policy": POLICY_OPTION,
    "--answer-timeout": ANSWER_TIMEOUT_OPTION,
    "--simulator": dict(
        choices=["auto", "analytic", "kinematic"],
        help="how branches are simulated: kinematic (task-priority control on the robot model; "
        "what auto picks when the sim extra is installed) or analytic (distances and speeds)",
    ),
    "--timing": dict(
        choices=["default", "paper"],
        help="how simulated actions are timed: default, or paper (the paper's Baxter: joints "
        "at most 0.6 rad/s, and per-action times calibrated on its Table I, to set the "
        "simulated robot and human times beside its 219 s / 26 s / 250 s); default: the "
        "scenario's timing key",
    ),
    "--disturb": dict(
        action="append", default=[], metavar="KIND[:ACTION[:N]]",
        help="kinematic simulator only: during the N-th ACTION (default transport:1) the real "
        "robot meets KIND = blocked_path (an obstacle appears at the target) or slow_arm; "
        "push[:PROCESS[:N]] pushes the held object 3 cm during the N-th hold (default the "
        "first hold process), which the hold behaviour undoes",
    ),
    "--human-sensing": dict(
        choices=["injected", "har", "har-real"], default="injected",
        help="how the manager learns what the operator did: told directly, recognised from "
        "a synthesised wrist signal (har), or from real HMP trials of other volunteers than "
        "the model was trained on (har-real, needs --hmp; perception extra)",
    ),
    "--hmp": dict(metavar="DIR", help="the HMP dataset folder for --human-sensing har-real"),
    "--perception": dict(
        choices=["given", "scene"], default="given",
        help="where the manager's object positions come from: given by the scenario, or "
        "scene perception of the robot's head camera (sim and perception extras)",
    ),
    "--repair": dict(
        action="store_true",
        help="with --perception scene: repair an inconsistent knowledge base (look again, ask "
        "the operator to confirm) instead of waiting",
    ),
    "--har-model": dict(
        metavar="FILE", help="a trained recogniser (flexhrc har train) for --human-sensing har"
    ),
    "--log": dict(
        metavar="FILE",
        help="write the event log (JSON lines), event by event as the run goes; the file is "
        "locked, so a second run on it is refused",
    ),
    "--plot": dict(metavar="FILE", help="write the timeline (.png, .svg or .pdf)"),
    "--quiet": dict(action="store_true", help="no live trace"),
    "--realtime": dict(
        type=float_range(0.0, 1e6, lo_open=True), nargs="?", const=1.0, metavar="SPEED",
        help="pace the simulated clock for watching: real time, or SPEED times faster",
    ),
    "--operators": dict(
        metavar="FILE",
        help="an operator model (flexhrc learn STORE... -o FILE; docs/operators.md): each "
        "person's steps are timed by what they took before, and updated as they act",
    ),
}  # fmt: skip


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser("demo", help="run a ready-made simulated human-robot demo")
    dsub = p.add_subparsers(dest="demo", metavar="DEMO", required=True)
    _run_options(_command(dsub, "table", cmd_demo_table), TABLE_OPTIONS)
    r = _command(sub, "run", cmd_run)
    r.add_argument(
        "scenario", metavar="FILE|NAME", help="a scenario file, or a shipped scenario's name"
    )
    _run_options(r, {})
    rp = _command(sub, "replay", cmd_replay)
    rp.add_argument(
        "log", metavar="LOG", help="the event log a run wrote with --log, or a cell's store (.db)"
    )
    rp.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the timeline from the log (.png, .svg or .pdf); with --fork-at both "
        "timelines, the stored run above the what-if",
    )
    what_if = rp.add_argument_group(
        "what-if (a cell's store only, docs/cell.md)",
        "rebuild the stored cooperation up to event K, go on with new choices and simulated "
        "agents, keep the new run in a new store and print both runs side by side",
    )
    what_if.add_argument(
        "--fork-at",
        type=int_range(1, None),
        metavar="K",
        help="fork the stored run after its event K (its seq: 1 is the start)",
    )
    what_if.add_argument(
        "--human",
        choices=PROFILES,
        metavar="PROFILE",
        help="the operators' profile from event K on: passive, takeover, cooperative, random "
        "(default: as stored)",
    )
    what_if.add_argument(
        "--on-failure",
        choices=ON_FAILURE_OPTION["choices"],
        default=None,
        help="the failure policy of the what-if: retry or paper (default: as stored; refused "
        "when a robot action failed within the first K events)",
    )
    what_if.add_argument(
        "--operators",
        metavar="FILE",
        help="the operator model (flexhrc learn; docs/operators.md) the manager times the "
        "people's steps by; a run made with --operators forks faithfully with the same file",
    )
    what_if.add_argument(
        "--utility",
        metavar="FILE",
        help="the branch utility from event K on: a YAML file with the block the scenario key "
        "utility: takes (docs/scenarios.md; default: the stored run's)",
    )
    what_if.add_argument(
        "-o",
        "--output",
        metavar="NEW.db",
        help="the what-if's store (default: STORE-forkK.db beside the stored one); an existing "
        "file is refused unless --force",
    )
    what_if.add_argument(
        "--force", action="store_true", help="replace an existing -o file with the what-if"
    )
    what_if.add_argument(
        "--scenario",
        metavar="FILE|NAME",
        help="the stored run's scenario, when it is a file (default: the shipped scenario the "
        "store names)",
    )
    add_json_flag(rp)


def _command(sub: Any, name: str, func: Any) -> argparse.ArgumentParser:
    help_, description = COMMANDS[name]
    p: argparse.ArgumentParser = sub.add_parser(name, help=help_, description=description)
    p.set_defaults(func=func)
    return p


def _run_options(p: argparse.ArgumentParser, first: dict[str, dict[str, Any]]) -> None:
    for flag, kw in first.items():
        p.add_argument(flag, **kw)
    add_segments_option(p)
    for flag, kw in RUN_OPTIONS.items():
        p.add_argument(flag, **kw)
    add_json_flag(p)


def cmd_demo_table(args: argparse.Namespace) -> int:
    from flexhrc.app import TableDemo

    table = TableDemo(
        args.legs, args.tabletop, args.leg_length, tuple(args.unreachable_bolt), not args.no_human
    )
    return cmd_run(args, table)


def cmd_run(args: argparse.Namespace, scenario: Any = None) -> int:
    from flexhrc.app import RunConfig, run_scenario
    from flexhrc.app.run import trace_line

    scenario = args.scenario if scenario is None else scenario
    config = config_of(RunConfig, args, scenario=scenario)
    report = run_scenario(config, trace=trace_printer(args, trace_line), progress=progress)
    for warning in report.warnings:
        progress(warning)
    emit(args, report.json, report.text)
    if report.signal is not None:
        print("interrupted", file=sys.stderr)
    return int(report.exit_code)


def cmd_replay(args: argparse.Namespace) -> int:
    from flexhrc.app import replay

    if args.fork_at is not None:
        return _cmd_what_if(args)
    given = [o for o, v in _WHAT_IF_OPTIONS.items() if getattr(args, v) not in (None, False)]
    if given:
        raise FlexhrcError(f"{', '.join(given)}: only with --fork-at K (a what-if run)")
    report = replay(args.log, plot=args.plot)
    for warning in report.warnings:
        progress(warning)
    emit(args, report.json, report.text)
    return 0


#: The options of ``replay`` that only a what-if takes (option -> its attribute).
_WHAT_IF_OPTIONS = {
    "--human": "human",
    "--on-failure": "on_failure",
    "--operators": "operators",
    "--utility": "utility",
    "-o": "output",
    "--force": "force",
    "--scenario": "scenario",
}


def _cmd_what_if(args: argparse.Namespace) -> int:
    """``replay STORE --fork-at K``: the stored run and its what-if side by side."""
    from flexhrc.app import what_if
    from flexhrc.cell.fork import compare_text
    from flexhrc.cell.store import is_store

    # a resumed operator may answer options sent to it twice; the cell drops the repeat
    quiet_library_logs()
    if not is_store(args.log):
        raise FlexhrcError(
            f"--fork-at: {args.log} is not a cell's event store (.db): only a store can be "
            "forked (flexhrc cell --store FILE.db)"
        )
    report = what_if(
        args.log,
        args.fork_at,
        args.output,
        human=args.human,
        on_failure=args.on_failure,
        operators=args.operators,
        utility=args.utility,
        scenario=args.scenario,
        force=args.force,
        plot=args.plot,
    )
    emit(args, report.to_json(), compare_text(report))
    return 0
