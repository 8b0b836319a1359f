"""Processes of a cell for the tests: the manager and agents as real `python -m flexhrc` runs."""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..conftest import subprocess_env

TABLE_NO_HUMAN = "scenario: table_assembly\nhuman: false\n"
# legs 1 and 3 are within reach of the left arm only: without it, half the work waits for it
TABLE_LEFT_ONLY = (
    "scenario: table_assembly\nhuman: false\nreachable_only_by: {leg1: left, leg3: left}\n"
)
TABLE_HUMAN_BOLT = "scenario: table_assembly\nunreachable_bolts: [2]\n"  # the operator screws it


class Crash(Exception):
    """The manager 'dies' here (a test's pump raises it after so many stored events)."""


def pump_of(cell: Any, bus: Any, agents: list[Any], limit: int | None = None) -> Any:
    """The pump of an in-process cell: deliver the bus, let every agent act; raises
    :class:`Crash` once the cell has stored ``limit`` events."""

    def pump(timeout: float) -> None:
        if limit is not None and len(cell.events) >= limit:
            raise Crash
        bus.flush()
        for a in agents:
            a.poll()

    return pump


def simulated_agents(scenario: Any, bus: Any) -> list[Any]:
    """Every agent of ``scenario`` simulated on ``bus`` (analytic execution), in domain order."""
    from flexhrc.cell import HumanAgent, RobotAgent
    from flexhrc.cell.components import execution_model

    return [
        (HumanAgent if a.is_human else RobotAgent)(
            a.name, scenario, bus, execution=execution_model("analytic")
        )
        for a in scenario.domain.agents.values()
    ]


def flexhrc(*args: str, log: Path | None = None) -> subprocess.Popen[str]:
    """Start ``python -m flexhrc ARGS``: stdout piped, stderr to ``log`` (or piped)."""
    err: Any = open(log, "w") if log is not None else subprocess.PIPE  # noqa: SIM115
    return subprocess.Popen(
        [sys.executable, "-m", "flexhrc", *args],
        stdout=subprocess.PIPE,
        stderr=err,
        text=True,
        env=subprocess_env(),
    )


def cell(
    scenario: str, port: int, store: Path, *extra: str, log: Path, ready: Path | None = None
) -> subprocess.Popen[str]:
    """The manager as a process, listening on loopback ``port``; port 0: the system picks one
    and the cell writes it to ``ready`` (see :func:`listening_port`)."""
    return flexhrc(
        "cell",
        scenario,
        "--transport",
        "zenoh",
        "--agents",
        "external",
        "--listen",
        f"tcp/127.0.0.1:{port}",
        "--store",
        str(store),
        "--json",
        "--wait",
        "20",
        *(("--ready-file", str(ready)) if ready is not None else ()),
        *extra,
        log=log,
    )


def listening_port(ready: Path, proc: subprocess.Popen[str], timeout: float = 60.0) -> int:
    """The port a cell started with ``--listen tcp/127.0.0.1:0 --ready-file READY`` got (it
    binds the port itself: no port chosen here can be taken before the child binds it)."""
    deadline = time.monotonic() + timeout
    while not ready.exists():
        if proc.poll() is not None or time.monotonic() > deadline:
            raise AssertionError(f"the cell never wrote {ready} (exit {proc.poll()})")
        time.sleep(0.01)
    endpoint = json.loads(ready.read_text())["listen"][0]
    return int(endpoint.rsplit(":", 1)[1])


def start_cell(
    scenario: str, store: Path, *extra: str, log: Path
) -> tuple[subprocess.Popen[str], int]:
    """:func:`cell` on a port the system picks; returns the process and its port."""
    ready = log.with_suffix(".ready")
    proc = cell(scenario, 0, store, *extra, log=log, ready=ready)
    try:
        return proc, listening_port(ready, proc)
    except BaseException:
        kill_all([proc])
        raise


def robot(scenario: str, arm: str, port: int, log: Path, *extra: str) -> subprocess.Popen[str]:
    return flexhrc(
        "agent",
        "robot",
        scenario,
        "--arm",
        arm,
        "--connect",
        f"tcp/127.0.0.1:{port}",
        *extra,
        log=log,
    )


def human(scenario: str, name: str, port: int, log: Path, *extra: str) -> subprocess.Popen[str]:
    return flexhrc(
        "agent", "human", scenario, "--name", name, "--connect", f"tcp/127.0.0.1:{port}", *extra,
        log=log,
    )  # fmt: skip


def rows(store: Path) -> list[tuple[int, float, str, dict[str, Any]]]:
    """The store's events (read-only; empty while the file does not exist yet)."""
    if not store.exists():
        return []
    try:
        db = sqlite3.connect(f"file:{store}?mode=ro", uri=True, timeout=1.0)
        try:
            got = db.execute("SELECT seq, t, kind, body FROM events ORDER BY seq").fetchall()
        finally:
            db.close()
    except sqlite3.OperationalError:
        return []
    return [(s, t, k, json.loads(b)) for s, t, k, b in got]


def wait_until(
    store: Path,
    check: Callable[[list[tuple[int, float, str, dict[str, Any]]]], bool],
    timeout: float,
) -> list[tuple[int, float, str, dict[str, Any]]]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = rows(store)
        if check(got):
            return got
        time.sleep(0.005)
    raise AssertionError(f"timed out after {timeout} s; store has {len(rows(store))} events")


def finish(proc: subprocess.Popen[str], timeout: float = 60.0) -> dict[str, Any]:
    """Wait for a `--json` run and return its document."""
    out, _ = proc.communicate(timeout=timeout)
    assert proc.returncode in (0, 1), f"exit {proc.returncode}"
    return json.loads(out)


def executed(log: Path) -> list[int]:
    """Command ids a robot agent executed, from its trace."""
    ids = []
    for line in log.read_text().splitlines():
        if "] execute cmd " in line:
            ids.append(int(line.split("execute cmd ", 1)[1].split()[0]))
    return ids


def kill_all(procs: list[subprocess.Popen[str]]) -> None:
    for p in procs:
        if p.poll() is None:
            p.kill()
        p.wait(10)
