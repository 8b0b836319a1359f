"""``flexhrc demo table``, ``flexhrc run FILE|NAME`` and ``flexhrc replay LOG``.

``demo table`` runs the shipped table scenario (:func:`flexhrc.scenario.builtin.table_assembly`:
tabletop placement, legs fix, check; ``--segments legs`` the legs fix alone) for the table its
options describe; ``run`` runs any scenario file
(``flexhrc: 1``, :mod:`flexhrc.scenario`) or shipped scenario by name, and still accepts the
older ``scenario: table_assembly`` files.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from flexhrc.cli.common import (
    add_json_flag,
    add_segments_option,
    check_outputs,
    emit,
    float_range,
    int_range,
    plural,
    progress,
    seed_type,
)
from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.taskmanager.replay import solved_by_line

TRACE_TYPES = {
    "decision",
    "command",
    "suggestion",
    "recognised",
    "abort",
    "action_failed",
    "infeasible",
    "outcome",
    "human_decides",
    "waiting",
    "human_action_unmatched",
    "human_sensed",
    "human_sensing_missed",
    "human_gives_up",
    "process_activated",
    "process_ended",
    "precondition_failed",
    "inconsistent",
    "consistent_again",
    "repair",
    "repaired",
    "operator_answers",
    "operator_nudges",
    "false_report",
    "stop",
}
PLOT_SUFFIXES = (".png", ".svg", ".pdf")
# scenario settings -> the demo's options (for errors that name what the user typed)
DEMO_FLAGS = {
    "legs": "--legs",
    "tabletop": "--tabletop",
    "leg_length": "--leg-length",
    "seed": "--seed",
    "unreachable_bolts": "--unreachable-bolt",
}
MAX_LEGS = 10_000
EXIT_SIGNAL = {signal.SIGINT: 130, signal.SIGTERM: 143}


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser("demo", help="run a ready-made simulated human-robot demo")
    dsub = p.add_subparsers(dest="demo", metavar="DEMO", required=True)
    t = dsub.add_parser(
        "table",
        help="the cooperative table assembly (dual-arm robot + human operator)",
        description="A dual-arm robot and a simulated human fix legs to a tabletop (FlexHRC+ "
        "paper, VI-D). Prints a live trace and the paper's Table I.",
    )
    _scenario_options(t)
    t.set_defaults(func=cmd_demo_table)

    r = sub.add_parser(
        "run",
        help="run a scenario: a file (YAML) or a shipped one by name",
        description="Run the cooperation a scenario describes, end to end: Task Manager, "
        "simulator, simulated operators, log, plots (format: docs/scenarios.md; shipped: "
        "flexhrc scenario list).",
    )
    r.add_argument(
        "scenario", metavar="FILE|NAME", help="a scenario file, or a shipped scenario's name"
    )
    _run_options(r)
    r.set_defaults(func=cmd_run)

    rp = sub.add_parser(
        "replay",
        help="print the summary of a saved cooperation log (JSONL) or cell store (.db)",
        description="Check every event of a cooperation log and print its summary (Table I); "
        "says so when the run was cut short (no outcome event).",
    )
    rp.add_argument("log", metavar="LOG", help="the event log a run wrote with --log")
    rp.add_argument(
        "--plot", metavar="FILE", help="draw the timeline from the log (.png, .svg or .pdf)"
    )
    add_json_flag(rp)
    rp.set_defaults(func=cmd_replay)


def _scenario_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--legs",
        type=int_range(None, MAX_LEGS),
        default=4,
        help="number of legs (default 4; as many as the tabletop holds, see --tabletop)",
    )
    p.add_argument(
        "--tabletop",
        default="large",
        metavar="large|small|WxD",
        help="tabletop: large (0.30x0.40 m, 20 legs at most), small (0.26x0.34 m) or its "
        "width x depth in metres, e.g. 0.9x0.9 for 60 legs (default large)",
    )
    p.add_argument(
        "--leg-length",
        choices=["long", "short"],
        default="long",
        help="length of the legs: long (0.40 m) or short (0.30 m)",
    )
    p.add_argument(
        "--unreachable-bolt",
        type=int,
        action="append",
        default=[],
        metavar="K",
        help="bolt K cannot be reached by either arm (the robot asks the human, paper Fig. 12)",
    )
    p.add_argument("--no-human", action="store_true", help="the robot works alone")
    _run_options(p)


def _run_options(p: argparse.ArgumentParser) -> None:
    from flexhrc.events import PROFILES

    add_segments_option(p)
    p.add_argument(
        "--human",
        choices=PROFILES,
        default=None,
        help="human operator profile: passive (acts when asked), takeover, cooperative, random",
    )
    p.add_argument(
        "--seed",
        type=seed_type,
        default=0,
        help="seed of the leg layout and of the operator's choices (default 0)",
    )
    p.add_argument(
        "--human-takes",
        type=int,
        action="append",
        default=None,
        metavar="K",
        help="script the operator: it takes the K-th cooperation step it could do (for the "
        "table: bolt K; repeatable), whatever the profile",
    )
    p.add_argument(
        "--fail",
        action="append",
        default=[],
        metavar="ACTION[:N]",
        help="inject a failure of the N-th robot ACTION (e.g. transport:1)",
    )
    p.add_argument(
        "--reaction",
        choices=["conflicts", "paper"],
        default="conflicts",
        help="when the operator does something not suggested: stop only the robot actions "
        "that conflict with it (conflicts, default) or every robot action, arms to rest "
        "(paper, V-B)",
    )
    p.add_argument(
        "--simulator",
        choices=["auto", "analytic", "kinematic"],
        default=None,
        help="how branches are simulated: kinematic (task-priority control on the robot model; "
        "what auto picks when the sim extra is installed) or analytic (distances and speeds)",
    )
    p.add_argument(
        "--disturb",
        action="append",
        default=[],
        metavar="KIND[:ACTION[:N]]",
        help="kinematic simulator only: during the N-th ACTION (default transport:1) the real "
        "robot meets KIND = blocked_path (an obstacle appears at the target) or slow_arm",
    )
    p.add_argument(
        "--human-sensing",
        choices=["injected", "har", "har-real"],
        default="injected",
        help="how the manager learns what the operator did: told directly, recognised from "
        "a synthesised wrist signal (har), or from real HMP trials of other volunteers than "
        "the model was trained on (har-real, needs --hmp; perception extra)",
    )
    p.add_argument(
        "--hmp", metavar="DIR", help="the HMP dataset folder for --human-sensing har-real"
    )
    p.add_argument(
        "--perception",
        choices=["given", "scene"],
        default="given",
        help="where the manager's object positions come from: given by the scenario, or "
        "scene perception of the robot's head camera (sim and perception extras)",
    )
    p.add_argument(
        "--repair",
        action="store_true",
        help="with --perception scene: repair an inconsistent knowledge base (look again, ask "
        "the operator to confirm) instead of waiting",
    )
    p.add_argument(
        "--har-model",
        metavar="FILE",
        help="a trained recogniser (flexhrc har train) for --human-sensing har",
    )
    p.add_argument(
        "--log",
        metavar="FILE",
        help="write the event log (JSON lines), event by event as the run goes; the file is "
        "locked, so a second run on it is refused",
    )
    p.add_argument("--plot", metavar="FILE", help="write the timeline (.png, .svg or .pdf)")
    p.add_argument("--quiet", action="store_true", help="no live trace")
    p.add_argument(
        "--realtime",
        type=float_range(0.0, 1e6, lo_open=True),
        nargs="?",
        const=1.0,
        default=None,
        metavar="SPEED",
        help="pace the simulated clock for watching: real time, or SPEED times faster",
    )
    add_json_flag(p)


def _simulators(args: argparse.Namespace, actions: Any = None) -> tuple[Any, Any]:
    """(branch simulator, execution model) for --simulator and --disturb; ``actions`` are the
    domain's action names --disturb may name."""
    from flexhrc.scenario.simulators import choose_simulator, resolve_simulator_name

    name = resolve_simulator_name(args.simulator or "auto")
    if name == "analytic" and args.disturb:
        raise FlexhrcError("--disturb needs --simulator kinematic (use --fail with analytic)")
    specs = [_disturbance(spec, actions) for spec in args.disturb]  # before building anything
    _, sim = choose_simulator(name)
    for action, nth, params in specs:
        sim.schedule(action, nth, **params)
    return sim, sim


