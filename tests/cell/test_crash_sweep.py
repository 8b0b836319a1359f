"""Crash at every point (issue 20, item 4): the manager SIGKILLs itself right after committing
its N-th event (``FLEXHRC_CRASH_AFTER=N``), for every N of a run, and ``--resume`` ends with the
uninterrupted run's knowledge base, ``by_agent`` and solved hyper-arcs, a gap-free ``seq``, each
command issued once and answered once.

The in-process sweeps fork one child per N (the manager with its agents inside, the in-process
transport): the child kills itself at event N, the test resumes the store in its own process.
The Zenoh run crashes a manager with agent processes at a few N chosen to fall while commands
are in flight, and checks the agents' journals: no command executed twice."""

from __future__ import annotations

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

from .helpers import finish, kill_all, listening_port, robot, rows, start_cell

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


@pytest.mark.slow
def test_crash_with_agent_processes_over_zenoh_executes_no_command_twice(tmp_path: Path) -> None:
    """A manager with arm processes (journals) killed at a few events while commands are in
    flight: right after a command is stored (sent or about to be), right after its ack, and
    right after an ack that completes a hyper-arc; each resumed run ends as the uninterrupted
    one and no arm executed a command twice."""
    scenario = tmp_path / "table.yaml"
    scenario.write_text("scenario: table_assembly\nhuman: false\n")
    ref = serve_cell(load_scenario(str(scenario)), CellConfig())
    ref_store = tmp_path / "ref.db"
    serve_cell(load_scenario(str(scenario)), CellConfig(store=ref_store))
    kinds = [e.kind for e in read_store(ref_store)]
    first_cmd = kinds.index("command") + 1
    points = sorted(
        {
            first_cmd,  # the very first command
            kinds.index("command", len(kinds) // 2) + 1,  # a command mid-run, in flight
            kinds.index("ack", len(kinds) // 3) + 1,  # right after an ack
            kinds.index("solved", 10) + 1,  # after a hyper-arc is solved
        }
    )
    for n in points:
        case = tmp_path / f"n{n}"
        case.mkdir()
        store = case / "cell.db"
        os.environ[CRASH_AFTER_ENV] = str(n)
        try:
            manager, port = start_cell(str(scenario), store, log=case / "cell.err")
        finally:
            del os.environ[CRASH_AFTER_ENV]
        arms = [
            robot(str(scenario), arm, port, case / f"{arm}.err", "--journal", str(case / arm))
            for arm in ("left", "right")
        ]
        procs = [manager, *arms]
        try:
            assert manager.wait(60) == -signal.SIGKILL
            assert len(rows(store)) == n
            ready = case / "cell2.ready"
            resumed = start_resumed(str(scenario), store, port, case, ready)
            procs.append(resumed)
            data = finish(resumed)
            for arm in arms:
                assert arm.wait(30) == 0
        finally:
            kill_all(procs)
        _same_result(data, ref, n)
        events = _sound_store(store)
        issued = {e.body["id"] for e in events if e.kind == "command"}
        started = [
            line["id"]
            for arm in ("left", "right")
            for line in _journal(case / arm)
            if line.get("event") == "start"
        ]
        assert len(started) == len(set(started)), f"N={n}: a command was executed twice"
        assert set(started) == issued, f"N={n}: not every command was executed once"


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
