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
that ``flexhrc replay FILE.db`` can rebuild the summary of ``flexhrc replay LOG.jsonl``.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
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
            self._open(option)
        except StoreError:
            os.close(self._lock_fd)  # (the lock with it)
            raise

    def _open(self, option: str) -> None:
        try:
            self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA journal_mode=WAL")
            # NORMAL in WAL mode: a committed event survives the process being killed (the
            # WAL is written before commit returns); only a power loss may drop the last ones.
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute(SCHEMA)
            row = self._db.execute("SELECT COALESCE(MAX(seq), 0), COUNT(*) FROM events").fetchone()
            problem = None
            if not _has_events_table(self._db):
                problem = "not a flexhrc event store (no events table)"
            elif type(row[0]) is not int:
                problem = (
                    f"not a flexhrc event store (a seq that is not an integer: {row[0]!r:.40})"
                )
            elif row[0] != row[1]:
                problem = f"seq has gaps ({row[1]} rows, last {row[0]})"
        except sqlite3.DatabaseError as exc:
            problem = f"not a flexhrc event store ({exc})"
        if problem is not None:
            with contextlib.suppress(sqlite3.Error, AttributeError):
                self._db.close()
            raise StoreError(f"{option} {self.path}: {problem}")
        self.last_seq = row[0]

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
        """Every event stored so far; a corrupted row is a :class:`StoreError` naming the file
        and the row's ``seq``."""
        try:
            return list(iter_events(self._db, self.path))
        except FormatError as exc:
            raise StoreError(f"{self.option} {exc}") from None
        except sqlite3.DatabaseError as exc:
            raise StoreError(
                f"{self.option} {self.path}: not a flexhrc event store ({exc})"
            ) from None

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


def _has_events_table(db: sqlite3.Connection) -> bool:
    cols = {r[1] for r in db.execute("PRAGMA table_info(events)")}
    return {"seq", "t", "kind", "body"} <= cols


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def iter_events(db: sqlite3.Connection, source: str | Path = "<store>") -> Iterator[StoredEvent]:
    """The events of a store in ``seq`` order, each row checked as the store writes it (an
    integer ``seq``, a finite time ``t``, a ``kind`` name, a JSON object ``body``); a row
    that is not is a :class:`FormatError` naming ``source`` and the row's ``seq``. SQLite
    keeps whatever a column is given, so an edited or damaged file can hold anything."""
    for seq, t, kind, body in db.execute("SELECT seq, t, kind, body FROM events ORDER BY seq"):
        if type(seq) is not int:
            raise FormatError(f"an event's seq is not an integer ({seq!r:.40})", source)
        if type(t) not in (int, float) or not math.isfinite(t):
            raise FormatError(f"event {seq}: t must be a finite time, got {t!r:.40}", source)
        if type(kind) is not str or not kind:
            raise FormatError(f"event {seq}: kind must be a name, got {kind!r:.40}", source)
        if type(body) is not str:
            raise FormatError(f"event {seq} ({kind}): the body is not JSON text", source)
        try:
            data = json.loads(body, parse_constant=_refuse_constant)
        except RecursionError:
            raise FormatError(
                f"event {seq} ({kind}): the body is nested too deeply", source
            ) from None
        except ValueError as exc:  # (JSONDecodeError among them)
            raise FormatError(
                f"event {seq} ({kind}): the body is not JSON ({exc})", source
            ) from None
        if not isinstance(data, dict):
            raise FormatError(f"event {seq} ({kind}): the body must be a JSON object", source)
        yield StoredEvent(seq, float(t), kind, data)


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
            if not _has_events_table(db):
                raise FormatError("not a flexhrc event store (no events table)", p)
            events = list(iter_events(db, p))
        finally:
            db.close()
    except sqlite3.DatabaseError as exc:
        raise FormatError(f"not a flexhrc event store ({exc})", p) from None
    return events


def is_store(path: str | Path) -> bool:
    """Does the file start with the SQLite header (so ``replay`` reads it as a store)?"""
    try:
        with open(path, "rb") as fh:
            return fh.read(16) == b"SQLite format 3\x00"
    except OSError:
        return False


#: The fields :func:`log_events` reads of a stored body, by kind: (key, test, what it must be).
_LOG_FIELDS: dict[str, tuple[tuple[str, Any, str], ...]] = {
    "command": (
        ("id", lambda v: type(v) is int, "an integer"),
        ("agents", lambda v: isinstance(v, list), "a list of agents"),
        ("action", lambda v: isinstance(v, str), "an action"),
    ),
    "ack": (
        ("id", lambda v: type(v) is int, "an integer"),
        ("status", lambda v: isinstance(v, str), "a status"),
    ),
    "human_action": (
        ("action", lambda v: isinstance(v, str), "an action"),
        ("start", lambda v: type(v) in (int, float) and math.isfinite(v), "a finite time"),
    ),
    "stop": (("id", lambda v: type(v) is int, "an integer"),),
}
_OPTIONAL = {("human_action", "start")}


def _readable(ev: StoredEvent, source: str | Path) -> None:
    """Raise a :class:`FormatError` naming the event when a field :func:`log_events` reads
    is missing or of the wrong type (a damaged store)."""
    for key, ok, what in _LOG_FIELDS.get(ev.kind, ()):
        if key not in ev.body:
            if (ev.kind, key) in _OPTIONAL:
                continue
            raise FormatError(f"event {ev.seq} ({ev.kind}): missing {key!r}", source)
        if not ok(ev.body[key]):
            raise FormatError(
                f"event {ev.seq} ({ev.kind}): {key!r} must be {what}, not {ev.body[key]!r:.40}",
                source,
            )


def log_events(events: list[StoredEvent], source: str | Path | None = None) -> list[dict[str, Any]]:
    """The store as the JSON-lines events of ``flexhrc run --log`` (``start``, ``decision``,
    ``command``, ``action_start``/``action_end``, ``outcome``, ``summary`` ...), for
    :func:`~flexhrc.taskmanager.replay.summarise_log` and the timeline plot. Cell-only kinds
    (``agent_up``/``agent_down``, ``human_action`` inputs) become the runner's events or are
    left out. With ``source`` (a store read from disk) every field read is checked first: a
    damaged one is a :class:`FormatError` naming ``source`` and the event's ``seq``."""
    out: list[dict[str, Any]] = []
    commands: dict[int, tuple[float, dict[str, Any]]] = {}
    for ev in events:
        if source is not None:
            _readable(ev, source)
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
    log = log_events(events, path)
    check_log([(i + 1, ev) for i, ev in enumerate(log)], f"{path} (as a log, event)")
    return log


def summarise_store(path: str | Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """``flexhrc replay FILE.db``: the summary (same keys as ``flexhrc replay LOG``) and the
    events in log form."""
    from flexhrc.taskmanager.replay import summarise_log

    log = store_log(path)
    return summarise_log(log), log
