"""``flexhrc behave TASK --robots N [--transport inprocess|zenoh]``: several robots, one task.

In process (the default): every robot's network and the peer bus tick together on one simulated
clock (deterministic). Over Zenoh: one OS process per robot on 127.0.0.1 (multicast scouting
off; robot1 listens on a free port, the others connect to it), each paced at ``--realtime``
SPEED (default 10) x wall time; a robot whose process dies is seen as lost through its Zenoh
liveliness token, and the others finish the task. The parent process starts the robots, waits
for them and checks the merged runs (times taken from each process's wall clock, so they
compare across processes).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from flexhrc.cli.common import emit, log
from flexhrc.errors import FlexhrcError

DEFAULT_TEAM_SPEED = 10.0
BARRIER_TIMEOUT_S = 30.0


def robot_log_path(path: str, robot: str) -> str:
    """``run.jsonl`` -> ``run.robot1.jsonl``: one streamed log per robot."""
    p = Path(path)
    return str(p.with_name(f"{p.stem}.{robot}{p.suffix}"))


def run_team_command(args: argparse.Namespace) -> int:
    if args.robot is not None:
        return _robot_process(args)
    if args.transport == "zenoh":
        return _spawn_team(args)
    return _in_process(args)


def _load(args: argparse.Namespace) -> tuple[str, Any, Any, dict[str, Any]]:
    from flexhrc.cli.behave_common import resolve_document

    return resolve_document(args.target, args.layout, None, args.seed)


def _check_logs(args: argparse.Namespace, robots: list[str]) -> None:
    from flexhrc.cli.behave_common import check_plot
    from flexhrc.files import check_output

    check_plot(args.plot)

    if args.log:
        for robot in robots:
            check_output(robot_log_path(args.log, robot), option="--log")


def _summary(args: argparse.Namespace, label: str, task: Any, team: dict[str, Any]) -> int:
    from flexhrc.behavior.network import Run
    from flexhrc.cli.behave_common import summary_lines

    if args.plot:
        from flexhrc.behavior.plot import team_gantt

        runs = [
            Run(r["behavior"], r["arm"], r["start"], r["end"], r["outcome"]) for r in team["runs"]
        ]
        team["plot"] = str(
            team_gantt(
                runs,
                task.behaviors,
                args.plot,
                f"{label}: {', '.join(team['order'])}",
                team.get("lost"),
                team.get("lost_at"),
            )
        )

    class _View:
        outcome = team["outcome"]
        time = team["time"]
        ticks = team["ticks"]
        resets = sum(1 for r in team["runs"] if r["outcome"] == "reset")
        order = team["order"]

    def text() -> str:
        lines = [f"{label}: {task.to_prefix()}", f"robots: {', '.join(team['robots'])}"]
        if team.get("lost"):
            lines.append(f"lost: {', '.join(team['lost'])} (the others finished the task)")
        lines.append("runs:")
        for r in team["runs"]:
            end = "-" if r["end"] is None else f"{r['end']:.1f}"
            lines.append(
                f"  {r['start']:7.1f}s .. {end:>6}s  {r['behavior']:<10} {r['arm']:<16} "
                f"{r['outcome']}"
            )
        lines.append("")
        lines += summary_lines(_View, team["violations"], team.get("plot"))
        return "\n".join(lines)

    emit(args, team, text)
    return 0 if team["outcome"] == "done" and not team["violations"] else 1


def _in_process(args: argparse.Namespace) -> int:
    from flexhrc.behavior.logfile import end_record, event_record, header_record
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.peers import robot_names, run_team
    from flexhrc.behavior.validate import check_run
    from flexhrc.cli.behave_common import live_line
    from flexhrc.files import EventLogWriter

    robots = robot_names(args.robots)
    _check_logs(args, robots)
    label, task, world, factories = _load(args)
    params = NetworkParams(seed=args.seed)
    writers: dict[str, EventLogWriter] = {}
    behaviors = set(task.behaviors)
    realtime = args.realtime

    def attach(robot: str, net: Any) -> None:
        if args.log:  # one streamed log per robot, each replayable with `behave replay`
            writer = writers[robot] = EventLogWriter(robot_log_path(args.log, robot))
            writer.write(
                header_record(
                    f"{label} ({robot})",
                    task.to_prefix(),
                    task.behaviors,
                    net.world.arm_names,
                    args.seed,
                    params.tick_period,
                    robot=robot,
                )
            )
            net.listeners.append(lambda ev: writer.write(event_record(ev)))
        if realtime is not None:

            def live(ev: Any) -> None:
                line = live_line(ev, behaviors)
                if line:
                    log(args, f"{robot}: {line}")

            net.listeners.append(live)

    start = time.monotonic()

    def pace(tick: int) -> None:
        if realtime is not None:
            delay = start + tick * params.tick_period / realtime - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    try:
        team = run_team(
            task,
            world,
            args.robots,
            params,
            max_ticks=args.max_ticks,
            behaviors=factories,
            on_network=attach,
            on_tick=pace,
        )
        for robot, writer in writers.items():
            result = team.robots[robot]
            writer.write(end_record(result, check_run(task, result.runs, require_complete=False)))
    finally:
        for writer in writers.values():
            writer.close()
    data = team.to_dict()
    data.update(
        target=label,
        task=task.to_prefix(),
        seed=args.seed,
        transport="inprocess",
        violations=check_run(task, team.runs),
    )
    return _summary(args, label, task, data)


# ----------------------------------------------------------------------------- over Zenoh


def _spawn_team(args: argparse.Namespace) -> int:
    from flexhrc.behavior.network import Run
    from flexhrc.behavior.peers import robot_names
    from flexhrc.behavior.validate import check_run
    from flexhrc.transport.zenoh import free_tcp_port  # OptionalDependencyError without zenoh

    robots = robot_names(args.robots)
    _check_logs(args, robots)
    label, task, _world, _f = _load(args)  # bad input is reported here, not by N children
    speed = args.realtime if args.realtime is not None else DEFAULT_TEAM_SPEED
    port = free_tcp_port()
    procs = []
    for robot in robots:
        cmd = [
            sys.executable,
            "-m",
            "flexhrc",
            "behave",
            args.target,
            "--robots",
            str(args.robots),
            "--transport",
            "zenoh",
            "--robot",
            robot,
            "--peer-port",
            str(port),
            "--realtime",
            repr(speed),
            "--seed",
            str(args.seed),
            "--json",
        ]
        if args.layout is not None:
            cmd += ["--layout", str(args.layout)]
        if args.max_ticks is not None:
            cmd += ["--max-ticks", str(args.max_ticks)]
        if args.log:
            cmd += ["--log", robot_log_path(args.log, robot)]
        for module in args.types or ():
            cmd += ["--types", module]
        procs.append(
            (
                robot,
                subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True),
            )
        )
    log(args, f"{label}: {len(robots)} robot processes over Zenoh on 127.0.0.1:{port}")
    outputs: dict[str, dict[str, Any]] = {}
    lost = []
    try:
        for robot, proc in procs:
            out, err = proc.communicate()
            if proc.returncode not in (0, 1) or not out.strip():
                lost.append(robot)
                log(args, f"{robot}: exited with code {proc.returncode}: {err.strip()[-300:]}")
                continue
            outputs[robot] = json.loads(out)
    finally:
        for _robot, proc in procs:
            if proc.poll() is None:
                proc.kill()
    if not outputs:
        raise FlexhrcError("no robot process finished")
    epoch = min(o["wall_start"] for o in outputs.values())
    runs = [
        Run(
            r["behavior"],
            f"{robot}/{r['arm']}",
            round((r["start"] - epoch) * speed, 3),
            None if r["end"] is None else round((r["end"] - epoch) * speed, 3),
            r["outcome"],
        )
        for robot, o in outputs.items()
        for r in o["wall_runs"]
    ]
    runs.sort(key=lambda r: (r.start, r.behavior))
    done = sorted((r for r in runs if r.outcome == "done"), key=lambda r: r.end or 0.0)
    team = {
        "outcome": "done" if all(o["outcome"] == "done" for o in outputs.values()) else "timeout",
        "order": [r.behavior for r in done],
        "ticks": max(o["ticks"] for o in outputs.values()),
        "time": max((r.end or 0.0) for r in runs) if runs else 0.0,
        "lost": lost + sorted({x for o in outputs.values() for x in o.get("lost", [])} - set(lost)),
        "robots": {
            robot: {k: o[k] for k in ("outcome", "order", "resets")} for robot, o in outputs.items()
        },
        "runs": [r.to_dict() for r in runs],
        "target": label,
        "task": task.to_prefix(),
        "seed": args.seed,
        "transport": "zenoh",
        "port": port,
        "violations": check_run(task, runs),
    }
    return _summary(args, label, task, team)


def _robot_process(args: argparse.Namespace) -> int:
    """One robot of a team over Zenoh: its own network, peer messages on Zenoh."""
    from flexhrc.behavior.logfile import end_record, event_record, header_record
    from flexhrc.behavior.network import BehaviorNetwork, default_max_ticks, runs_from_log
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.peers import PeerLink, from_wire, robot_names, robot_world, to_wire
    from flexhrc.behavior.validate import check_run
    from flexhrc.files import EventLogWriter, check_output
    from flexhrc.transport.zenoh import ZenohTransport, json_decode, json_encode, zenoh_config

    robots = robot_names(args.robots)
    if args.robot not in robots:
        raise FlexhrcError(f"--robot must be one of {', '.join(robots)}, got {args.robot!r}")
    if args.log:
        check_output(args.log, option="--log")
    label, task, world, factories = _load(args)
    index = robots.index(args.robot)
    endpoint = f"tcp/127.0.0.1:{args.peer_port}"
    config = zenoh_config(listen=[endpoint]) if index == 0 else zenoh_config(connect=[endpoint])
    bus = ZenohTransport(
        config,
        encode=lambda m: json_encode(to_wire(m)),
        decode=lambda b: from_wire(json_decode(b)),
    )
    params = NetworkParams(seed=args.seed)
    net = BehaviorNetwork(task, robot_world(world, index, args.robot), params, behaviors=factories)
    link = PeerLink(args.robot, robots, bus, net)
    seen: set[str] = set()
    lost: list[str] = []

    def on_alive(key: str, alive: bool) -> None:
        robot = key.rsplit("/", 1)[-1]
        if alive:
            seen.add(robot)
        elif robot in seen and robot != args.robot and robot not in lost:
            lost.append(robot)
            link.peer_lost(robot)

    bus.watch_liveliness("bnpeer/alive/*", on_alive)
    token = bus.declare_token(f"bnpeer/alive/{args.robot}")
    writer = EventLogWriter(args.log) if args.log else None
    wall_events: list[Any] = []
    try:
        deadline = time.monotonic() + BARRIER_TIMEOUT_S
        while not set(robots) <= seen:  # every robot is up: start together
            if time.monotonic() > deadline:
                missing = ", ".join(sorted(set(robots) - seen))
                raise FlexhrcError(
                    f"{args.robot}: no sign of {missing} after {BARRIER_TIMEOUT_S:.0f} s"
                )
            bus.wait(0.05)
            bus.flush()
        wall_start = time.time()
        if writer is not None:
            writer.write(
                header_record(
                    f"{label} ({args.robot})",
                    task.to_prefix(),
                    task.behaviors,
                    world_arms(net),
                    args.seed,
                    params.tick_period,
                    robot=args.robot,
                    wall_start=wall_start,
                )
            )
        tick_wall = [wall_start]

        def wall_of(ev: Any) -> float:
            # Comparable across processes: a completion is announced to the others during its
            # tick, so it gets the tick's start time (no earlier than the announcement); a start
            # follows the others' grants, so it gets the time it is recorded (no later).
            return time.time() if ev.kind == "start" else tick_wall[0]

        if writer is not None:
            net.listeners.append(lambda ev: writer.write({**event_record(ev), "wall": wall_of(ev)}))

        def stamp(ev: Any) -> None:
            if ev.kind in ("start", "done", "reset"):
                wall_events.append(ev._replace(t=wall_of(ev)))

        net.listeners.append(stamp)
        speed = args.realtime if args.realtime is not None else DEFAULT_TEAM_SPEED
        limit = args.max_ticks if args.max_ticks is not None else default_max_ticks(task)
        start = time.monotonic()
        while not net.finished and net.clock.tick < limit:
            bus.flush()
            tick_wall[0] = time.time()
            net.tick()
            delay = start + net.clock.now() / speed - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        bus.flush()
        time.sleep(0.2)  # let the last announcements reach the others before leaving
        result = net.result()
        if writer is not None:
            writer.write(end_record(result, check_run(task, result.runs, require_complete=False)))
    finally:
        if writer is not None:
            writer.close()
        token.undeclare()
        bus.close()
    data = result.to_dict()
    data.update(
        robot=args.robot,
        target=label,
        wall_start=wall_start,
        wall_runs=[r.to_dict() for r in runs_from_log(wall_events)],
        remote_done=[list(x) for x in link.remote_done],
        lost=lost,
    )
    emit(args, data, json.dumps(data))
    return 0 if result.outcome == "done" else 1


def world_arms(net: Any) -> list[str]:
    return list(net.world.arm_names)