def _disturbance(spec: str, actions: Any) -> tuple[str, int, dict[str, Any]]:
    kind, _, rest = spec.partition(":")
    action, _, n = rest.partition(":")
    if kind not in ("blocked_path", "slow_arm"):
        raise FlexhrcError(f"--disturb {spec!r}: KIND is blocked_path or slow_arm")
    action = action or "transport"
    if actions is not None and action not in actions:
        raise FlexhrcError(
            f"--disturb {spec!r}: unknown robot action {action!r}; one of {', '.join(actions)}"
        )
    nth = _nth(n, f"--disturb {spec!r}")
    params: dict[str, Any] = {"kind": kind, "once": True, "at_s": 0.3}
    if kind == "slow_arm":
        params.update(factor=0.2, at_s=None)
    return action, nth, params


def _nth(text: str, where: str) -> int:
    try:
        nth = int(text) if text else 1
    except ValueError:
        raise FlexhrcError(f"{where}: N must be a whole number") from None
    if not 1 <= nth <= 1_000_000:
        raise FlexhrcError(f"{where}: N must be at least 1 (the first time is 1), got {nth}")
    return nth


def _check_perception_options(args: argparse.Namespace) -> None:
    """Option combinations of perception and human sensing, checked before any work."""
    if args.human_sensing == "har-real" and not args.hmp:
        raise FlexhrcError("--human-sensing har-real needs --hmp DIR (the HMP dataset folder)")
    if args.hmp and args.human_sensing != "har-real":
        raise FlexhrcError("--hmp goes with --human-sensing har-real")
    if args.hmp and not Path(args.hmp).is_dir():
        raise FlexhrcError(f"--hmp {args.hmp}: not a directory")
    if args.human_sensing == "har-real" and args.har_model:
        raise FlexhrcError(
            "--har-model goes with --human-sensing har (har-real trains its own model on other "
            "volunteers than those it replays)"
        )
    if args.repair and args.perception != "scene":
        raise FlexhrcError("--repair needs --perception scene (only perception notices)")


