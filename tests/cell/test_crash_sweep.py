"""Crash at every point (issue 20, item 4): the manager SIGKILLs itself right after committing
its N-th event (``FLEXHRC_CRASH_AFTER=N``), for every N of a run, and ``--resume`` ends with the
uninterrupted run's knowledge base, ``by_agent`` and solved hyper-arcs, a gap-free ``seq``, each
command issued once and answered once.

The in-process sweeps fork one child per N (the manager with its agents inside, the in-process
transport): the child kills itself at event N, the test resumes the store in its own process.
The Zenoh run crashes a manager with agent processes at a few N chosen to fall while commands
are in flight, and checks the agents' journals: no command executed twice."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell.serve import CellConfig, serve_cell
from flexhrc.cell.store import CRASH_AFTER_ENV, read_store, summarise_store
from flexhrc.scenario import load_scenario

from .helpers import finish, human, kill_all, listening_port, robot, rows, start_cell

# the table task, and an operator that acts on its own in the kitchen (options and intents)
SWEEPS = [("table_assembly", "passive"), ("kitchen_drawer", "takeover")]


def _same_result(data: dict[str, Any], ref: dict[str, Any], n: int) -> None:
    """The resumed run (crashed after event ``n``) ended as the uninterrupted one."""
    assert data["outcome"] == ref["outcome"] == "solved", n
    assert data["knowledge"] == ref["knowledge"], n
    assert data["by_agent"] == ref["by_agent"], n
    assert data["solved_hyperarcs"] == ref["solved_hyperarcs"], n
    assert data["timing"]["total_s"] == ref["timing"]["total_s"], n


def _sound_store(path: Path) -> list[Any]:
    """Gap-free seq, every command issued once and answered at most once (``replay`` checks
    the rest: one start, one outcome, time never going back, acks of issued commands)."""
    events = read_store(path)
    assert [e.seq for e in events] == list(range(1, len(events) + 1))
    commands = [e.body["id"] for e in events if e.kind == "command"]
    acks = [e.body["id"] for e in events if e.kind == "ack"]
    assert len(commands) == len(set(commands)), "a command was issued twice"
    assert len(acks) == len(set(acks)) and set(acks) <= set(commands)
    assert [e.kind for e in events].count("outcome") == 1
    return events


def _crash_child(scenario: Any, config: CellConfig, n: int) -> None:
    """Run the cell in a forked child that SIGKILLs itself after committing event ``n``."""
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child
        code = 3
        try:
            os.environ[CRASH_AFTER_ENV] = str(n)
            serve_cell(scenario, config)
            code = 0  # the run ended before event n: only for n past the last event
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL, (n, status)


@pytest.mark.parametrize(("name", "human"), SWEEPS)
def test_crash_after_every_event_resumes_to_the_uninterrupted_run(
    tmp_path: Path, name: str, human: str
) -> None:
    scenario = load_scenario(name)
    ref_store = tmp_path / "ref.db"
    ref = serve_cell(scenario, CellConfig(human=human, store=ref_store))
    total = len(read_store(ref_store))  # every event, the closing summary included
    assert total > 15
    t0 = time.perf_counter()
    for n in range(1, total + 1):
        store = tmp_path / f"crash{n}.db"
        config = CellConfig(human=human, store=store)
        _crash_child(scenario, config, n)
        assert len(read_store(store)) == n  # committed before the kill, nothing after it
        resumed = serve_cell(scenario, CellConfig(human=human, store=store, resume=True))
        _same_result(resumed, ref, n)
        _sound_store(store)
        replayed, _ = summarise_store(store)  # the store reads back as the run it was
        assert replayed["by_agent"] == ref["by_agent"]
        assert replayed["solved_hyperarcs"] == ref["solved_hyperarcs"]
        store.unlink()
    # the figure for the note (pytest -s shows it)
    print(f"{name}: {total} crash points resumed in {time.perf_counter() - t0:.1f} s")


def _journal(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _crash_points(events: list[Any]) -> list[int]:
    """Events to crash after, each with work in flight: a command stored while another runs,
    an operator's report while commands run, an ack while another command runs, a report in
    the middle of a request of several steps, the last ack."""
    in_flight: list[set[int]] = []
    running: set[int] = set()
    for ev in events:
        if ev.kind == "ack":
            running.discard(ev.body["id"])
        in_flight.append(set(running))  # sent before this event was stored, not answered
        if ev.kind == "command":
            running.add(ev.body["id"])
    kinds = [ev.kind for ev in events]

    def first(kind: str, also: Any = lambda i: True) -> int:
        return next(i + 1 for i, k in enumerate(kinds) if k == kind and in_flight[i] and also(i))

    return sorted(
        {
            first("command"),
            first("human_action"),
            first("ack"),
            next(i + 1 for i in range(len(kinds) - 1) if kinds[i : i + 2] == ["human_action"] * 2),
            len(kinds) - kinds[::-1].index("ack"),
        }
    )


@pytest.mark.slow
def test_crash_with_agent_processes_over_zenoh_executes_no_command_twice(tmp_path: Path) -> None:
    """The manager of the kitchen drawer over Zenoh, its arms (with journals) and operator as
    processes, killed at events with commands and requests in flight (:func:`_crash_points`);
    each resumed run ends as the uninterrupted one and no arm executed a command twice."""
    name = "kitchen_drawer"
    ref_store = tmp_path / "ref.db"
    ref = serve_cell(load_scenario(name), CellConfig(store=ref_store))
    points = _crash_points(read_store(ref_store))
    assert len(points) == 5
    for n in points:
        case = tmp_path / f"n{n}"
        case.mkdir()
        store = case / "cell.db"
        os.environ[CRASH_AFTER_ENV] = str(n)
        try:
            manager, port = start_cell(name, store, log=case / "cell.err")
        finally:
            del os.environ[CRASH_AFTER_ENV]
        agents = [
            robot(name, arm, port, case / f"{arm}.err", "--journal", str(case / f"{arm}.jsonl"))
            for arm in ("left", "right")
        ]
        agents.append(human(name, "human", port, case / "human.err"))
        procs = [manager, *agents]
        try:
            assert manager.wait(60) == -signal.SIGKILL, (case / "cell.err").read_text()[-2000:]
            assert len(rows(store)) == n
            resumed = start_resumed(name, store, port, case, case / "cell2.ready")
            procs.append(resumed)
            data = finish(resumed)
            for agent in agents:
                assert agent.wait(30) == 0
        finally:
            kill_all(procs)
        _same_result(data, ref, n)
        events = _sound_store(store)
        issued = {e.body["id"] for e in events if e.kind == "command"}
        started = [
            line["id"]
            for arm in ("left", "right")
            for line in _journal(case / f"{arm}.jsonl")
            if line.get("event") == "start"
        ]
        assert len(started) == len(set(started)), f"N={n}: a command was executed twice"
        assert set(started) == issued, f"N={n}: not every command was executed once"
        reports = [e.body["id"] for e in events if e.kind == "human_action"]
        assert len(reports) == len(set(reports)) == ref["human_actions"], n


def start_resumed(scenario: str, store: Path, port: int, case: Path, ready: Path) -> Any:
    from .helpers import cell

    proc = cell(scenario, port, store, "--resume", log=case / "cell2.err", ready=ready)
    listening_port(ready, proc)
    return proc


def test_the_hook_is_a_whole_number(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from flexhrc.cell.store import EventStore
    from flexhrc.errors import FlexhrcError

    monkeypatch.setenv(CRASH_AFTER_ENV, "soon")
    with pytest.raises(FlexhrcError, match="FLEXHRC_CRASH_AFTER='soon': expected a whole number"):
        EventStore(tmp_path / "s.db")
    monkeypatch.setenv(CRASH_AFTER_ENV, "")
    EventStore(tmp_path / "t.db").close()


@pytest.mark.slow
def test_k06_a_manager_stopped_longer_than_the_lease_loses_no_work(tmp_path: Path) -> None:
    """The probe's K06: the manager of a running cell gets SIGSTOP for 12 s (the Zenoh lease is
    10 s), then SIGCONT. No agent is recorded lost, no command failed, every command executed
    once, and the cooperation ends as the uninterrupted one (its times aside: the cell's clock
    is the wall clock here, and it ran on during the stall)."""
    from .helpers import TABLE_NO_HUMAN, wait_until

    scenario = tmp_path / "table.yaml"
    scenario.write_text(TABLE_NO_HUMAN)
    ref = serve_cell(load_scenario(str(scenario)), CellConfig())
    store = tmp_path / "cell.db"
    manager, port = start_cell(str(scenario), store, "--realtime", "4", log=tmp_path / "cell.err")
    arms = [
        robot(str(scenario), arm, port, tmp_path / f"{arm}.err", "--journal",
              str(tmp_path / f"{arm}.jsonl"))
        for arm in ("left", "right")
    ]  # fmt: skip
    procs = [manager, *arms]
    try:
        wait_until(store, lambda r: sum(k == "ack" for _, _, k, _ in r) >= 2, 60)
        os.kill(manager.pid, signal.SIGSTOP)
        time.sleep(12.0)  # the stall itself (longer than the lease), not a synchronisation
        os.kill(manager.pid, signal.SIGCONT)
        data = finish(manager, timeout=120)
        for arm in arms:
            assert arm.wait(30) == 0
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(manager.pid, signal.SIGCONT)
        kill_all(procs)
    log = (tmp_path / "cell.err").read_text()
    assert data["outcome"] == "solved", log[-2000:]
    events = _sound_store(store)
    assert [e.body for e in events if e.kind == "agent_down"] == [], log[-2000:]
    assert [e.body for e in events if e.kind == "ack" and e.body["status"] != "done"] == []
    assert data["knowledge"] == ref["knowledge"]
    assert data["by_agent"] == ref["by_agent"]
    assert data["robot_actions"] == ref["robot_actions"]
    started = [
        line["id"]
        for arm in ("left", "right")
        for line in _journal(tmp_path / f"{arm}.jsonl")
        if line.get("event") == "start"
    ]
    assert sorted(started) == sorted(e.body["id"] for e in events if e.kind == "command")
