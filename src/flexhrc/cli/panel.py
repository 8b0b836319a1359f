"""``flexhrc panel``: the table assembly in this process, the operator at the browser panel.

Also the ``--web HOST:PORT [--token T]`` options other commands (``flexhrc cell``) share:
:func:`add_web_options` and :func:`start_panel`.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from flexhrc.cli.common import add_json_flag, add_segments_option, emit
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


def serve(address: tuple[str, int], token: str | None, backend: Any) -> Any:
    """Start the panel for ``backend`` on a server thread; prints its address on stderr."""
    from flexhrc.web.server import PanelServer

    server = PanelServer(backend, address[0], address[1], token=token).start()
    server.announce()
    return server


def start_panel(args: argparse.Namespace, backend: Any) -> Any:
    """Start the panel server for ``--web`` (None when not asked); checks the address first."""
    address = check_web(args)
    return None if address is None else serve(address, args.token, backend)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "panel",
        help="the table assembly with the operator at the browser panel (one process)",
        description="Runs the cooperative table assembly in this process with simulated arms; "
        "the operator takes part only through the panel (open the printed address).",
    )
    p.add_argument("--legs", type=int, default=4, help="number of legs (default 4)")
    p.add_argument(
        "--unreachable-bolt",
        type=int,
        action="append",
        default=[],
        metavar="K",
        help="no arm reaches bolt K: the robot asks the operator (paper Fig. 12)",
    )
    p.add_argument("--seed", type=int, default=0)
    add_segments_option(p)
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="simulated seconds per second for the arms (default 1: real time)",
    )
    p.add_argument(
        "--exit-when-done",
        action="store_true",
        help="stop serving when the cooperation ends (default: serve until Ctrl-C)",
    )
    add_web_options(p, required=True)
    add_json_flag(p)
    p.set_defaults(func=cmd_panel)


def cmd_panel(args: argparse.Namespace) -> int:
    from flexhrc.web.local import table_assembly

    if not (args.speed > 0 and args.speed < float("inf")):
        raise FlexhrcError(f"--speed must be a positive number, got {args.speed}")
    if args.legs < 1:
        raise FlexhrcError(f"--legs must be at least 1, got {args.legs}")
    for bolt in args.unreachable_bolt:
        if not 1 <= bolt <= args.legs:
            raise FlexhrcError(f"--unreachable-bolt {bolt}: choose a bolt 1..{args.legs}")
    if args.web is None:
        raise FlexhrcError("--web needs an address, e.g. --web 127.0.0.1:8080")
    backend = table_assembly(
        args.legs,
        seed=args.seed,
        unreachable_bolts=tuple(args.unreachable_bolt),
        segments=args.segments,
        speed=args.speed,
    )
    server = start_panel(args, backend)
    try:
        backend.start()
        while not backend.wait_done(0.5):
            pass
        snap = backend.snapshot()
        print(
            f"cooperation {snap['outcome']}" + (f": {snap['reason']}" if snap["reason"] else ""),
            file=sys.stderr,
            flush=True,
        )
        if not args.exit_when_done:
            print("panel: still serving; Ctrl-C to stop", file=sys.stderr, flush=True)
            while True:
                time.sleep(3600)
    finally:
        if server is not None:
            server.stop()
        backend.close()
        if backend.tm.done:
            snap = backend.snapshot()
            emit(
                args,
                {"outcome": snap["outcome"], "reason": snap["reason"], "events": snap["events"]},
                f"outcome: {snap['outcome']}",
            )
    return 0 if backend.tm.outcome == "solved" else 1