def _human_sensing(args: argparse.Namespace) -> Any:
    _check_perception_options(args)
    if args.human_sensing == "har-real":
        try:
            from flexhrc.sensing.har_real import HmpReplaySensor
        except ImportError as exc:
            raise FlexhrcError(
                f"--human-sensing har-real needs the perception extra ({exc.name} is missing): "
                "pip install 'flexhrc[perception]'"
            ) from None
        if not args.quiet:
            print("training the wrist-motion recogniser on HMP volunteers ...", file=sys.stderr)
        return HmpReplaySensor(args.hmp, seed=args.seed)
    if args.human_sensing != "har":
        if args.har_model:
            raise FlexhrcError("--har-model goes with --human-sensing har")
        return None
    try:
        from flexhrc.perception.human import GMMGMRRecognizer
        from flexhrc.perception.human.sensing import WearableHumanSensor
    except ImportError as exc:
        raise FlexhrcError(
            f"--human-sensing har needs the perception extra ({exc.name} is missing): "
            "pip install 'flexhrc[perception]'"
        ) from None
    model = GMMGMRRecognizer.load(args.har_model) if args.har_model else None
    if model is None and not args.quiet:
        print("training the wrist-motion recogniser on synthetic motions ...", file=sys.stderr)
    return WearableHumanSensor(model, seed=args.seed)


def _failures(specs: list[str], actions: Any = None) -> list[Any]:
    from flexhrc.cell.local import InjectedFailure

    out = []
    for spec in specs:
        action, sep, n = spec.partition(":")
        if not action or ":" in n or (sep and not n):
            raise FlexhrcError(f"--fail {spec!r}: expected ACTION or ACTION:N")
        if actions is not None and action not in actions:
            raise FlexhrcError(
                f"--fail {spec!r}: unknown robot action {action!r}; one of {', '.join(actions)}"
            )
        try:
            nth = int(n) if n else 1
        except ValueError:
            raise FlexhrcError(f"--fail {spec!r}: expected ACTION or ACTION:N") from None
        if not 1 <= nth <= 1_000_000:
            raise FlexhrcError(f"--fail {spec!r}: N must be at least 1 (the first time is 1)")
        out.append(InjectedFailure(action, nth))
    return out


