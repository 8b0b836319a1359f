"""``flexhrc cell SCENARIO``: the Task Manager as a service, agents inside or as processes."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

from flexhrc.cli.common import add_cell_options, add_json_flag, add_segments_option, emit
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager.replay import solved_by_line

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"


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
    p.add_argument("--seed", type=int, default=0, help="scenario seed (default 0)")
    from flexhrc.taskmanager.operator import PROFILES

    p.add_argument(
        "--human",
        choices=PROFILES,
        default="passive",
        metavar="PROFILE",
        help="how the internal simulated operators behave: passive (default), takeover, "
        "cooperative or random (external ones: `flexhrc agent human --profile`)",
    )
    p.add_argument("--quiet", action="store_true", help="no live trace")
    p.add_argument(
        "--ready-file",
        metavar="PATH",
        help="once the cell listens, write PATH (atomically): JSON with the endpoints it listens "
        "on as bound (`--listen tcp/127.0.0.1:0`: the port the system gave), its pid and name",
    )
    from flexhrc.cli.panel import add_web_options

    add_web_options(p)  # the operator panel (docs/panel.md)
    add_json_flag(p)
    p.set_defaults(func=cmd_cell)


def add_transport_options(p: argparse.ArgumentParser, *, default: str = "inprocess") -> None:
    if default == "inprocess":
        p.add_argument(
            "--transport",
            choices=["inprocess", "zenoh"],
            default="inprocess",
            help="message transport (default inprocess; zenoh for several processes)",
        )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"Zenoh endpoint to listen on (repeatable; default {DEFAULT_LISTEN} for the cell, "
        "a random loopback port for an agent)",
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to connect to (a router or the cell; repeatable)",
    )
    p.add_argument(
        "--cell",
        default="default",
        metavar="NAME",
        help="cell name: keys live under flexhrc/NAME/ (default 'default')",
    )


def quiet_library_logs() -> None:
    """The command's trace already shows every dropped message: keep the library's warnings
    (flexhrc.cell, flexhrc.transport) from printing them a second time."""
    import logging

    for name in ("flexhrc.cell", "flexhrc.transport"):
        logging.getLogger(name).addHandler(logging.NullHandler())


def open_zenoh(args: argparse.Namespace, *, listen_default: list[str]) -> Any:
    import re

    if not re.fullmatch(r"[A-Za-z0-9_\-]+", args.cell):
        raise FlexhrcError(f"--cell {args.cell!r}: letters, digits, '_' and '-' only")
    try:
        from flexhrc.transport.zenoh import ZenohTransport, normalise_endpoint, zenoh_config
    except ImportError as exc:
        raise FlexhrcError(
            "the zenoh transport needs the zenoh extra: pip install 'flexhrc[zenoh]'"
        ) from exc
    listen = args.listen or (listen_default if not args.connect else [])
    for ep in listen:
        proto, _, rest = normalise_endpoint(ep).partition("/")
        host = rest.rsplit(":", 1)[0].strip("[]")
        local = proto == "unixsock-stream" or host in ("127.0.0.1", "localhost", "::1")
        if not local and not getattr(args, "quiet", False):
            print(
                f"warning: --listen {ep}: reachable from other hosts; Zenoh's access control "
                "and TLS are not configured by flexhrc (docs/cell.md)",
                file=sys.stderr,
            )
    return ZenohTransport(
        zenoh_config(listen=listen, connect=args.connect), prefix=f"flexhrc/{args.cell}"
    )


def listening_on(transport: Any, configured: list[str]) -> list[str]:
    """The endpoints a Zenoh transport listens on as bound (a port 0 resolved), else as
    configured."""
    from flexhrc.transport.zenoh import normalise_endpoint

    if any(normalise_endpoint(ep).endswith(":0") for ep in configured):
        return list(transport.locators())
    return list(configured)


def write_ready_file(path: str, record: dict[str, Any]) -> None:
    """Write ``record`` as JSON to ``path`` atomically (a reader sees all of it or nothing)."""
    import json
    import os
    from pathlib import Path

    target = Path(path)
    tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(record) + "\n")
        os.replace(tmp, target)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise FlexhrcError(f"--ready-file {path}: cannot write it ({exc.strerror})") from None


def branch_simulator(choice: str, scenario: Any) -> Any:
    """The Task Manager's branch simulator for ``--simulator`` (the scenario may force one)."""
    from flexhrc.cell.components import execution_model

    return execution_model(choice, scenario)


