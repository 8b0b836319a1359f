"""``flexhrc cell SCENARIO``: the Task Manager as a service, agents inside or as processes."""

from __future__ import annotations

import argparse
from typing import Any

from flexhrc.cli.common import (
    add_cell_options,
    add_json_flag,
    add_seed_option,
    add_segments_option,
    add_transport_options,
    config_of,
    emit,
    progress,
    quiet_library_logs,
)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "cell",
        help="run a live cell: the Task Manager as a service, agents inside or as processes",
        description="Run a cooperation as a cell (docs/cell.md). Default: one process, the "
        "in-process bus, simulated agents inside. With --transport zenoh --agents external the "
        "manager waits for `flexhrc agent robot|human` processes. --store keeps every event in "
        "a SQLite file; --resume continues a crashed cell from it.",
    )
    p.add_argument("scenario", metavar="SCENARIO", help="table_assembly, or a scenario file")
    add_segments_option(p)
    add_transport_options(p)
    p.add_argument(
        "--agents",
        choices=["internal", "external"],
        default="internal",
        help="simulated agents inside this process (default) or as their own processes",
    )
    add_cell_options(
        p,
        wait_s=30.0,
        waits_for="external agents",
        simulator_help="branch simulator and, for internal agents, the simulated world",
        realtime_type=float,  # checked by the cell, which names the option
    )
    add_seed_option(p, "scenario seed (default 0)")
    from flexhrc.taskmanager.operator import PROFILES

    p.add_argument(
        "--human",
        choices=PROFILES,
        default="passive",
        metavar="PROFILE",
        help="how the internal simulated operators behave: passive (default), takeover, "
        "cooperative or random (external ones: `flexhrc agent human --profile`)",
    )
    p.add_argument(
        "--operators",
        metavar="FILE",
        help="an operator model (flexhrc learn STORE... -o FILE; docs/operators.md): each "
        "person's steps are timed by what they took before, and updated as they act",
    )
    p.add_argument("--quiet", action="store_true", help="no live trace")
    p.add_argument(
        "--ready-file",
        metavar="PATH",
        help="once the cell listens, write PATH (atomically): JSON with the endpoints it listens "
        "on as bound (`--listen tcp/127.0.0.1:0`: the port the system gave), its pid and name "
        "(and with --web the panel's address, its port as bound)",
    )
    from flexhrc.cli.panel import add_web_options

    add_web_options(p)  # the operator panel (docs/panel.md)
    add_json_flag(p)
    p.set_defaults(func=cmd_cell)


def cmd_cell(args: argparse.Namespace) -> int:
    quiet_library_logs()
    import flexhrc.planning.policies  # noqa: F401  (registers --policy lookahead)
    from flexhrc.cell.serve import CellConfig, serve_cell, summary_line
    from flexhrc.cli.panel import run_cell
    from flexhrc.scenario import load_scenario

    config = config_of(CellConfig, args)

    def start(trace: Any, attach: list[Any], servers: list[Any]) -> dict[str, Any]:
        scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
        return serve_cell(
            scenario,
            config,
            trace=trace,
            progress=None if args.quiet else progress,
            attach=attach,
            # the panel's address as bound (--web 127.0.0.1:0), without the token
            ready_extra=lambda: {"web": servers[0].address} if servers else {},
        )

    # with external agents the panel is the operator (holds their tokens)
    data = run_cell(args, start, operator=config.agents == "external")
    emit(args, data, lambda: summary_line(data, args.store))
    if data["cell"].get("store_lost"):  # said even under --quiet: the run cannot be resumed
        progress(f"warning: {data['cell']['store_lost']}")
    return 0 if data["outcome"] == "solved" else 1
