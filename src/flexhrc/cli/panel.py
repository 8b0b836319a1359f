"""``flexhrc panel [SCENARIO]``: a cooperation in this process, the operator at the browser panel.

Only translates arguments into a :class:`flexhrc.web.local.PanelConfig`, calls
:func:`flexhrc.web.serve_panel` and prints its report. Also the ``--web HOST:PORT [--token T]``
options other commands (``flexhrc cell``) share: :func:`add_web_options`, :func:`check_web`.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import Any

from flexhrc.cli.common import (
    add_json_flag,
    add_seed_option,
    add_segments_option,
    add_simulator_option,
    emit,
    trace_printer,
)
from flexhrc.errors import FlexhrcError


def add_web_options(p: argparse.ArgumentParser, *, required: bool = False) -> None:
    from flexhrc.web.server import DEFAULT_ADDRESS

    p.add_argument(
        "--web",
        metavar="HOST:PORT",
        nargs="?",
        const=DEFAULT_ADDRESS,
        default=DEFAULT_ADDRESS if required else None,
        help=f"serve the operator panel (default {DEFAULT_ADDRESS}; an address other than "
        "loopback needs --token)",
    )
    p.add_argument(
        "--token",
        metavar="T",
        default=None,
        help="secret every panel request must carry (?token=T, Authorization: Bearer T)",
    )


def check_web(args: argparse.Namespace) -> tuple[str, int] | None:
    """``--web``/``--token`` checked before any work: the address, or None without ``--web``."""
    if getattr(args, "web", None) is None:
        if getattr(args, "token", None) is not None:
            raise FlexhrcError("--token is only used with --web")
        return None
    from flexhrc.web.server import check_bind, parse_web_address

    host, port = parse_web_address(args.web)
    check_bind(host, args.token)
    return host, port


def run_cell(
    args: argparse.Namespace,
    start: Callable[[Any, list[Any], list[Any]], dict[str, Any]],
    *,
    operator: bool,
) -> dict[str, Any]:
    """Run a cell as ``flexhrc cell`` and ``flexhrc ros2 cell`` do: ``start(trace, attach,
    servers)`` runs it with the live trace (None under ``--quiet``; on stderr under ``--json``)
    and, with ``--web``, the operator panel attached (``operator``: the page stands in for the
    scenario's operators, their tokens); ``servers`` holds the panel's server once it listens.
    ``--web``/``--token`` are checked before ``start``; the panel gets the last state, then
    stops."""
    from flexhrc.cell.serve import trace_line

    web = check_web(args)  # a non-loopback --web without --token is refused before any work
    servers: list[Any] = []

    def panel(cell: Any) -> Any:  # polled by the cell's loop like an agent
        from flexhrc.web.live import CellPanel
        from flexhrc.web.server import PanelServer

        assert web is not None  # attached only with --web
        backend = CellPanel(cell, operator=operator)
        servers.append(PanelServer(backend, web[0], web[1], token=args.token).start())
        servers[-1].announce()  # its address, on stderr
        return backend

    try:
        return start(trace_printer(args, trace_line), [panel] if web else [], servers)
    finally:
        for server in servers:
            server.stop(grace=0.3)  # the page gets the last state first


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "panel",
        help="a scenario in this process with the operator at the browser panel",
        description="Runs a cooperation in this process — the cell's loop, simulated arms on "
        "the wall clock — and the operator takes part only through the panel (open the printed "
        "address). SCENARIO is a name or a file, as for `flexhrc run` and `flexhrc cell`.",
    )
    p.add_argument(
        "scenario",
        metavar="SCENARIO",
        nargs="?",
        default="table_assembly",
        help="a shipped scenario's name or a scenario file (default table_assembly)",
    )
    p.add_argument(
        "--legs",
        type=int,
        default=None,
        help="the table's legs fix with this many legs (the file `scenario: table_assembly` "
        "with `legs: N`; table only)",
    )
    p.add_argument(
        "--unreachable-bolt",
        type=int,
        action="append",
        default=[],
        metavar="K",
        help="the table's legs fix, no arm reaching bolt K: the robot asks the operator "
        "(paper Fig. 12; table only)",
    )
    add_seed_option(p, "scenario seed (default 0)")
    add_segments_option(p)
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="simulated seconds per second for the arms (default 1: real time)",
    )
    add_simulator_option(
        p, "branch simulator and the arms' simulated world (default: the scenario's)"
    )
    p.add_argument("--store", metavar="FILE.db", help="keep every event in this SQLite file")
    p.add_argument(
        "--exit-when-done",
        action="store_true",
        help="stop serving when the cooperation ends (default: serve until Ctrl-C)",
    )
    add_web_options(p, required=True)
    add_json_flag(p)
    p.set_defaults(func=cmd_panel)


def panel_config(args: argparse.Namespace) -> Any:
    """The :class:`~flexhrc.web.local.PanelConfig` the arguments describe (checked)."""
    from flexhrc.web.local import PanelConfig, check_speed, table_legs

    check_speed(args.speed, "--speed")
    if args.web is None:
        raise FlexhrcError("--web needs an address, e.g. --web 127.0.0.1:8080")
    host, port = check_web(args) or ("", 0)
    scenario: Any = args.scenario
    if args.legs is not None or args.unreachable_bolt:
        if args.scenario not in ("table_assembly", "table"):
            raise FlexhrcError(
                "--legs and --unreachable-bolt choose the table's legs fix: "
                f"give them without SCENARIO (or with table_assembly), not with {args.scenario!r}"
            )
        scenario = table_legs(
            4 if args.legs is None else args.legs,
            unreachable_bolts=tuple(args.unreachable_bolt),
            seed=args.seed,
            segments=args.segments,
        )
    return PanelConfig(
        scenario=scenario,
        seed=args.seed,
        segments=None if scenario is not args.scenario else args.segments,
        speed=args.speed,
        simulator=args.simulator,
        host=host,
        port=port,
        token=args.token,
        store=args.store,
    )


def cmd_panel(args: argparse.Namespace) -> int:
    import flexhrc.planning.policies  # noqa: F401  (a stored lookahead run resumes with it)
    from flexhrc.web.local import serve_panel

    panel = serve_panel(panel_config(args))
    try:
        assert panel.server is not None
        panel.server.announce()
        while not panel.wait(0.5):
            pass
        report = panel.report()
        print(
            f"cooperation {report.outcome}" + (f": {report.reason}" if report.reason else ""),
            file=sys.stderr,
            flush=True,
        )
        if not args.exit_when_done:
            print("panel: still serving; Ctrl-C to stop", file=sys.stderr, flush=True)
            while True:
                time.sleep(3600)
    finally:
        panel.close()
        if panel.done:
            report = panel.report()
            emit(args, report.to_dict(), f"outcome: {report.outcome}")
    return 0 if panel.cell.tm.outcome == "solved" else 1