def _trace_printer(args: argparse.Namespace) -> Any:
    if args.quiet:
        return None
    stream = sys.stderr if args.json else sys.stdout

    def trace(ev: dict[str, Any]) -> None:
        kind = ev["type"]
        if kind not in TRACE_TYPES:
            return
        t = f"{ev['t']:7.2f}s"
        if kind == "decision":
            n = len(ev["branches"])
            best = ev["chosen"]
            line = f"decide {ev['element']} (cost {ev['cost']}): {plural(n, 'branch')} simulated"
            if best is not None:
                b = ev["branches"][best]
                grounding = ", ".join(f"{k}={v}" for k, v in sorted(b["grounding"].items()))
                line += f", best {grounding} J={b['utility']:.4f}"
            else:
                line += ", none succeeds"
        elif kind == "command":
            line = f"{'+'.join(ev['agents']):<6} {ev['action']}"
        elif kind == "suggestion":
            line = f"ask human: {ev['element']}: {'; '.join(ev['actions'])}"
        elif kind == "recognised":
            line = f"human did {ev['action']} -> follows {ev['element']}"
        elif kind == "abort":
            line = f"stop {ev['element']}: {ev['reason']}"
        elif kind == "action_failed":
            line = f"FAILED {ev['element']} ({ev['status']}): {ev['reason']}"
        elif kind == "infeasible":
            line = f"{ev['element']} infeasible: {ev['reason']}"
        elif kind == "human_decides":
            line = (
                f"{ev.get('agent', 'human')} goes for {ev['element']}: {'; '.join(ev['actions'])}"
            )
        elif kind == "human_gives_up":
            what = ev.get("object") or ev.get("step")
            line = f"{ev.get('agent', 'human')} leaves {what}: the {ev['holder']} got there first"
        elif kind == "human_sensed":
            line = (
                f"wrist sensor: {ev['performed']} -> recognised {ev['recognised']} "
                f"(confidence {ev['confidence']:.2f}, {ev['samples']} samples)"
            )
        elif kind == "human_sensing_missed":
            line = f"wrist sensor missed {ev['action']}: the manager is not told"
        elif kind == "inconsistent":
            line = f"INCONSISTENT: {ev['reason']}"
        elif kind == "consistent_again":
            line = f"consistent again: {ev['object']} ({ev['why']})"
        elif kind == "repair":
            line = f"repair: {ev['step']}" + (f" - {ev['question']}" if "question" in ev else "")
        elif kind == "repaired":
            line = f"repaired {ev['object']} by {ev['by']}"
        elif kind == "operator_answers":
            line = f"operator: {ev['answer']} ({ev['question']})"
        elif kind == "operator_nudges":
            line = f"operator moves {ev['part']} by {ev['offset']}"
        elif kind == "false_report":
            line = f"wrist sensor reports {ev['action']} (false)"
        elif kind == "stop":
            line = f"STOP {ev['agent']}: {ev['reason']}"
        elif kind == "process_activated":
            line = f"{ev['node']} reached: its processes start ({', '.join(ev['processes'])})"
        elif kind == "process_ended":
            line = f"{ev['process']} ended ({ev['reason']}); {ev['node']} can be met"
        elif kind == "precondition_failed":
            line = f"{ev['element']}: {ev['reason']} at dispatch; re-planning"
        elif kind == "human_action_unmatched":
            line = f"human did {ev['action']}: it advances no feasible hyper-arc"
        elif kind == "waiting":
            line = f"waiting: {ev['reason']}"
        elif kind == "outcome":
            line = f"outcome: {ev['outcome'].upper()}" + (
                f" ({ev['reason']})" if ev["reason"] else ""
            )
        else:
            line = json.dumps(ev)
        print(f"{t}  {line}", file=stream, flush=True)

    return trace


def cmd_demo_table(args: argparse.Namespace) -> int:
    from flexhrc.scenario.builtin.table import ScenarioError, TableLayout, table_assembly

    table: dict[str, Any] = dict(
        legs=args.legs,
        tabletop=args.tabletop,
        leg_length=args.leg_length,
        seed=args.seed,
        human=not args.no_human,
        unreachable_bolts=tuple(args.unreachable_bolt),
    )
    try:
        TableLayout(**table)  # the table's errors in the words of the options, first
        if args.no_human and args.human_takes:
            raise FlexhrcError("--human-takes needs a human: drop --no-human")
        if args.no_human and args.human is not None:
            raise FlexhrcError(f"--human {args.human} needs a human: drop --no-human")
        if args.perception == "scene":
            table = _bodies_apart(table)
        scenario = table_assembly(**table, segments=args.segments or "all")
    except ScenarioError as exc:
        raise FlexhrcError(_flag_error(exc)) from None
    return _run_table(args, scenario, args.human or "passive", inputs=[])


