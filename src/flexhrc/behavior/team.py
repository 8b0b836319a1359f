"""Several robots, one task, as a run of ``flexhrc behave TASK --robots N``.

:func:`run_team_config` runs a :class:`~flexhrc.behavior.command.BehaveConfig` with ``robots`` > 1
(:func:`flexhrc.behavior.behave.run_behave` hands it here):

* in process (the default): every robot's network and the peer bus tick together on one simulated
  clock (:func:`flexhrc.behavior.peers.run_team`; deterministic);
* over Zenoh: one OS process per robot on 127.0.0.1 (multicast scouting off; robot1 listens on a
  free port, the others connect to it), each paced at ``realtime`` SPEED (default 10) x wall time;
  a robot whose process dies is seen as lost through its Zenoh liveliness token, and the others
  finish the task. This process starts the robots (``flexhrc behave ... --robot NAME``), waits for
  them and checks the merged runs (times taken from each process's wall clock, so they compare
  across processes); with ``robot`` set, this process *is* one of them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from flexhrc.behavior.command import (
    DEFAULT_TEAM_SPEED,
    BehaveConfig,
    BehaveReport,
    LineSink,
    LoadedTask,
    check_plot,
    live_trace,
    load_target,
    summary_lines,
    tick_loop,
)
from flexhrc.behavior.logfile import end_record, event_record, stream_log
from flexhrc.behavior.network import Run
from flexhrc.behavior.peers import robot_names
from flexhrc.behavior.validate import check_run
from flexhrc.errors import FlexhrcError
from flexhrc.files import EventLogWriter, atomic_write_text, check_output

BARRIER_TIMEOUT_S = 30.0


def robot_log_path(path: str, robot: str) -> str:
    """``run.jsonl`` -> ``run.robot1.jsonl``: one streamed log per robot."""
    p = Path(path)
    return str(p.with_name(f"{p.stem}.{robot}{p.suffix}"))


def run_team_config(config: BehaveConfig, on_line: LineSink) -> BehaveReport:
    """Run a team (see the module docstring); ``on_line`` gets live and progress lines."""
    if config.robot is not None:
        return _robot_process(config)
    robots = robot_names(config.robots)
    check_plot(config.plot)
    if config.log:
        for robot in robots:
            check_output(robot_log_path(config.log, robot), option="--log")
    loaded = load_target(config.target, None, config.seed)  # bad input: here, not in N children
    if config.transport == "zenoh":
        team = _spawn_team(config, loaded, robots, on_line)
    else:
        team = _in_process(config, loaded, on_line)
    where = {key: team.pop(key) for key in ("transport", "port") if key in team}
    team.update(target=loaded.label, task=loaded.task.to_prefix(), seed=config.seed, **where)
    team["violations"] = check_run(loaded.task, [Run(**r) for r in team["runs"]])
    return _report(config, loaded.task.behaviors, team)


def _report(config: BehaveConfig, behaviors: list[str], team: dict[str, Any]) -> BehaveReport:
    label = team["target"]
    if config.plot:
        from flexhrc.behavior.plot import team_gantt

        runs = [Run(**r) for r in team["runs"]]
        title = f"{label}: {', '.join(team['order'])}"
        plot = team_gantt(
            runs, behaviors, config.plot, title, team.get("lost"), team.get("lost_at")
        )
        team["plot"] = str(plot)

    def text() -> str:
        lines = [f"{label}: {team['task']}", f"robots: {', '.join(team['robots'])}"]
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
        lines += summary_lines(team)
        return "\n".join(lines)

    return BehaveReport(team, text)


def _in_process(config: BehaveConfig, loaded: LoadedTask, on_line: LineSink) -> dict[str, Any]:
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.peers import run_team

    task = loaded.task
    params = NetworkParams(seed=config.seed)
    writers: dict[str, EventLogWriter] = {}
    realtime = config.realtime

    def attach(robot: str, net: Any) -> None:
        if config.log:  # one streamed log per robot, each replayable with `behave replay`
            path = robot_log_path(config.log, robot)
            label = f"{loaded.label} ({robot})"
            writers[robot] = stream_log(net, path, label, config.seed, robot=robot)
        if realtime is not None:
            live_trace(net, on_line, f"{robot}: ")

    start = time.monotonic()

    def pace(tick: int) -> None:
        if realtime is not None:
            delay = start + tick * params.tick_period / realtime - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    try:
        team = run_team(
            task,
            loaded.world,
            config.robots,
            params,
            max_ticks=config.max_ticks,
            behaviors=loaded.behaviors,
            on_network=attach,
            on_tick=pace,
        )
        for robot, writer in writers.items():
            result = team.robots[robot]
            writer.write(end_record(result, check_run(task, result.runs, require_complete=False)))
    finally:
        for writer in writers.values():
            writer.close()
    return {**team.to_dict(), "transport": "inprocess"}


# ----------------------------------------------------------------------------- over Zenoh


def _child_command(
    config: BehaveConfig, robot: str, port: int, speed: float, ready: Path | None = None
) -> list[str]:
    """``flexhrc behave`` for one robot process of the team (``ready``: the listener's
    ready file, with ``port`` 0)."""
    if config.child_args:
        task_args = list(config.child_args)
    elif isinstance(config.target, str):
        task_args = [config.target]
    else:
        raise FlexhrcError(
            "over Zenoh each robot process loads the task itself: give the task as text "
            "(a task file or an inline task), or child_args"
        )
    cmd = [sys.executable, "-m", "flexhrc", "behave", *task_args]
    cmd += ["--robots", str(config.robots), "--transport", "zenoh", "--robot", robot]
    cmd += ["--peer-port", str(port), "--realtime", repr(speed), "--seed", str(config.seed)]
    cmd.append("--json")
    if ready is not None:
        cmd += ["--ready-file", str(ready)]
    if config.max_ticks is not None:
        cmd += ["--max-ticks", str(config.max_ticks)]
    if config.log:
        cmd += ["--log", robot_log_path(config.log, robot)]
    for module in config.types:
        cmd += ["--types", module]
    return cmd


def _spawn_team(
    config: BehaveConfig, loaded: LoadedTask, robots: list[str], on_line: LineSink
) -> dict[str, Any]:
    import flexhrc.transport.zenoh  # noqa: F401  (OptionalDependencyError without zenoh)

    speed = config.realtime if config.realtime is not None else DEFAULT_TEAM_SPEED

    def spawn(robot: str, port: int, ready: Path | None = None) -> subprocess.Popen[str]:
        cmd = _child_command(config, robot, port, speed, ready)
        return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    # the first robot listens on a port the system gives it and says which (a port picked here
    # and handed over could be taken by another process before the child binds it)
    with tempfile.TemporaryDirectory(prefix="flexhrc-team-") as tmp:
        ready = Path(tmp) / f"{robots[0]}.ready"
        procs = [(robots[0], spawn(robots[0], 0, ready))]
        try:
            port = _listening_port(ready, procs[0][1], robots[0])
            procs += [(robot, spawn(robot, port)) for robot in robots[1:]]
        except BaseException:
            for _robot, proc in procs:
                if proc.poll() is None:
                    proc.kill()
                proc.communicate()
            raise
    on_line(f"{loaded.label}: {len(robots)} robot processes over Zenoh on 127.0.0.1:{port}")
    outputs: dict[str, dict[str, Any]] = {}
    lost = []
    try:
        for robot, proc in procs:
            out, err = proc.communicate()
            if proc.returncode not in (0, 1) or not out.strip():
                lost.append(robot)
                on_line(f"{robot}: exited with code {proc.returncode}: {err.strip()[-300:]}")
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
    return {
        "outcome": "done" if all(o["outcome"] == "done" for o in outputs.values()) else "timeout",
        "order": [r.behavior for r in done],
        "ticks": max(o["ticks"] for o in outputs.values()),
        "time": max((r.end or 0.0) for r in runs) if runs else 0.0,
        "lost": lost + sorted({x for o in outputs.values() for x in o.get("lost", [])} - set(lost)),
        "robots": {
            robot: {k: o[k] for k in ("outcome", "order", "resets")} for robot, o in outputs.items()
        },
        "runs": [r.to_dict() for r in runs],
        "transport": "zenoh",
        "port": port,
    }


def _listening_port(ready: Path, proc: subprocess.Popen[str], robot: str) -> int:
    """The port ``robot``'s process listens on, from the ready file it writes once it does."""
    deadline = time.monotonic() + BARRIER_TIMEOUT_S
    while not ready.exists():
        try:
            proc.wait(timeout=0.02)  # wakes at once if the process ends
        except subprocess.TimeoutExpired:
            if time.monotonic() > deadline:
                raise FlexhrcError(
                    f"{robot} did not listen within {BARRIER_TIMEOUT_S:.0f} s"
                ) from None
            continue
        _, err = proc.communicate()
        raise FlexhrcError(f"{robot}: exited with code {proc.returncode}: {err.strip()[-300:]}")
    endpoint = json.loads(ready.read_text())["listen"][0]
    return int(str(endpoint).rsplit(":", 1)[1])


