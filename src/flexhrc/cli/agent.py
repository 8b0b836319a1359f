"""``flexhrc agent robot|human SCENARIO``: one simulated agent of a cell, as its own process."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from flexhrc.cli.cell import add_transport_options, open_zenoh, quiet_library_logs
from flexhrc.cli.common import add_segments_option, emit, serve_agent
from flexhrc.errors import FlexhrcError


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "agent",
        help="run one simulated agent of a cell (a robot arm or an operator) as a process",
        description="A simulated agent that joins a cell over Zenoh (docs/cell.md): it declares "
        "its liveliness token, executes what the cell sends and exits when the cell ends.",
    )
    asub = p.add_subparsers(dest="agent_kind", metavar="KIND", required=True)
    r = asub.add_parser("robot", help="a simulated robot arm (kinematic simulator)")
    r.add_argument("scenario", metavar="SCENARIO", help="the cell's scenario (name or file)")
    r.add_argument("--arm", required=True, metavar="NAME", help="which arm (e.g. left)")
    r.add_argument(
        "--journal",
        metavar="FILE",
        help="keep the commands this arm started and finished (JSON lines), so a restarted "
        "agent process never executes a command id twice",
    )
    r.add_argument(
        "--simulator",
        choices=["auto", "analytic", "kinematic"],
        default="auto",
        help="the simulated world (default: the scenario's simulator)",
    )
    _common(r)
    r.set_defaults(func=cmd_agent)
    h = asub.add_parser(
        "human",
        help="a simulated operator: follows suggestions and, unless passive, acts on its own",
    )
    h.add_argument("scenario", metavar="SCENARIO", help="the cell's scenario (name or file)")
    h.add_argument("--name", required=True, metavar="NAME", help="which operator (e.g. human)")
    h.add_argument(
        "--profile",
        default="passive",
        metavar="PROFILE",
        help="passive (default: only when asked), takeover (takes every step it can), "
        "cooperative (takes one now and then), random (at random moments, random objects); "
        "its choices are seeded by --seed",
    )
    _common(h)
    h.set_defaults(func=cmd_agent)
    e = asub.add_parser(
        "perception",
        help="the cell's perception: the head camera renders the simulated workspace after "
        "every action that changes it and sends percepts (sim and perception extras)",
    )
    e.add_argument("scenario", metavar="SCENARIO")
    _common(e)
    e.set_defaults(func=cmd_agent_perception)


def _common(p: argparse.ArgumentParser) -> None:
    add_transport_options(p, default="zenoh")
    add_segments_option(p)
    p.add_argument("--seed", type=int, default=0, help="scenario seed (same as the cell's)")
    p.add_argument("--quiet", action="store_true", help="no trace on stderr")
    p.add_argument(
        "--json", action="store_true", help="print a JSON summary on stdout when the cell ends"
    )


def cmd_agent(args: argparse.Namespace) -> int:
    quiet_library_logs()
    from flexhrc.cell import HumanAgent, RobotAgent
    from flexhrc.cell.components import check_agent_name, execution_model
    from flexhrc.scenario import load_scenario

    if not args.connect and not args.listen:
        raise FlexhrcError("--connect ENDPOINT is needed (the cell's --listen endpoint)")
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    name = args.arm if args.agent_kind == "robot" else args.name

    def trace(line: str) -> None:
        if not args.quiet:
            print(f"[{name}] {line}", file=sys.stderr, flush=True)

    # check the names before opening the network
    opt = "--arm" if args.agent_kind == "robot" else "--name"
    check_agent_name(scenario.domain, name, args.agent_kind, opt)
    if args.agent_kind == "human":
        from flexhrc.cell.components import check_profile

        check_profile(args.profile)
    if getattr(args, "journal", None):
        from flexhrc.files import check_output

        check_output(args.journal, option="--journal")
    transport = open_zenoh(args, listen_default=[])

    def make() -> Any:
        if args.agent_kind == "robot":
            return RobotAgent(
                name,
                scenario,
                transport,
                execution=execution_model(args.simulator, scenario),
                trace=trace,
                journal=args.journal,
            )
        return HumanAgent(
            name,
            scenario,
            transport,
            profile=args.profile,
            seed=args.seed,
            execution=execution_model("analytic", scenario),
            trace=trace,
        )

    agent, outcome = serve_agent(
        make, transport, trace, f"ready ({args.agent_kind}, cell {args.cell!r})"
    )
    data = {
        "agent": name,
        "kind": args.agent_kind,
        "outcome": outcome,
        "received": agent.received,
        "dropped": agent.dropped,
        "executed": list(getattr(agent, "executed", [])),
    }
    if args.json:
        emit(args, data)
    return 0


def cmd_agent_perception(args: argparse.Namespace) -> int:
    """``flexhrc agent perception SCENARIO --connect ENDPOINT``."""
    from flexhrc.scenario import load_scenario

    if not args.connect and not args.listen:
        raise FlexhrcError("--connect ENDPOINT is needed (the cell's --listen endpoint)")
    try:
        from flexhrc.sensing.agent import PerceptionAgent
    except ImportError as exc:
        raise FlexhrcError(
            f"agent perception needs the sim and perception extras ({exc.name} is missing): "
            "pip install 'flexhrc[sim,perception]'"
        ) from None
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)

    def trace(line: str) -> None:
        if not args.quiet:
            print(f"[perception] {line}", file=sys.stderr, flush=True)

    transport = open_zenoh(args, listen_default=[])
    agent, _ = serve_agent(
        lambda: PerceptionAgent(scenario, transport, trace=trace),
        transport,
        trace,
        f"ready (cell {args.cell!r})",
    )
    if args.json:
        emit(args, agent.summary())
    return 0
