"""``flexhrc demo table``, ``flexhrc run SCENARIO.yaml`` and ``flexhrc replay LOG``."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from flexhrc.cli.common import add_json_flag, emit
from flexhrc.errors import FlexhrcError, FormatError

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
    "inconsistent",
    "consistent_again",
    "repair",
    "repaired",
    "operator_answers",
    "operator_nudges",
    "false_report",
    "stop",
}


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

    r = sub.add_parser("run", help="run a user-written scenario file (YAML)")
    r.add_argument("scenario", metavar="SCENARIO.yaml")
    _run_options(r)
    r.set_defaults(func=cmd_run)

    rp = sub.add_parser("replay", help="print the summary of a saved cooperation log (JSONL)")
    rp.add_argument("log", metavar="LOG")
    rp.add_argument("--plot", metavar="FILE", help="draw the timeline PNG from the log")
    add_json_flag(rp)
    rp.set_defaults(func=cmd_replay)


def _scenario_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--legs", type=int, default=4, help="number of legs (default 4)")
    p.add_argument("--tabletop", choices=["large", "small"], default="large")
    p.add_argument("--leg-length", choices=["long", "short"], default="long")
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
    from flexhrc.taskmanager.runner import PROFILES

    p.add_argument("--human", choices=PROFILES, default=None, help="human operator profile")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--human-takes",
        type=int,
        action="append",
        default=None,
        metavar="K",
        help="script the operator: it takes bolt K (repeatable), whatever the profile",
    )
    p.add_argument(
        "--fail",
        action="append",
        default=[],
        metavar="ACTION[:N]",
        help="inject a failure of the N-th robot ACTION (e.g. transport:1)",
    )
    p.add_argument(
        "--simulator",
        choices=["auto", "analytic", "kinematic"],
        default="auto",
        help="how branches are simulated: kinematic (task-priority control on the robot model; "
        "the default when the sim extra is installed) or analytic (distances and speeds)",
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
        "scene perception of the head camera's depth images (sim and perception extras)",
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
    p.add_argument("--log", metavar="FILE", help="write the event log (JSON lines)")
    p.add_argument("--plot", metavar="FILE", help="write the timeline PNG")
    p.add_argument("--quiet", action="store_true", help="no live trace")
    p.add_argument(
        "--realtime",
        type=float,
        nargs="?",
        const=1.0,
        default=0.0,
        metavar="SPEED",
        help="pace the simulated clock for watching: real time, or SPEED times faster",
    )
    add_json_flag(p)


def _simulators(args: argparse.Namespace) -> tuple[Any, Any]:
    """(branch simulator, execution model) for --simulator and --disturb."""
    choice = args.simulator
    if choice == "auto":
        import importlib.util

        choice = "kinematic" if importlib.util.find_spec("pinocchio") else "analytic"
    if choice == "analytic":
        if args.disturb:
            raise FlexhrcError("--disturb needs --simulator kinematic (use --fail with analytic)")
        return None, None
    try:
        from flexhrc.action.bridge import KinematicTaskSimulator

        kin = KinematicTaskSimulator()
    except ImportError as exc:
        raise FlexhrcError(
            f"--simulator kinematic needs the sim extra ({exc.name} is missing): "
            "pip install 'flexhrc[sim]'"
        ) from None
    for spec in args.disturb:
        kind, _, rest = spec.partition(":")
        action, _, n = rest.partition(":")
        if kind not in ("blocked_path", "slow_arm"):
            raise FlexhrcError(f"--disturb {spec!r}: KIND is blocked_path or slow_arm")
        try:
            nth = int(n) if n else 1
        except ValueError:
            raise FlexhrcError(f"--disturb {spec!r}: N must be a whole number") from None
        params: dict[str, Any] = {"kind": kind, "once": True, "at_s": 0.3}
        if kind == "slow_arm":
            params.update(factor=0.2, at_s=None)
        kin.schedule(action or "transport", nth, **params)
    return kin, kin


def _check_perception_options(args: argparse.Namespace) -> None:
    """Option combinations, checked before any work."""
    if args.human_sensing == "har-real" and not args.hmp:
        raise FlexhrcError("--human-sensing har-real needs --hmp DIR (the HMP dataset folder)")
    if args.hmp and args.human_sensing != "har-real":
        raise FlexhrcError("--hmp goes with --human-sensing har-real")
    if args.hmp and not Path(args.hmp).is_dir():
        raise FlexhrcError(f"--hmp {args.hmp}: not a directory")
    if args.repair and args.perception != "scene":
        raise FlexhrcError("--repair needs --perception scene (only perception notices)")


def _human_sensing(args: argparse.Namespace) -> Any:
    _check_perception_options(args)
    if args.human_sensing == "har-real":
        if args.har_model:
            raise FlexhrcError(
                "--har-model goes with --human-sensing har (har-real trains its own model on "
                "other volunteers than those it replays)"
            )
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


def _failures(specs: list[str]) -> list[Any]:
    from flexhrc.taskmanager.runner import InjectedFailure

    out = []
    for spec in specs:
        action, _, n = spec.partition(":")
        try:
            out.append(InjectedFailure(action, int(n) if n else 1))
        except ValueError:
            raise FlexhrcError(f"--fail {spec!r}: expected ACTION or ACTION:N") from None
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
            line = f"decide {ev['element']} (cost {ev['cost']}): {n} branches simulated"
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
            line = f"human goes for {ev['leg']} ({ev['bolt']})"
        elif kind == "human_gives_up":
            what = ev.get("leg") or ev.get("bolt")
            line = f"human leaves {what}: the {ev['holder']} got there first"
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


def _perceived(args: argparse.Namespace, scenario: Any, run_kw: dict[str, Any]) -> Any:
    """The run with the head camera, the scene pipeline and anchoring in the loop."""
    from dataclasses import replace

    from flexhrc.representation import OnlineGraph

    try:
        from flexhrc.sensing.run import lying_layout
        from flexhrc.sensing.setup import perceived_run
    except ImportError as exc:
        raise FlexhrcError(
            f"--perception scene needs the sim and perception extras ({exc.name} is missing): "
            "pip install 'flexhrc[sim,perception]'"
        ) from None
    if scenario.leg_positions is None:
        # the parts are bodies the camera sees: lay them out clear of each other
        from flexhrc.scenarios.table_assembly import LEG_LENGTHS, TABLETOPS

        scenario = replace(
            scenario,
            leg_positions=lying_layout(
                scenario.legs,
                scenario.seed,
                tabletop_depth=TABLETOPS[scenario.tabletop][1],
                length=LEG_LENGTHS[scenario.leg_length],
            ),
        )
    if not args.quiet:
        print("perception: head camera, scene pipeline, anchoring ...", file=sys.stderr)
    return perceived_run(
        OnlineGraph(scenario.graph()),
        scenario.domain(),
        scenario.knowledge(),
        repair=args.repair,
        **run_kw,
    )


def cmd_demo_table(args: argparse.Namespace) -> int:
    from flexhrc.scenarios.table_assembly import TableScenario

    scenario = TableScenario(
        legs=args.legs,
        tabletop=args.tabletop,
        leg_length=args.leg_length,
        seed=args.seed,
        human=not args.no_human,
        unreachable_bolts=tuple(args.unreachable_bolt),
    )
    return _run_table(args, scenario, args.human or "passive")


def _run_table(args: argparse.Namespace, scenario: Any, profile: str) -> int:
    from flexhrc.representation import OnlineGraph
    from flexhrc.taskmanager.runner import CooperationRun, table_i

    if not scenario.human and profile != "passive":
        raise FlexhrcError("--human needs a human: drop --no-human")
    simulator, execution = _simulators(args)
    run_kw: dict[str, Any] = dict(
        simulator=simulator,
        execution=execution,
        human_profile=profile,
        seed=args.seed,
        failures=_failures(args.fail),
        trace=_trace_printer(args),
        realtime=args.realtime,
        human_takes=args.human_takes,
        human_sensing=_human_sensing(args),
    )
    run: Any
    if args.perception == "scene":
        run = _perceived(args, scenario, run_kw)
    else:
        run = CooperationRun(
            OnlineGraph(scenario.graph()), scenario.domain(), scenario.knowledge(), **run_kw
        )
    result = run.run()
    if args.log:
        result.save_log(args.log)
    if args.plot:
        from flexhrc.taskmanager.timeline import plot_timeline

        who = f"human takes bolts {args.human_takes}" if args.human_takes else f"human {profile}"
        title = f"table assembly, {scenario.legs} legs, {who}, seed {args.seed}"
        plot_timeline(result.events, args.plot, title)
    data = dict(result.summary)

    def text() -> str:
        out = ["", table_i(data), ""]
        legs = ", ".join(f"{a}: {n}" for a, n in data["legs_by_agent"].items())
        out.append(
            f"outcome {data['outcome']}"
            + (f" ({data['reason']})" if data["reason"] else "")
            + f"; legs connected by {legs}; {data['decisions']} decision trees, "
            f"{data['branches_simulated']} branches simulated; "
            f"{data['robot_actions']} robot and {data['human_actions']} human actions"
        )
        if args.log:
            out.append(f"event log: {args.log}")
        if args.plot:
            out.append(f"timeline: {args.plot}")
        return "\n".join(out)

    emit(args, data, text)
    return 0 if data["outcome"] == "solved" else 1


def cmd_run(args: argparse.Namespace) -> int:
    from flexhrc.representation.formats.yaml_format import read_yaml
    from flexhrc.scenarios.table_assembly import TableScenario

    path = Path(args.scenario)
    if not path.is_file():
        raise FormatError("no such file", path)
    doc = read_yaml(path)
    if not isinstance(doc, dict):
        raise FormatError("a scenario file must be a mapping", path, 1)
    kind = doc.get("scenario")
    if kind != "table_assembly":
        raise FormatError(
            f"unknown scenario {kind!r}; supported: table_assembly",
            path,
            getattr(doc, "lines", {}).get("scenario", 1),
        )
    allowed = {
        "scenario",
        "legs",
        "tabletop",
        "leg_length",
        "seed",
        "human",
        "unreachable_bolts",
        "leg_positions",
        "profile",
        "reachable_only_by",
    }
    for key in doc:
        if key not in allowed:
            raise FormatError(
                f"unknown key {key!r} (allowed: {', '.join(sorted(allowed))})",
                path,
                doc.lines.get(key) if hasattr(doc, "lines") else None,
            )
    try:
        scenario = TableScenario(
            legs=int(doc.get("legs", 4)),
            tabletop=str(doc.get("tabletop", "large")),
            leg_length=str(doc.get("leg_length", "long")),
            seed=int(doc.get("seed", args.seed)),
            human=bool(doc.get("human", True)),
            unreachable_bolts=tuple(int(b) for b in doc.get("unreachable_bolts", [])),
            reachable_only_by=dict(doc.get("reachable_only_by", {})),
            leg_positions=[_xyz(p) for p in doc["leg_positions"]]
            if "leg_positions" in doc
            else None,
        )
    except (TypeError, ValueError) as exc:
        raise FormatError(f"bad value: {exc}", path) from None
    profile = args.human or str(doc.get("profile", "passive"))
    return _run_table(args, scenario, profile)


def _xyz(p: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in p)
    return (x, y, z)


def cmd_replay(args: argparse.Namespace) -> int:
    from flexhrc.taskmanager.replay import summarise_log
    from flexhrc.taskmanager.runner import table_i

    events = _read_log(Path(args.log))
    data = summarise_log(events)
    if args.plot:
        from flexhrc.taskmanager.timeline import plot_timeline

        plot_timeline(events, args.plot, f"replay of {args.log}")

    def text() -> str:
        legs = ", ".join(f"{a}: {n}" for a, n in data["legs_by_agent"].items())
        return "\n".join(
            [
                table_i(data),
                "",
                f"outcome {data['outcome']}; legs connected by {legs}; "
                f"{data['decisions']} decision trees, {data['branches_simulated']} branches; "
                f"{data['robot_actions']} robot and {data['human_actions']} human actions",
            ]
        )

    emit(args, data, text)
    return 0


def _read_log(path: Path) -> list[dict[str, Any]]:
    from flexhrc.jsonl import read_jsonl

    events = read_jsonl(path, required=("t", "type"))
    if not events:
        raise FormatError("empty log", path)
    return events