def _bolt_steps(bolts: list[int] | None, scenario: Any) -> list[int | str] | None:
    """``--human-takes K`` means bolt K: in the legs segment alone that is the K-th cooperation
    step; with the tabletop placement before it, the step is named by its node."""
    if not bolts:
        return None
    if scenario.segments == ("legs",):
        return list(bolts)
    return [f"connected_{k}" for k in bolts]


def _flag_error(exc: Any) -> str:
    """A scenario error in the words of the demo's options."""
    flag = DEMO_FLAGS.get(exc.key, f"--{exc.key.replace('_', '-')}")
    text = f"{flag} {exc.detail}"
    if exc.fix is not None:
        text += f"; {DEMO_FLAGS.get(exc.fix[0], exc.fix[0])} {exc.fix[1]} holds them"
    return text


@contextlib.contextmanager
def _stop_on_signals(run: Any) -> Iterator[list[int]]:
    """SIGINT/SIGTERM ask the run to stop at its next event (it then writes an ``outcome``
    event ``interrupted`` and the summary); a second signal stops at once."""
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return

    def handler(signum: int, _frame: Any) -> None:
        if caught:
            raise KeyboardInterrupt
        caught.append(signum)
        run.request_stop(f"interrupted by {signal.Signals(signum).name}")

    old = {sig: signal.signal(sig, handler) for sig in EXIT_SIGNAL}
    try:
        yield caught
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)


def _run_table(
    args: argparse.Namespace, scenario: Any, profile: str, inputs: list[Any], where: str = ""
) -> int:
    """A table assembly (a :class:`~flexhrc.scenario.Scenario` of
    :func:`flexhrc.scenario.builtin.table_assembly`), with the options of ``demo``/``run``."""
    from flexhrc.files import EventLogWriter

    # everything that can be wrong is found before the run starts
    domain = scenario.domain
    legs = sum(1 for o in scenario.world().objects.values() if o.type == "leg")
    robot_actions = _robot_actions(domain)
    failures = _failures(args.fail, robot_actions)
    if args.human_takes:
        for k in args.human_takes:
            if not 1 <= k <= legs:
                raise FlexhrcError(f"--human-takes {k}: not one of the bolts 1..{legs}")
        if not scenario.humans:
            raise FlexhrcError(f"--human-takes needs a human, but {where}human: false")
    check_outputs(
        [("--log", args.log, None), ("--plot", args.plot, PLOT_SUFFIXES)],
        inputs=[*inputs, args.har_model],
    )
    if args.plot:
        _need_matplotlib()
    simulator, execution = _simulators(args, robot_actions)
    sensing = _human_sensing(args)
    writer = EventLogWriter(args.log) if args.log else None
    try:
        run_kw: dict[str, Any] = dict(
            simulator=simulator,
            execution=execution,
            human_profile=profile,
            seed=args.seed,
            failures=failures,
            trace=_trace_printer(args),
            realtime=args.realtime or 0.0,
            human_takes=_bolt_steps(args.human_takes, scenario),
            human_sensing=sensing,
            sink=writer.write if writer is not None else None,
            reaction=args.reaction,
        )
        graph, truth = scenario.online_graph(), scenario.world()
        if args.perception == "scene":
            run = _perceived(args, graph, domain, truth, run_kw)
        else:
            run = _local_run(scenario, run_kw)
        with _stop_on_signals(run) as caught:
            result = run.run()
    finally:
        if writer is not None:
            writer.close()
    who = f"human takes bolts {args.human_takes}" if args.human_takes else f"human {profile}"
    data = _with_sensing(dict(result.summary), result.events, args)
    return _report(
        args, run, result, data, caught,
        title=f"table assembly, {plural(legs, 'leg')}, {who}, seed {args.seed}",
        subject="", solved_by=solved_by_line(data),
    )  # fmt: skip


def _local_run(scenario: Any, run_kw: dict[str, Any]) -> Any:
    """The engine in this process (:class:`~flexhrc.cell.local.LocalCell`) with the options of
    a ``demo``/``run`` command."""
    from flexhrc.cell.local import LocalCell

    kw = dict(run_kw)
    trace, sink = kw.pop("trace", None), kw.pop("sink", None)
    kw["profile"] = kw.pop("human_profile")
    return LocalCell(scenario, observers=[f for f in (sink, trace) if f is not None], **kw)