def trace_line(ev: dict[str, Any]) -> str | None:
    kind = ev["type"]
    if kind == "command":
        line = f"{'+'.join(ev['agents']):<6} {ev['action']}  [cmd {ev['id']}]"
    elif kind == "ack":
        if ev["status"] == "done":
            return None
        line = f"cmd {ev['id']} {ev['status']}: {ev.get('reason')}"
    elif kind == "suggestion":
        line = f"ask {ev['agent']}: {ev['element']}: {'; '.join(ev['actions'])}"
    elif kind == "human_action":
        line = f"{ev['agent']} did {ev['action']}"
    elif kind == "decision":
        line = f"decide {ev['element']} (cost {ev['cost']}): {len(ev['branches'])} branches"
    elif kind == "agent_down":
        line = f"AGENT LOST: {ev['agent']}"
    elif kind == "agent_up":
        line = f"agent back: {ev['agent']}"
    elif kind == "dropped":
        line = f"dropped a message: {ev['reason']}"
    elif kind in ("abort", "action_failed", "infeasible"):
        line = f"{kind} {ev['element']}: {ev.get('reason')}"
    elif kind == "outcome":
        line = f"outcome: {str(ev['outcome']).upper()}" + (
            f" ({ev['reason']})" if ev.get("reason") else ""
        )
    else:
        return None
    return f"{ev['t']:8.2f}s  {line}"


