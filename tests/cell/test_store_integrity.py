"""Store integrity (probe 2026-12-02, sections 8 and 13, ST42): a corrupted row is one clear
error naming the store and the row's seq, on ``replay`` and on ``--resume`` alike — never a
traceback, never a hang; a resume of an ended run appends nothing; a store deleted under a
running cell is not reported as written; a store copied without its ``-wal`` says so."""

from __future__ import annotations

import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import protocol as P
from flexhrc.cell.replay import replay
from flexhrc.cell.serve import CellConfig, serve_cell, summary_line
from flexhrc.cell.store import read_store
from flexhrc.errors import FlexhrcError
from flexhrc.scenario import load_scenario

from ..conftest import subprocess_env
from .helpers import simulated_agents

TABLE = load_scenario("table_assembly")


@pytest.fixture(scope="module")
def full_store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished table-assembly store (76 rows; seq 4 is the first ack)."""
    path = tmp_path_factory.mktemp("store") / "full.db"
    assert serve_cell(TABLE, CellConfig(store=path))["outcome"] == "solved"
    return path


def _cut(full: Path, path: Path, rows: int = 28) -> Path:
    """A store of a cell killed after ``rows`` events (the probe's 28-event store)."""
    shutil.copy(full, path)
    db = sqlite3.connect(path)
    db.execute("DELETE FROM events WHERE seq > ?", (rows,))
    db.commit()
    db.close()
    return path


def _edit(path: Path, *sql: str) -> None:
    db = sqlite3.connect(path)
    for statement in sql:
        db.executescript(statement) if ";" in statement else db.execute(statement)
    db.commit()
    db.close()


# (case, the change, what the one error says) — "event 4": the row's seq is named
CORRUPT = [
    ("ST01", "UPDATE events SET body='{not json' WHERE seq=4", "event 4 (ack): the body is not JSON"),
    ("ST02", "UPDATE events SET body='[1,2]' WHERE seq=4",
     "event 4 (ack): the body must be a JSON object, not list"),
    ("ST03", "UPDATE events SET t=NULL WHERE seq=4",
     "event 4 (ack): 't' must be a finite time >= 0, got None"),
    ("ST04", "UPDATE events SET t='abc' WHERE seq=4",
     "event 4 (ack): 't' must be a finite time >= 0, got 'abc'"),
    ("ST07", "UPDATE events SET kind='teleport' WHERE seq=4", "event 4: unknown kind 'teleport'"),
    ("ST08", "UPDATE events SET body=json_remove(body, '$.status') WHERE seq=4",
     "event 4 (ack): ack: missing field 'status'"),
    ("ST09", "UPDATE events SET body=json_set(body, '$.id', 'abc') WHERE seq=4",
     "event 4 (ack): ack: field 'id' must be int"),
    ("ST10", "UPDATE events SET body=json_set(body, '$.id', 999) WHERE seq=4",
     "event 4 (ack): an ack for command 999, which the store never issued"),
    ("ST11", "UPDATE events SET body=json_set(body, '$.status', 'exploded') WHERE seq=4",
     "event 4 (ack): ack: status must be one of"),
    ("ST12", "UPDATE events SET body='[]' WHERE seq=1",
     "event 1 (start): the body must be a JSON object, not list"),
    # the first ack again as the last row (at its own, earlier, time)
    ("ST15", "INSERT INTO events SELECT 29, t, kind, body FROM events WHERE seq=4",
     "event 29 (ack): time goes back"),
    # ...and at a later time: a second answer to one command
    ("ST15b", "INSERT INTO events SELECT 29, 30.0, kind, body FROM events WHERE seq=4",
     "event 29 (ack): a second ack for command 1 (the first is event 4)"),
    ("ST17", "CREATE TABLE e2 AS SELECT seq, kind, body FROM events; DROP TABLE events; "
     "CREATE TABLE events(seq INTEGER PRIMARY KEY, kind TEXT, body TEXT); "
     "INSERT INTO events SELECT * FROM e2; DROP TABLE e2;",
     "not a flexhrc event store (no events table)"),
    ("ST_agent", "UPDATE events SET body=json_set(body, '$.agent', 'robot9') WHERE seq=4",
     "event 4 (ack): 'robot9' is not an agent of this run"),
    ("ST_start2", "UPDATE events SET kind='start' WHERE seq=2",
     "event 2 (start): a second 'start' event (the first is event 1)"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "sql", "message"), CORRUPT, ids=[c[0] for c in CORRUPT])
def test_st01_st17_a_corrupted_row_is_one_clear_error_on_resume_and_replay(
    full_store: Path, tmp_path: Path, case: str, sql: str, message: str
) -> None:
    path = _cut(full_store, tmp_path / f"{case}.db")
    _edit(path, sql)
    with pytest.raises(FlexhrcError) as replayed:
        replay(path)
    assert str(path) in str(replayed.value) and message in str(replayed.value)
    rows = sqlite3.connect(path).execute("SELECT COUNT(*) FROM events").fetchone()[0]
    # ST07r, ST10r, ST11r hung: the resume now refuses the store before any work
    with pytest.raises(FlexhrcError) as resumed:
        serve_cell(TABLE, CellConfig(store=path, resume=True))
    assert str(path) in str(resumed.value) and message in str(resumed.value)
    assert sqlite3.connect(path).execute("SELECT COUNT(*) FROM events").fetchone()[0] == rows


def test_st05p_replay_names_the_gap(full_store: Path, tmp_path: Path) -> None:
    path = _cut(full_store, tmp_path / "gap.db")
    _edit(path, "DELETE FROM events WHERE seq=10")
    with pytest.raises(FlexhrcError, match=r"gap.db: seq has gaps: no event 10 \(the next is 11\)"):
        replay(path)
    with pytest.raises(FlexhrcError, match=r"seq has gaps \(27 rows, last 28\)"):
        serve_cell(TABLE, CellConfig(store=path, resume=True))


@pytest.mark.parametrize("case", ["ST01", "ST10", "ST11"])
def test_the_commands_exit_2_without_a_traceback(
    full_store: Path, tmp_path: Path, case: str
) -> None:
    sql, message = next((s, m) for c, s, m in CORRUPT if c == case)
    path = _cut(full_store, tmp_path / f"{case}.db")
    _edit(path, sql)
    for args in (["replay", str(path)], ["cell", "table_assembly", "--store", str(path),
                                          "--resume", "--quiet"]):  # fmt: skip
        res = subprocess.run(
            [sys.executable, "-m", "flexhrc", *args],
            capture_output=True, text=True, env=subprocess_env(), timeout=60,
        )  # fmt: skip
        assert res.returncode == 2, res.stderr
        assert "Traceback" not in res.stderr
        assert res.stderr.startswith("error: ") and message in res.stderr, res.stderr


@pytest.mark.parametrize("where", [b"CREATE", b"KEY"])
def test_a_store_whose_schema_has_a_damaged_byte_is_one_clear_error(
    full_store: Path, tmp_path: Path, where: bytes
) -> None:
    """One byte of the table's schema text changed (fuzz, store target): SQLite's error
    quotes the damaged text, which is no UTF-8 any more, so Python's sqlite3 raised
    UnicodeDecodeError from the query itself — a traceback of ``replay`` and ``--resume``."""
    data = bytearray(full_store.read_bytes())
    at = data.find(b"CREATE TABLE events(")
    at = data.find(where, at)
    data[at + 2] = 0xC5  # a lead byte followed by no continuation byte
    path = tmp_path / "damaged.db"
    path.write_bytes(bytes(data))
    for args in (["replay", str(path)], ["cell", "table_assembly", "--store", str(path),
                                          "--resume", "--quiet"]):  # fmt: skip
        res = subprocess.run(
            [sys.executable, "-m", "flexhrc", *args],
            capture_output=True, text=True, env=subprocess_env(), timeout=60,
        )  # fmt: skip
        assert res.returncode == 2, res.stderr
        assert "Traceback" not in res.stderr, res.stderr
        assert res.stderr.startswith("error: ") and str(path) in res.stderr, res.stderr
        assert "not a flexhrc event store (its schema is damaged" in res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    with pytest.raises(FlexhrcError, match="its schema is damaged"):
        read_store(path)


class Spoof:
    """A perception process that reports, once the cell has started, that leg1 is not where
    the knowledge base has it: the knowledge base is inconsistent and the cooperation fails at
    once (a deadlock). (The probe's spoof.py percept_contra, the tabletop reported as a leg, is
    refused since P21.)"""

    def __init__(self, cell: Any) -> None:
        self.cell, self.sent = cell, False

    def poll(self) -> None:
        if self.cell.started and not self.sent:
            self.sent = True
            percept = P.message(
                "percept", id="p1", object="leg1", object_type="leg", pose=[0.5, 0.0, 0.0],
                contradicts="leg1 is not where the knowledge base has it",
            )  # fmt: skip
            self.cell.transport.publish(P.PERCEPT_TOPIC, percept)

    def close(self) -> None:
        pass


def test_st32_resuming_a_failed_run_appends_nothing(tmp_path: Path) -> None:
    path = tmp_path / "dead.db"
    data = serve_cell(TABLE, CellConfig(store=path), attach=[Spoof])
    assert data["outcome"] == "failed" and "deadlock" in data["reason"]
    stored = read_store(path)
    said: list[str] = []
    for _ in range(2):  # each further resume used to add another outcome and summary
        again = serve_cell(TABLE, CellConfig(store=path, resume=True), progress=said.append)
        assert (again["outcome"], again["reason"]) == (data["outcome"], data["reason"])
    assert said == ["the stored cooperation already ended: failed"] * 2
    assert read_store(path) == stored
    assert replay(path).json["outcome"] == "failed"


def test_a_crash_between_the_outcome_and_the_summary_is_completed_once(
    full_store: Path, tmp_path: Path
) -> None:
    path = tmp_path / "nosummary.db"
    shutil.copy(full_store, path)
    _edit(path, "DELETE FROM events WHERE kind='summary'")
    n = len(read_store(path))
    assert serve_cell(TABLE, CellConfig(store=path, resume=True))["outcome"] == "solved"
    assert [e.kind for e in read_store(path)][n - 1 :] == ["outcome", "summary"]
    serve_cell(TABLE, CellConfig(store=path, resume=True))
    assert len(read_store(path)) == n + 1
    assert replay(path).json["compute_recorded"]


class Deleter:
    """Someone deletes the store (and its -wal, -shm) while the cell runs (probe ST49)."""

    def __init__(self, cell: Any, path: Path) -> None:
        self.cell, self.path, self.done = cell, path, False

    def poll(self) -> None:
        if len(self.cell.events) > 5 and not self.done:
            self.done = True
            for suffix in ("", "-wal", "-shm"):
                Path(f"{self.path}{suffix}").unlink(missing_ok=True)

    def close(self) -> None:
        pass


def test_st49_a_store_deleted_while_the_cell_runs_is_not_reported_as_written(
    tmp_path: Path,
) -> None:
    path = tmp_path / "del.db"
    said: list[str] = []
    data = serve_cell(
        TABLE,
        CellConfig(store=path),
        progress=said.append,
        attach=[lambda cell: Deleter(cell, path)],
    )
    assert data["outcome"] == "solved" and not path.exists()
    lost = data["cell"]["store_lost"]
    assert "del.db was deleted or replaced while the cell ran" in lost
    assert "cannot be resumed" in lost
    assert [line for line in said if line.startswith("warning:")] == [f"warning: {lost}"]
    line = summary_line(data, path)
    assert f"in {path}" not in line and "NOT STORED" in line


def test_an_intact_store_reports_nothing_lost(full_store: Path) -> None:
    data = serve_cell(TABLE, CellConfig(store=full_store, resume=True))
    assert "store_lost" not in data["cell"]


def test_st42_a_store_copied_without_its_wal_says_so(tmp_path: Path) -> None:
    """The store of a killed cell keeps its events in FILE.db-wal: a copy of FILE.db alone."""
    import os
    import signal

    from flexhrc.cell.store import CRASH_AFTER_ENV

    path = tmp_path / "killed.db"
    pid = os.fork()
    if pid == 0:  # pragma: no cover - the child: the cell, killed after 28 events
        try:
            os.environ[CRASH_AFTER_ENV] = "28"
            serve_cell(TABLE, CellConfig(store=path))
        finally:
            os._exit(3)
    _, status = os.waitpid(pid, 0)
    assert os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
    copy = tmp_path / "copy.db"
    shutil.copy(path, copy)  # without killed.db-wal
    hint = "copy copy.db-wal with it"
    with pytest.raises(FlexhrcError, match=hint):
        replay(copy)
    with pytest.raises(FlexhrcError, match=hint):
        serve_cell(TABLE, CellConfig(store=copy, resume=True))
    shutil.copy(f"{path}-wal", f"{copy}-wal")  # with it, all 28 events are there
    assert len(read_store(copy)) == 28
    data = serve_cell(TABLE, CellConfig(store=copy, resume=True))
    assert data["outcome"] == "solved" and data["cell"]["resumed"]


# -- K06: a manager stalled longer than the liveliness lease ------------------------------------
class LeaseBus:
    """The in-process bus with liveliness tokens, delivered in order with the messages; while
    ``lapsed`` the manager's session is gone: the acks agents send are lost on the way."""

    def __init__(self) -> None:
        from flexhrc.transport import InProcessBus

        self.bus = InProcessBus()
        self.tokens: set[str] = set()
        self.lapsed = False
        self.lost_acks = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(self.bus, name)

    def publish(self, topic: str, payload: Any) -> None:
        if self.lapsed and topic == P.ACK_TOPIC:
            self.lost_acks += 1
            return
        self.bus.publish(topic, payload)

    def declare_token(self, key: str) -> Any:
        from types import SimpleNamespace

        self.tokens.add(key)
        self.bus.publish("liveliness", (key, True))
        return SimpleNamespace(undeclare=lambda: self.tokens.discard(key))

    def watch_liveliness(self, pattern: str, callback: Any, *, history: bool = True) -> Any:
        from fnmatch import fnmatchcase

        def relay(event: tuple[str, bool]) -> None:
            if fnmatchcase(event[0], pattern):
                callback(*event)

        for key in sorted(self.tokens) if history else ():
            callback(key, True)
        return self.bus.subscribe("liveliness", relay)

    def wait(self, timeout: float) -> None:
        """Nothing arrives from elsewhere: the next flush delivers what is queued."""


class FakeClock:
    """``time`` for the cell's module, with a monotonic clock the test moves (a stall)."""

    def __init__(self) -> None:
        import time

        self.real, self.offset = time, 0.0

    def monotonic(self) -> float:
        return self.real.monotonic() + self.offset

    def __getattr__(self, name: str) -> Any:
        return getattr(self.real, name)


@pytest.mark.parametrize("back", [("human", "left", "right"), ("human", "left")])
def test_k06_a_stalled_manager_counts_the_work_that_was_done(
    monkeypatch: pytest.MonkeyPatch, back: tuple[str, ...]
) -> None:
    """The manager does not run for 12 s (longer than the lease) while the left arm executes
    a command: when it wakes every token is gone (its own session lapsed) and the ack the arm
    sent meanwhile was lost. The tokens that come back are agents that were there all along:
    nothing is recorded lost, the done command counts (its ack is asked for again). A token
    that does not come back within the grace is a lost agent, as before."""
    from flexhrc.cell import Cell
    from flexhrc.cell import supervisor as S
    from flexhrc.cell.components import execution_model

    scenario = load_scenario("table_assembly")
    ref = serve_cell(scenario, CellConfig())
    clock = FakeClock()
    monkeypatch.setattr(S, "time", clock)
    bus = LeaseBus()
    cell = Cell(scenario, bus, simulator=execution_model("analytic"))  # type: ignore[arg-type]
    agents = simulated_agents(scenario, bus)
    phase = ["run"]

    def pump(timeout: float) -> None:
        if phase[0] == "run" and "left" in cell.tm.busy and len(cell.events) > 12:
            phase[0] = "stalled"  # SIGSTOP: 12 s pass, the lease lapses, every token goes
            clock.offset += 12.0
            bus.lapsed = True
            for name in cell.agents:
                bus.bus.publish("liveliness", (f"alive/{name}", False))
        elif phase[0] == "stalled":
            phase[0] = "woken"  # SIGCONT: the agents that are there re-dial
            bus.lapsed = False
            for name in back:
                bus.bus.publish("liveliness", (f"alive/{name}", True))
        elif phase[0] == "woken":
            clock.offset += 0.5  # time goes on: a token that is not back is lost after a grace
        bus.flush()
        for agent in agents:
            if agent.name in back or phase[0] == "run":
                agent.poll()

    data = cell.run(pump=pump)
    assert bus.lost_acks >= 1  # the arm's answer during the stall was lost on the way
    downs = [e.body["agent"] for e in cell.events if e.kind == "agent_down"]
    failed = [e.body for e in cell.events if e.kind == "ack" and e.body["status"] != "done"]
    if len(back) == 3:
        assert downs == [] and failed == []
        assert data["outcome"] == "solved"
        assert data["knowledge"] == ref["knowledge"]
        assert data["by_agent"] == ref["by_agent"]
        assert data["timing"]["total_s"] == ref["timing"]["total_s"]
    else:  # right never came back: lost once the grace passed, and only right
        assert downs == ["right"]
        assert all(b["agent"] == "right" and b["reason"] == "agent lost" for b in failed)