def _report(
    args: argparse.Namespace,
    run: Any,
    result: Any,
    data: dict[str, Any],
    caught: list[int],
    *,
    title: str,
    subject: str,
    solved_by: str,
) -> int:
    """The end of a cooperation run (`demo table`, `run`): the timeline plot, warnings for
    failures that never fired, Table I and a summary line (or ``--json``), the exit code."""
    from flexhrc.taskmanager.replay import table_i

    if args.plot:
        from flexhrc.files import atomic_output
        from flexhrc.taskmanager.timeline import plot_timeline

        with atomic_output(args.plot) as tmp:
            plot_timeline(result.events, tmp, title)
    for f in run.unfired_failures():
        progress(
            f"warning: --fail {f.action}:{f.nth} never happened: the run had "
            f"{plural(run.executions_of(f.action), f.action + ' action')}"
        )

    def text() -> str:
        out = ["", table_i(data), ""]
        out.append(
            f"{subject}outcome {data['outcome']}"
            + (f" ({data['reason']})" if data["reason"] else "")
            + f"; {solved_by}; {plural(data['decisions'], 'decision tree')}, "
            f"{plural(data['branches_simulated'], 'branch', 'branches')} simulated "
            f"({data['simulator']} simulator); "
            f"{data['robot_actions']} robot and {plural(data['human_actions'], 'human action')}"
        )
        if args.log:
            out.append(f"event log: {args.log}")
        if args.plot:
            out.append(f"timeline: {args.plot}")
        return "\n".join(out)

    emit(args, data, text)
    if caught:
        print("interrupted", file=sys.stderr)
        return EXIT_SIGNAL[signal.Signals(caught[0])]
    return 0 if data["outcome"] == "solved" else 1


def _bodies_apart(table: dict[str, Any]) -> dict[str, Any]:
    """With perception the legs are bodies the camera sees, not points: when the demo's
    placement (``table``: the options of :class:`TableLayout`) puts them too close to lie side
    by side, they are laid out clear of each other (seeded, beside the tabletop)."""
    from flexhrc.errors import FlexhrcError as _Error
    from flexhrc.scenario.builtin.table import LEG_LENGTHS, TableLayout
    from flexhrc.sensing.loop import lying_layout
    from flexhrc.sensing.world import SimulatedWorkspace

    layout = TableLayout(**table)
    try:
        SimulatedWorkspace.from_knowledge(layout.world())
        return table
    except _Error:
        pass
    try:
        positions = lying_layout(
            layout.legs,
            layout.seed,
            tabletop_depth=layout.size[1],
            length=LEG_LENGTHS[layout.leg_length],
        )
    except _Error:
        raise FlexhrcError(
            f"--perception scene: {plural(layout.legs, 'leg')} do not fit beside the tabletop "
            "as bodies the camera can tell apart; use fewer --legs"
        ) from None
    return {**table, "leg_positions": positions}


def _perceived(
    args: argparse.Namespace, graph: Any, domain: Any, truth: Any, run_kw: dict[str, Any]
) -> Any:
    """The run with the head camera, the scene pipeline and anchoring in the loop: the
    manager is given no position of the parts; ``truth`` is the simulated workspace."""
    try:
        from flexhrc.sensing.setup import perceived_run
    except ImportError as exc:
        raise FlexhrcError(
            f"--perception scene needs the sim and perception extras ({exc.name} is missing): "
            "pip install 'flexhrc[sim,perception]'"
        ) from None
    if not args.quiet:
        progress("perception: head camera, scene pipeline, anchoring ...")
    # the cell configured with perception in the loop: no simulated-time budget of its own
    kw = {k: v for k, v in run_kw.items() if k != "max_time_s"}
    kw.setdefault("name", "table_assembly")  # `demo table`: the scenario the table's logs name
    return perceived_run(graph, domain, truth, repair=args.repair, **kw)


def _perceived_like(args: argparse.Namespace, run: Any) -> Any:
    """The perceived twin of a prepared cooperation run (same graph, domain, world,
    simulator, operators and options), as a configuration of the cell."""
    cell = run.cell  # a LocalCell: the cell's in-process configuration
    run_kw = dict(
        simulator=cell.tm.simulator,
        execution=run.injection.inner,
        seed=args.seed,
        failures=run.injection.failures,
        observers=cell.observers[1:],  # the streamed log and the trace, not its own list
        realtime=cell.realtime,
        human_takes=args.human_takes,
        human_sensing=run.human_sensing,
        humans=run.operator_profiles(),
        reaction=cell.tm.reaction,
        name=str(run.scenario.name),
    )
    return _perceived(args, cell.graph, cell.domain, cell.kb, run_kw)