def cmd_cell(args: argparse.Namespace) -> int:
    quiet_library_logs()
    from flexhrc.cell import Cell, EventStore, HumanAgent, RobotAgent
    from flexhrc.cell.components import execution_model
    from flexhrc.scenario import load_scenario
    from flexhrc.taskmanager.operator import operator_seed

    if not (math.isfinite(args.realtime) and args.realtime >= 0):
        raise FlexhrcError(f"--realtime must be a finite number >= 0, got {args.realtime}")
    if not (math.isfinite(args.wait) and args.wait > 0):
        raise FlexhrcError(f"--wait must be a positive number of seconds, got {args.wait}")
    if args.agents == "external" and args.transport != "zenoh":
        raise FlexhrcError("--agents external needs --transport zenoh")
    if args.transport == "inprocess" and (args.listen or args.connect):
        raise FlexhrcError("--listen and --connect go with --transport zenoh")
    if args.resume and not args.store:
        raise FlexhrcError("--resume needs --store FILE.db")
    if args.human != "passive" and args.agents == "external":
        raise FlexhrcError(
            "--human goes with --agents internal (an external operator has its own "
            "`flexhrc agent human --profile`)"
        )
    from flexhrc.cli.panel import check_web, serve

    web = check_web(args)  # a non-loopback --web without --token is refused before any work
    server = None
    scenario = load_scenario(args.scenario, seed=args.seed, segments=args.segments)
    store = EventStore(args.store, resume=args.resume) if args.store else None
    stream = sys.stderr if args.json else sys.stdout

    def progress(msg: str) -> None:
        if not args.quiet:
            print(msg, file=sys.stderr, flush=True)

    def trace(ev: dict[str, Any]) -> None:
        line = trace_line(ev)
        if line and not args.quiet:
            print(line, file=stream, flush=True)

    transport: Any
    try:
        if args.transport == "zenoh":
            transport = open_zenoh(args, listen_default=[DEFAULT_LISTEN])
        else:
            from flexhrc.transport import InProcessBus

            transport = InProcessBus()
        internal = args.agents == "internal"
        # in one process the manager's model of the robot and the arms' simulated world are one
        # object, as in `flexhrc run`: the manager plans from where the arms really are
        simulator = branch_simulator(args.simulator, scenario)
        cell = Cell(
            scenario,
            transport,
            store=store,
            resume=args.resume,
            realtime=args.realtime,
            ordered=True if internal else None,
            agent_speed=0.0 if internal else args.realtime,
            simulator=simulator,
            liveliness=args.transport == "zenoh",
            name=args.cell,
            trace=trace,
            seed=args.seed,
        )
        agents: list[Any] = []
        if internal:
            humans = [a.name for a in scenario.domain.agents.values() if a.is_human]
            # the arms of one process share one simulated world, as in `flexhrc run`: what the
            # follower of a joint command did, and where the other arm is, are in it
            world = simulator
            for a in scenario.domain.agents.values():
                if a.is_human:
                    human_model = execution_model("analytic", scenario)
                    operator = HumanAgent(
                        a.name,
                        scenario,
                        transport,
                        profile=args.human,
                        # seeded as `flexhrc run` seeds its operators: one seed, one cooperation
                        seed=operator_seed(args.seed, humans.index(a.name)),
                        execution=human_model,
                    )
                    agents.append(operator)
                else:
                    agents.append(RobotAgent(a.name, scenario, transport, execution=world))
            if args.transport == "inprocess":
                for st in cell.agents.values():
                    st.alive = st.seen = True
        if web is not None:  # polled by the loop like an agent; with external agents it is
            from flexhrc.web.live import CellPanel  # the operator (holds their tokens)

            agents.append(CellPanel(cell, operator=not internal))
            server = serve(web, args.token, agents[-1])

        def pump(timeout: float) -> None:
            wait = getattr(transport, "wait", None)
            if wait is not None and not (internal and transport.pending()):
                wait(timeout)
            delivered = transport.flush()
            for agent in agents:
                agent.poll()
            if wait is None and not delivered:
                time.sleep(0.001)  # nothing moved (e.g. waiting for a resend): do not spin

        endpoints: list[str] = []
        if args.transport == "zenoh":
            configured = args.listen or ([] if args.connect else [DEFAULT_LISTEN])
            endpoints = listening_on(transport, configured)
            where = ", ".join(endpoints)
            progress(
                f"cell {args.cell!r} on zenoh"
                + (f", listening on {where}" if where else "")
                + (f", connected to {', '.join(args.connect)}" if args.connect else "")
            )
        if args.ready_file:  # the manager's subscriptions and token are declared: agents may come
            import os

            write_ready_file(
                args.ready_file, {"listen": endpoints, "pid": os.getpid(), "cell": args.cell}
            )
        data = cell.run(pump=pump, agents_timeout=args.wait, progress=progress)
        for agent in agents:
            agent.close()
        cell.close()
        if args.transport == "zenoh":
            time.sleep(0.2)  # let the end message leave before the session closes
    finally:
        if server is not None:
            server.stop(grace=0.3)  # the page gets the last state first
        if store is not None:
            store.close()
        if "transport" in locals():
            transport.close()

    def text() -> str:
        out = [
            f"outcome {data['outcome']}"
            + (f" ({data['reason']})" if data["reason"] else "")
            + f"; {solved_by_line(data)}; {data['decisions']} decision trees; "
            f"{data['robot_actions']} robot and {data['human_actions']} human actions; "
            f"{data['cell']['events']} events"
            + (f" in {args.store}" if args.store else "")
            + (
                f"; {data['cell']['dropped']} malformed messages dropped"
                if data["cell"]["dropped"]
                else ""
            )
        ]
        return "\n".join(out)

    emit(args, data, text)
    return 0 if data["outcome"] == "solved" else 1
