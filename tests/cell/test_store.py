"""The SQLite event store: schema contract, gap-free seq, clear errors, replay FILE.db."""

from __future__ import annotations

import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from flexhrc.cell.store import EventStore, StoreError, is_store, read_store
from flexhrc.errors import FormatError

from ..conftest import subprocess_env


def test_schema_seq_and_resume(tmp_path: Path) -> None:
    path = tmp_path / "s.db"
    with EventStore(path) as store:
        assert store.append("start", {"agents": ["left"]}, 0.0) == 1
        assert store.append("ack", {"id": 1, "status": "done"}, 1.5) == 2
    db = sqlite3.connect(path)
    cols = [(r[1], r[2]) for r in db.execute("PRAGMA table_info(events)")]
    assert cols == [("seq", "INTEGER"), ("t", "REAL"), ("kind", "TEXT"), ("body", "TEXT")]
    assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    db.close()
    with pytest.raises(StoreError, match="already exists; add --resume"):
        EventStore(path)
    with EventStore(path, resume=True) as store:
        assert store.append("ack", {"id": 2, "status": "failed"}, 2.0) == 3
    events = read_store(path)
    assert [e.seq for e in events] == [1, 2, 3]
    assert events[1].body == {"id": 1, "status": "done"} and events[1].is_input
    assert is_store(path)


def test_one_writer_per_store(tmp_path: Path) -> None:
    path = tmp_path / "s.db"
    with EventStore(path), pytest.raises(StoreError, match="in use"):
        EventStore(path, resume=True)


def test_bad_paths_and_files(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="no such store"):
        EventStore(tmp_path / "none.db", resume=True)
    with pytest.raises(Exception, match="unsupported output format"):
        EventStore(tmp_path / "s.txt")
    with pytest.raises(Exception, match="does not exist"):
        EventStore(tmp_path / "no" / "s.db")
    junk = tmp_path / "junk.db"
    junk.write_bytes(b"SQLite format 3\x00" + b"\x07" * 200)
    with pytest.raises(FormatError, match="not a flexhrc event store"):
        read_store(junk)
    other = tmp_path / "other.db"
    sqlite3.connect(other).execute("CREATE TABLE x(a)").connection.commit()
    with pytest.raises(FormatError, match="no events table"):
        read_store(other)


def test_replay_of_a_store_prints_the_log_summary(tmp_path: Path) -> None:
    store = tmp_path / "cell.db"
    env = subprocess_env()
    run = subprocess.run(
        [sys.executable, "-m", "flexhrc", "cell", "table_assembly", "--store", str(store),
         "--json", "--quiet"],
        capture_output=True, text=True, env=env, timeout=120,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    rep = subprocess.run(
        [sys.executable, "-m", "flexhrc", "replay", str(store), "--json"],
        capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip
    assert rep.returncode == 0, rep.stderr
    import json

    cell, replay = json.loads(run.stdout), json.loads(rep.stdout)
    for key in ("outcome", "robot_actions", "human_actions", "decisions", "branches_simulated"):
        assert replay[key] == cell[key], key
    assert replay["timing"]["total_s"] == cell["timing"]["total_s"]
    assert replay["legs_by_agent"] == cell["legs_by_agent"]
    # a second run on the same store is refused before any work; --resume of an ended one adds
    # nothing
    again = subprocess.run(
        [sys.executable, "-m", "flexhrc", "cell", "table", "--store", str(store)],
        capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip
    assert again.returncode == 2 and "already exists" in again.stderr
    assert "Traceback" not in again.stderr
    n = len(read_store(store))
    resumed = subprocess.run(
        [sys.executable, "-m", "flexhrc", "cell", "table", "--store", str(store), "--resume",
         "--json", "--quiet"],
        capture_output=True, text=True, env=env, timeout=60,
    )  # fmt: skip
    assert resumed.returncode == 0 and json.loads(resumed.stdout)["outcome"] == "solved"
    assert len(read_store(store)) == n


def test_replay_of_a_broken_store_is_one_clear_error(tmp_path: Path) -> None:
    junk = tmp_path / "junk.db"
    junk.write_bytes(b"SQLite format 3\x00" + b"\x07" * 500)
    empty = tmp_path / "empty.db"
    EventStore(empty).close()
    for path, message in ((junk, "not a flexhrc event store"), (empty, "empty store")):
        res = subprocess.run(
            [sys.executable, "-m", "flexhrc", "replay", str(path)],
            capture_output=True, text=True, env=subprocess_env(), timeout=60,
        )  # fmt: skip
        assert res.returncode == 2, res.stderr
        assert message in res.stderr and str(path) in res.stderr
        assert "Traceback" not in res.stderr