def _with_sensing(data: dict[str, Any], events: list[dict[str, Any]], args: Any) -> dict[str, Any]:
    """The ``perception`` (with ``--perception scene``) and ``human_sensing`` (with
    ``--perception scene`` or a wrist sensor) keys of a run's JSON; a plain run keeps the keys
    it always had (the cell's summary has the same)."""
    scene = args.perception == "scene"
    if scene:
        data["perception"] = {"mode": "scene", **data.get("perception", {})}
    else:
        data.pop("perception", None)
    if not scene and args.human_sensing == "injected":
        data.pop("human_sensing", None)
        return data
    if "human_sensing" not in data:
        sensed = [e for e in events if e["type"] == "human_sensed" and e["samples"]]
        uncovered = sum(1 for e in events if e["type"] == "human_sensing_uncovered")
        if sensed or uncovered or args.human_sensing != "injected":
            ok = sum(e["recognised"] == e["performed"] for e in sensed)
            missed = sum(e["recognised"] is None for e in sensed)
            data["human_sensing"] = {
                "performed": len(sensed), "recognised": ok, "missed": missed,
                "false_reports": len(sensed) - ok - missed, "uncovered": uncovered,
            }  # fmt: skip
        else:
            told = sum(1 for e in events if e["type"] == "human_action")
            data["human_sensing"] = {
                "performed": told,
                "recognised": told,
                "missed": 0,
                "false_reports": 0,
            }
    data["human_sensing"] = {"mode": args.human_sensing, **data["human_sensing"]}
    return data


def _robot_actions(domain: Any) -> list[str]:
    """The actions a robot agent of ``domain`` can carry out (what --fail and --disturb name)."""
    out = []
    for name, schema in domain.actions.items():
        spec = schema.agents
        if spec.variable is not None:
            kind = dict(schema.parameters).get(spec.variable, "agent")
            agents = domain.agents_of_type(kind)
        else:
            agents = [domain.agents[n] for n in spec.names if n in domain.agents]
        if any(not a.is_human for a in agents):
            out.append(name)
    return sorted(out)


def _need_matplotlib() -> None:
    import importlib.util

    from flexhrc.errors import OptionalDependencyError

    if importlib.util.find_spec("matplotlib") is None:
        raise OptionalDependencyError("--plot", "viz", "matplotlib")


def cmd_run(args: argparse.Namespace) -> int:
    from flexhrc import scenario as scenario_mod
    from flexhrc.files import read_text
    from flexhrc.representation.formats.yaml_format import read_yaml
    from flexhrc.scenario.source import NAMES

    if args.scenario in NAMES and not Path(args.scenario).exists():  # as `cell`, `ros2` ...
        sc = scenario_mod.load_scenario(args.scenario, seed=args.seed, segments=args.segments)
        return _run_scenario(args, sc, sc.path or Path(args.scenario))
    path = scenario_mod.resolve(args.scenario)
    read_text(path)  # missing, a folder, unreadable, binary, not UTF-8: one clear error
    try:
        doc = read_yaml(path)
    except RecursionError:
        raise FormatError("nested too deeply to be a scenario file", path) from None
    if not isinstance(doc, dict):
        raise FormatError("a scenario file must be a mapping", path, 1)
    if "scenario" in doc and "flexhrc" not in doc:
        return _run_legacy(args, path, doc)
    if args.segments is not None:  # parts of a task, alike in every command
        sc = scenario_mod.load_scenario(path, seed=args.seed, segments=args.segments)
        return _run_scenario(args, sc, path)
    return _run_scenario(args, scenario_mod.load(path), path)