def _robot_process(config: BehaveConfig) -> BehaveReport:
    """One robot of a team over Zenoh: its own network, peer messages on Zenoh."""
    from flexhrc.behavior.messages import to_wire
    from flexhrc.behavior.network import BehaviorNetwork, runs_from_log
    from flexhrc.behavior.params import NetworkParams
    from flexhrc.behavior.peers import PeerLink, from_wire, robot_world
    from flexhrc.transport.zenoh import (
        ZenohTransport,
        json_decode,
        json_encode,
        listening_on,
        zenoh_config,
    )

    robots = robot_names(config.robots)
    me = str(config.robot)
    if me not in robots:
        raise FlexhrcError(f"--robot must be one of {', '.join(robots)}, got {me!r}")
    if config.log:
        check_output(config.log, option="--log")
    loaded = load_target(config.target, None, config.seed)
    task = loaded.task
    index = robots.index(me)
    endpoint = f"tcp/127.0.0.1:{config.peer_port}"
    zconfig = zenoh_config(listen=[endpoint]) if index == 0 else zenoh_config(connect=[endpoint])
    bus = ZenohTransport(
        zconfig,
        encode=lambda m: json_encode(to_wire(m)),
        decode=lambda b: from_wire(json_decode(b)),
    )
    world = robot_world(loaded.world, index, me)
    net = BehaviorNetwork(task, world, NetworkParams(seed=config.seed), behaviors=loaded.behaviors)
    link = PeerLink(me, robots, bus, net)
    seen: set[str] = set()
    lost: list[str] = []

    def on_alive(key: str, alive: bool) -> None:
        robot = key.rsplit("/", 1)[-1]
        if alive:
            seen.add(robot)
        elif robot in seen and robot != me and robot not in lost:
            lost.append(robot)
            link.peer_lost(robot)

    bus.watch_liveliness("bnpeer/alive/*", on_alive)
    token = bus.declare_token(f"bnpeer/alive/{me}")
    if config.ready_file:  # listening, subscribed and announced: the others may come
        record = {"listen": listening_on(bus, [endpoint]), "pid": os.getpid(), "robot": me}
        atomic_write_text(config.ready_file, json.dumps(record) + "\n")
    writer: EventLogWriter | None = None
    wall_events: list[Any] = []
    try:
        deadline = time.monotonic() + BARRIER_TIMEOUT_S
        while not set(robots) <= seen:  # every robot is up: start together
            if time.monotonic() > deadline:
                missing = ", ".join(sorted(set(robots) - seen))
                raise FlexhrcError(f"{me}: no sign of {missing} after {BARRIER_TIMEOUT_S:.0f} s")
            bus.wait(0.05)
            bus.flush()
        wall_start = time.time()
        tick_wall = [wall_start]

        def wall_of(ev: Any) -> float:
            # Comparable across processes: a completion is announced to the others during its
            # tick, so it gets the tick's start time (no earlier than the announcement); a start
            # follows the others' grants, so it gets the time it is recorded (no later).
            return time.time() if ev.kind == "start" else tick_wall[0]

        if config.log:  # the event lines carry their wall time too
            label = f"{loaded.label} ({me})"
            writer = stream_log(
                net,
                config.log,
                label,
                config.seed,
                record=lambda ev: {**event_record(ev), "wall": wall_of(ev)},
                robot=me,
                wall_start=wall_start,
            )

        def stamp(ev: Any) -> None:
            if ev.kind in ("start", "done", "reset"):
                wall_events.append(ev._replace(t=wall_of(ev)))

        net.listeners.append(stamp)

        def before_tick() -> None:
            bus.flush()
            tick_wall[0] = time.time()

        speed = config.realtime if config.realtime is not None else DEFAULT_TEAM_SPEED
        tick_loop(net, config.max_ticks, speed, before_tick)
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
        robot=me,
        target=loaded.label,
        wall_start=wall_start,
        wall_runs=[r.to_dict() for r in runs_from_log(wall_events)],
        remote_done=[list(x) for x in link.remote_done],
        lost=lost,
    )
    return BehaveReport(data, json.dumps(data))
