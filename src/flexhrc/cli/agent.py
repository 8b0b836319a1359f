"""``flexhrc agent robot|human SCENARIO``: one simulated agent of a cell, as its own process."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from flexhrc.cli.common import (
    TermFlag,
    add_seed_option,
    add_segments_option,
    add_simulator_option,
    add_transport_options,
    config_of,
    emit,
    progress,
    quiet_library_logs,
    serve_agent,
)
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
    r.add_argument("--arm", required=True, metavar="NAME", help="which arm (e.g. left)")
    r.add_argument(
        "--journal",
        metavar="FILE",
        help="keep the commands this arm started and finished (JSON lines), so a restarted "
        "agent process never executes a command id twice",
    )
    add_simulator_option(r, "the simulated world (default: the scenario's simulator)")
    _common(r)
    r.set_defaults(func=cmd_agent)
    h = asub.add_parser(
        "human",
        help="a simulated operator: follows suggestions and, unless passive, acts on its own",
    )
    h.add_argument("--name", required=True, metavar="NAME", help="which operator (e.g. human)")
    h.add_argument(
        "--profile",
        default="passive",
        metavar="PROFILE",
        help="passive (default: only when asked), takeover (takes every step it can), "
        "cooperative (takes one now and then), random (at random moments, random objects), "
        "reluctant (declines some requests, answers cannot to some actions); "
        "its choices are seeded by --seed",
    )
    _common(h)
    h.set_defaults(func=cmd_agent)
    e = asub.add_parser(
        "perception",
        help="the cell's perception: the head camera renders the simulated workspace after "
        "every action that changes it and sends percepts (sim and perception extras)",
    )
    _common(e)
    e.set_defaults(func=cmd_agent_perception)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("scenario", metavar="SCENARIO", help="the cell's scenario (name or file)")
    add_transport_options(p, default="zenoh")
    add_segments_option(p)
    add_seed_option(p, "scenario seed (same as the cell's)")
    p.add_argument("--quiet", action="store_true", help="no trace on stderr")
    p.add_argument(
        "--json", action="store_true", help="print a JSON summary on stdout when the cell ends"
    )


def cmd_agent(args: argparse.Namespace) -> int:
    quiet_library_logs()
    from flexhrc.cell.serve import AgentConfig, join_cell
    from flexhrc.scenario import load_scenario

    robot = args.agent_kind == "robot"
    config = config_of(
        AgentConfig,
        args,
        kind=args.agent_kind,
        name=args.arm if robot else args.name,
        simulator=args.simulator if robot else "auto",
        journal=args.journal if robot else None,
        profile="passive" if robot else args.profile,
    )
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    data = join_cell(
        scenario,
        config,
        trace=_say(args, config.name),
        progress=None if args.quiet else progress,
        until=TermFlag(),
    )
    if args.json:
        emit(args, data)
    return 0


def _say(args: argparse.Namespace, name: str) -> Any:
    def trace(line: str) -> None:
        if not args.quiet:
            print(f"[{name}] {line}", file=sys.stderr, flush=True)

    return trace


def cmd_agent_perception(args: argparse.Namespace) -> int:
    """``flexhrc agent perception SCENARIO --connect ENDPOINT``."""
    from flexhrc.cell.serve import zenoh_for_cell
    from flexhrc.scenario import load_scenario

    if not args.connect and not args.listen and not args.zenoh_config:
        raise FlexhrcError("--connect ENDPOINT is needed (the cell's --listen endpoint)")
    try:
        from flexhrc.sensing.agent import PerceptionAgent
    except ImportError as exc:
        raise FlexhrcError(
            f"agent perception needs the sim and perception extras ({exc.name} is missing): "
            "pip install 'flexhrc[sim,perception]'"
        ) from None
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)

    trace = _say(args, "perception")
    transport = zenoh_for_cell(
        args.cell,
        args.listen,
        args.connect,
        warn=None if args.quiet else progress,
        config_file=args.zenoh_config,
    )
    agent, _ = serve_agent(
        lambda: PerceptionAgent(scenario, transport, trace=trace),
        transport,
        trace,
        f"ready (cell {args.cell!r})",
    )
    if args.json:
        emit(args, agent.summary())
    return 0