def _run_scenario(args: argparse.Namespace, sc: Any, path: Path) -> int:
    """A ``flexhrc: 1`` scenario file, end to end."""
    from flexhrc.files import EventLogWriter
    from flexhrc.scenario import prepare

    if args.human is not None and not sc.humans:
        raise FlexhrcError(f"--human {args.human} needs an operator, but {path} has no humans")
    if args.human_takes and not sc.humans:
        raise FlexhrcError(f"--human-takes needs an operator, but {path} has no humans")
    for k in args.human_takes or []:
        if k < 1:
            raise FlexhrcError(f"--human-takes {k}: steps are counted from 1")
    robot_actions = _robot_actions(sc.domain)
    failures = _failures(args.fail, robot_actions)
    check_outputs(
        [("--log", args.log, None), ("--plot", args.plot, PLOT_SUFFIXES)],
        inputs=[path, args.har_model],
    )
    if args.plot:
        _need_matplotlib()
    args.simulator = args.simulator or sc.simulator
    simulator, execution = _simulators(args, robot_actions)
    sensing = _human_sensing(args)
    writer = EventLogWriter(args.log) if args.log else None
    try:
        run = prepare(
            sc,
            profile=args.human,
            seed=args.seed,
            simulator=simulator,
            execution=execution,
            reaction=args.reaction,
            trace=_trace_printer(args),
            sink=writer.write if writer is not None else None,
            failures=failures,
            human_takes=args.human_takes,
            human_sensing=sensing,
            realtime=args.realtime or 0.0,
        )
        if args.perception == "scene":
            run = _perceived_like(args, run)
        with _stop_on_signals(run) as caught:
            result = run.run()
    finally:
        if writer is not None:
            writer.close()
    who = ", ".join(f"{name} {prof}" for name, prof in run.operator_profiles()) or "no operator"
    data = _with_sensing({"scenario": sc.name, **result.summary}, result.events, args)
    return _report(
        args, run, result, data, caught,
        title=f"{sc.name}, {who}, seed {args.seed}",
        subject=f"{sc.name}: ", solved_by=solved_by_line(data),
    )  # fmt: skip


def _run_legacy(args: argparse.Namespace, path: Path, doc: Any) -> int:
    """The older ``scenario: table_assembly`` files (the legs fix of one table, unless
    ``--segments`` says otherwise) and ``scenario: parallel_assembly`` files, translated by
    :func:`flexhrc.scenario.legacy.from_legacy`."""
    from flexhrc.scenario.legacy import from_legacy

    lines: dict[str, int] = getattr(doc, "lines", {})
    sc = from_legacy(path, doc, seed=args.seed, segments=args.segments)
    if sc.name != "table_assembly":
        return _run_scenario(args, sc, path)
    if args.human is not None and not sc.humans and args.human != "passive":
        raise FlexhrcError(
            f"--human {args.human} needs a human, but {path}:{lines.get('human')}: human: false"
        )
    where = f"{path}:{lines.get('human')}: " if "human" in doc else ""
    profile = sc.humans[0].profile if sc.humans else "passive"
    return _run_table(args, sc, args.human or profile, inputs=[path], where=where)


def cmd_replay(args: argparse.Namespace) -> int:
    from flexhrc.taskmanager.replay import summarise_log, table_i

    check_outputs([("--plot", args.plot, PLOT_SUFFIXES)], inputs=[args.log])
    if args.plot:
        _need_matplotlib()
    path = Path(args.log)
    events = _read_log(path)
    data = summarise_log(events)
    if args.plot:
        from flexhrc.files import atomic_output
        from flexhrc.taskmanager.timeline import plot_timeline

        with atomic_output(args.plot) as tmp:
            plot_timeline(events, tmp, f"replay of {args.log}")
    if not data["complete"]:
        progress(f"warning: {path}: {data['reason']}")

    def text() -> str:
        return "\n".join(
            [
                table_i(data),
                "",
                f"outcome {data['outcome']}"
                + (f" ({data['reason']})" if data["reason"] else "")
                + f"; {solved_by_line(data)}; {plural(data['decisions'], 'decision tree')}, "
                f"{plural(data['branches_simulated'], 'branch', 'branches')}; "
                f"{data['robot_actions']} robot and "
                f"{plural(data['human_actions'], 'human action')}",
            ]
        )

    emit(args, data, text)
    return 0


def _read_log(path: Path) -> list[dict[str, Any]]:
    from flexhrc.cell.store import is_store, store_log
    from flexhrc.jsonl import read_jsonl_lines
    from flexhrc.taskmanager.replay import check_log

    if is_store(path):  # a cell's SQLite event store (flexhrc cell --store FILE.db)
        return store_log(path)
    lines = read_jsonl_lines(path, required=("t", "type"))
    if not lines:
        raise FormatError("empty log", path)
    check_log(lines, path)
    return [ev for _, ev in lines]
