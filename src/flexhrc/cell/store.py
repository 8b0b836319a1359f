"""The cell's event store: every input of the Task Manager, committed before it acts on it.

Event sourcing (``docs/cell.md``): the Task Manager is deterministic given its inputs, so a
crashed cell is rebuilt by replaying the stored inputs into a fresh manager. The store is one
SQLite file (stdlib :mod:`sqlite3`, write-ahead log, one transaction per event) with the schema
contract of issue 11::

    CREATE TABLE events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)

``seq`` counts from 1 without gaps, ``t`` is the cell's clock (simulated seconds), ``body`` is a
JSON object. The kinds are catalogued in :data:`flexhrc.events.STORE_KINDS`. Input kinds:
``start``, ``ack`` (body: ``id``, ``status``, ``reason``, ``agent``, ``positions``),
``human_action``, ``percept``, ``agent_up``, ``agent_down``, ``operator``, ``intent``,
``human_take``. Output kinds: ``command``, ``suggestion``, ``stop``, ``options``; the manager's
``decision``, ``solved``, ``outcome`` ... records and a closing ``summary`` are stored too so
that ``flexhrc replay FILE.db`` can rebuild the summary of ``flexhrc replay LOG.jsonl``. Every
body the cell writes names its run (``"run"``, :mod:`flexhrc.cell.identity`); a row without it
was written before run ids existed.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import INPUT_KINDS, REPLAY_TYPES
from flexhrc.files import check_output

SCHEMA = "CREATE TABLE IF NOT EXISTS events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)"


class StoreError(FlexhrcError):
    """A store that cannot be opened, written or read; the message names the file."""


@dataclass(frozen=True)
class StoredEvent:
    seq: int
    t: float
    kind: str
    body: dict[str, Any]

    @property
    def is_input(self) -> bool:
        return self.kind in INPUT_KINDS


class EventStore:
    """Append-only SQLite event log (see the module docstring).

    ``EventStore(path)`` creates a new store (refusing an existing non-empty one unless
    ``resume=True``, which opens it to continue). ``append`` commits one event and returns its
    ``seq``.
    """

    def __init__(self, path: str | Path, *, resume: bool = False, option: str = "--store"):
        self.path = Path(path)
        self.option = option
        exists = self.path.exists() and self.path.stat().st_size > 0
        if resume and not exists:
            raise StoreError(f"{option} {self.path}: no such store to resume")
        if not resume:
            check_output(self.path, option=option, suffixes=(".db", ".sqlite", ".sqlite3"))
            if exists:
                raise StoreError(
                    f"{option} {self.path}: the store already exists; add --resume to continue "
                    "it or choose a new file"
                )
        # one manager per store: a second one would interleave its seq numbers with ours
        try:
            self._lock_fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o666)
        except OSError as exc:
            raise StoreError(f"{option} {self.path}: cannot write: {exc.strerror or exc}") from None
        try:
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self._lock_fd)
            raise StoreError(
                f"{option} {self.path}: in use by another running cell (the file is locked)"
            ) from None
        try:
            self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            # NORMAL in WAL mode: a committed event survives the process being killed (the
            # WAL is written before commit returns); only a power loss may drop the last ones.
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute(SCHEMA)
            row = self._db.execute("SELECT COALESCE(MAX(seq), 0), COUNT(*) FROM events").fetchone()
        except sqlite3.DatabaseError as exc:
            raise StoreError(f"{option} {self.path}: not a flexhrc event store ({exc})") from None
        self.last_seq = int(row[0])
        if int(row[1]) != self.last_seq:
            raise StoreError(f"{option} {self.path}: seq has gaps ({row[1]} rows, last {row[0]})")

    def append(self, kind: str, body: dict[str, Any], t: float) -> int:
        """Commit one event; returns its ``seq`` (the previous one + 1)."""
        text = json.dumps(body, allow_nan=False, separators=(",", ":"))
        seq = self.last_seq + 1
        try:
            self._db.execute(
                "INSERT INTO events(seq, t, kind, body) VALUES (?, ?, ?, ?)",
                (seq, float(t), kind, text),
            )
        except sqlite3.Error as exc:
            raise StoreError(f"{self.option} {self.path}: cannot write: {exc}") from None
        self.last_seq = seq
        return seq

    def events(self) -> list[StoredEvent]:
        return list(iter_events(self._db))

    def close(self) -> None:
        with contextlib.suppress(sqlite3.Error):
            self._db.close()
        if self._lock_fd >= 0:
            os.close(self._lock_fd)  # releases the lock
            self._lock_fd = -1

    def __enter__(self) -> EventStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def iter_events(db: sqlite3.Connection) -> Iterator[StoredEvent]:
    for seq, t, kind, body in db.execute("SELECT seq, t, kind, body FROM events ORDER BY seq"):
        yield StoredEvent(int(seq), float(t), str(kind), json.loads(body))


def read_store(path: str | Path) -> list[StoredEvent]:
    """Every event of a store, read-only; one clear error for a file that is not a store."""
    p = Path(path)
    if not p.is_file():
        raise FormatError("no such file" if not p.exists() else "is not a file", p)
    if not os.access(p, os.R_OK):
        raise FormatError("cannot read: permission denied", p)
    try:
        db = sqlite3.connect(f"file:{p}?mode=ro", uri=True)
        try:
            cols = [r[1] for r in db.execute("PRAGMA table_info(events)")]
            if cols[:4] != ["seq", "t", "kind", "body"]:
                raise FormatError("not a flexhrc event store (no events table)", p)
            events = list(iter_events(db))
        finally:
            db.close()
    except sqlite3.DatabaseError as exc:
        raise FormatError(f"not a flexhrc event store ({exc})", p) from None
    except json.JSONDecodeError as exc:
        raise FormatError(f"an event body is not JSON ({exc})", p) from None
    return events


def is_store(path: str | Path) -> bool:
    """Does the file start with the SQLite header (so ``replay`` reads it as a store)?"""
    try:
        with open(path, "rb") as fh:
            return fh.read(16) == b"SQLite format 3\x00"
    except OSError:
        return False


def log_events(events: list[StoredEvent]) -> list[dict[str, Any]]:
    """The store as the JSON-lines events of ``flexhrc run --log`` (``start``, ``decision``,
    ``command``, ``action_start``/``action_end``, ``outcome``, ``summary`` ...), for
    :func:`~flexhrc.taskmanager.replay.summarise_log` and the timeline plot. Cell-only kinds
    (``agent_up``/``agent_down``, ``human_action`` inputs) become the runner's events or are
    left out."""
    out: list[dict[str, Any]] = []
    commands: dict[int, tuple[float, dict[str, Any]]] = {}
    for ev in events:
        b = ev.body
        t = round(ev.t, 6)
        if ev.kind == "start":
            out.append({"profile": "cell", **b, "t": t, "type": "start"})
        elif ev.kind == "command":
            commands[int(b["id"])] = (ev.t, b)
            out.append({**b, "t": t, "type": "command"})
            out.append(
                {
                    "t": t,
                    "type": "action_start",
                    "agents": b["agents"],
                    "action": b["action"],
                    "command": b["id"],
                    "element": b.get("element"),
                }
            )
        elif ev.kind == "ack":
            start, cmd = commands.get(int(b["id"]), (ev.t, {"agents": [b.get("agent")]}))
            out.append(
                {
                    "t": t,
                    "type": "action_end",
                    "agents": cmd["agents"],
                    "action": cmd.get("action", "?"),
                    "command": b["id"],
                    "status": b["status"],
                    "start": round(min(start, ev.t), 6),
                    "reason": b.get("reason"),
                    "element": cmd.get("element"),
                }
            )
        elif ev.kind == "human_action":
            start = min(float(b.get("start", ev.t)), ev.t)
            out.append(
                {
                    "t": t,
                    "type": "action_end",
                    "agents": [b.get("agent", "human")],
                    "action": b["action"],
                    "status": "done",
                    "start": round(start, 6),
                }
            )
        elif ev.kind in REPLAY_TYPES:
            out.append({**b, "t": t, "type": ev.kind})
            stopped = commands.pop(int(b["id"]), None) if ev.kind == "stop" else None
            if stopped is not None:  # the arm was busy until the stop (its ack never counts)
                start, cmd = stopped
                out.append(
                    {
                        "t": t,
                        "type": "action_end",
                        "agents": cmd["agents"],
                        "action": cmd.get("action", "?"),
                        "command": b["id"],
                        "status": "stopped",
                        "start": round(min(start, ev.t), 6),
                        "reason": b.get("reason"),
                    }
                )
    return out


def store_log(path: str | Path) -> list[dict[str, Any]]:
    """A store read as a cooperation log, validated like one (``flexhrc replay FILE.db``);
    a bad event is a :class:`FormatError` naming the store and the event's ``seq``."""
    from flexhrc.taskmanager.replay import check_log

    events = read_store(path)
    if not events:
        raise FormatError("empty store", path)
    log = log_events(events)
    check_log([(i + 1, ev) for i, ev in enumerate(log)], f"{path} (as a log, event)")
    return log


def summarise_store(path: str | Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """``flexhrc replay FILE.db``: the summary (same keys as ``flexhrc replay LOG``) and the
    events in log form."""
    from flexhrc.taskmanager.replay import summarise_log

    log = store_log(path)
    return summarise_log(log), log
