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

``--resume`` and ``replay`` read a store through the same checks (:func:`iter_events` for each
row, :func:`check_events` for the whole): a corrupted store is one :class:`FormatError` naming
the file and the row's ``seq``, never a traceback or a manager that waits for ever.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import math
import os
import signal
import sqlite3
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.events import INPUT_KINDS, MESSAGES, REPLAY_TYPES, STORE_KINDS
from flexhrc.files import check_output

SCHEMA = "CREATE TABLE IF NOT EXISTS events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)"


#: Test facility (``docs/cell.md``): with ``FLEXHRC_CRASH_AFTER=N`` in its environment, a
#: process that writes a store SIGKILLs itself right after committing the event whose ``seq`` is
#: ``N``, so a test can crash a manager at every point of a run and resume it.
CRASH_AFTER_ENV = "FLEXHRC_CRASH_AFTER"


def crash_after() -> int | None:
    """The ``seq`` after which this process kills itself (:data:`CRASH_AFTER_ENV`), if set."""
    text = os.environ.get(CRASH_AFTER_ENV, "").strip()
    if not text:
        return None
    try:
        n = int(text)
    except ValueError:
        raise FlexhrcError(f"{CRASH_AFTER_ENV}={text!r}: expected a whole number >= 1") from None
    if n < 1:
        raise FlexhrcError(f"{CRASH_AFTER_ENV}={text!r}: expected a whole number >= 1")
    return n


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
            raise self._refuse("in use by another running cell (the file is locked)") from None
        had_wal = _has_wal(self.path)  # before SQLite makes one
        try:
            self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
            if resume and not _has_events_table(self._db):  # never add a table to such a file
                raise self._refuse(
                    "not a flexhrc event store (no events table)" + wal_hint(self.path, had_wal)
                )
            self._db.execute("PRAGMA journal_mode=WAL")
            # NORMAL in WAL mode: a committed event survives the process being killed (the
            # WAL is written before commit returns); only a power loss may drop the last ones.
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute(SCHEMA)
            row = self._db.execute("SELECT COALESCE(MAX(seq), 0), COUNT(*) FROM events").fetchone()
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            raise self._refuse(f"not a flexhrc event store ({_sqlite_why(exc)})") from None
        if resume and not row[1]:
            raise self._refuse(
                "nothing to resume (the store holds no events)" + wal_hint(self.path, had_wal)
            )
        if type(row[0]) is not int:  # a table without types keeps a text or blob seq as is
            raise self._refuse(
                f"not a flexhrc event store (its last seq is {row[0]!r:.40}, not a whole number)"
            )
        self.last_seq = row[0]
        if int(row[1]) != self.last_seq:
            raise self._refuse(f"seq has gaps ({row[1]} rows, last {row[0]})")
        self._inode = os.fstat(self._lock_fd).st_ino
        self._crash_after = crash_after()
        #: Why the file is no longer the store (deleted or replaced while the cell ran), once
        #: an append noticed it; ``on_lost`` is called with it then, once.
        self.lost: str | None = None
        self.on_lost: Callable[[str], None] | None = None

    def _refuse(self, why: str) -> StoreError:
        """The error saying why the file is refused, once it is let go (the lock, and the
        database if open): a corrected file opens at once."""
        if hasattr(self, "_db"):
            self._db.close()
        os.close(self._lock_fd)
        return StoreError(f"{self.option} {self.path}: {why}")

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
        if self.lost is None:
            self._check_still_there()
        if seq == self._crash_after:  # the crash sweep's test hook (module docstring)
            os.kill(os.getpid(), signal.SIGKILL)
        return seq

    def _check_still_there(self) -> None:
        """An unlinked store takes every event and keeps none (probe ST49: a cell reported
        75 events "in" a file deleted under it): notice it, so the cell can say so."""
        try:
            gone = os.fstat(self._lock_fd).st_nlink == 0 or os.stat(self.path).st_ino != self._inode
        except OSError:
            gone = True
        if gone:
            self.lost = (
                f"{self.option} {self.path} was deleted or replaced while the cell ran (noticed "
                f"at event {self.last_seq}): its events are in no file and the run cannot be "
                "resumed"
            )
            if self.on_lost is not None:
                self.on_lost(self.lost)

    def events(self) -> list[StoredEvent]:
        """Every stored event, each row checked (:func:`iter_events`)."""
        try:
            return list(iter_events(self._db, self.path))
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
            raise StoreError(
                f"{self.option} {self.path}: not a flexhrc event store ({_sqlite_why(exc)})"
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


def iter_events(db: sqlite3.Connection, source: str | Path = "store") -> Iterator[StoredEvent]:
    """The rows of a store in ``seq`` order, each checked to be a row this module writes (a
    whole ``seq``, a known ``kind``, a finite time, a JSON object as body): anything else is a
    :class:`FormatError` naming ``source`` and the row's ``seq``."""
    for seq, t, kind, body in db.execute("SELECT seq, t, kind, body FROM events ORDER BY seq"):
        yield _row(seq, t, kind, body, source)


def _no_constant(name: str) -> Any:
    """The store writes strict JSON (``allow_nan=False``): NaN or Infinity in a row is damage."""
    raise ValueError(f"{name} is not a JSON number")


def _row(seq: Any, t: Any, kind: Any, body: Any, source: str | Path) -> StoredEvent:
    if not isinstance(seq, int):
        raise FormatError(f"a row's seq must be a whole number, got {seq!r:.40}", source)
    if not isinstance(kind, str) or kind not in STORE_KINDS:
        raise FormatError(f"event {seq}: unknown kind {kind!r:.40} (not a flexhrc store?)", source)
    where = f"event {seq} ({kind})"
    if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t) or t < 0:
        raise FormatError(f"{where}: 't' must be a finite time >= 0, got {t!r:.40}", source)
    try:
        data = (
            json.loads(body, parse_constant=_no_constant) if isinstance(body, str | bytes) else body
        )
    except (json.JSONDecodeError, UnicodeDecodeError, ValueError) as exc:
        raise FormatError(f"{where}: the body is not JSON ({exc})", source) from None
    except RecursionError:
        raise FormatError(f"{where}: the body is nested too deeply", source) from None
    if not isinstance(data, dict):
        raise FormatError(
            f"{where}: the body must be a JSON object, not {type(data).__name__}", source
        )
    return StoredEvent(seq, float(t), kind, data)


#: Inputs that are protocol messages as received: their stored body is checked against the
#: message's schema (``flexhrc.events.MESSAGES``), the row's time standing for a missing ``t``.
_MESSAGE_OF = {
    "ack": "ack",
    "human_action": "human_action",
    "percept": "percept",
    "intent": "intent",
    "operator": "operator",
    "operator_answers": "answer",
}


def check_events(events: list[StoredEvent], source: str | Path) -> None:
    """Check a store's events as a whole, as ``--resume`` and ``replay`` read them: ``seq``
    without gaps, one ``start`` first, time never going back, at most one ``outcome`` and one
    ``summary``, every input well formed, an ack only for a command stored before it and only
    once, every agent one of the run's. The first problem is a :class:`FormatError` naming
    ``source`` and the event's ``seq`` — a corrupted row is refused, never replayed into a
    manager that would wait for ever on it."""
    once: dict[str, int] = {}
    commands: dict[int, StoredEvent] = {}
    acked: dict[int, int] = {}
    ids: dict[str, dict[str, int]] = {}
    agents: set[str] = set()
    last_t = 0.0
    for i, ev in enumerate(events):
        b, kind = ev.body, ev.kind
        where = f"event {ev.seq} ({kind})"

        def fail(problem: str, where: str = where) -> FormatError:
            return FormatError(f"{where}: {problem}", source)

        if ev.seq != i + 1:
            raise FormatError(f"seq has gaps: no event {i + 1} (the next is {ev.seq})", source)
        if i == 0 and kind != "start":
            raise fail(f"a store must begin with a 'start' event, not {kind!r}")
        if ev.t < last_t - 1e-9:
            raise fail(f"time goes back ({ev.t} s after {last_t} s): events are stored in order")
        last_t = max(last_t, ev.t)
        if kind in ("start", "outcome", "summary"):
            if kind in once:
                raise fail(f"a second {kind!r} event (the first is event {once[kind]})")
            once[kind] = ev.seq
        if kind == "start":
            named = b.get("agents")
            if not isinstance(named, list) or not all(isinstance(a, str) for a in named):
                raise fail("'agents' must be a list of agent names")
            agents = set(named)
        elif kind == "command":
            cid = b.get("id")
            if not isinstance(cid, int) or isinstance(cid, bool):
                raise fail(f"'id' must be a whole number, got {cid!r:.40}")
            if cid in commands:
                raise fail(f"command {cid} was already issued in event {commands[cid].seq}")
            # the log and a resumed manager read its action and agents: a row without them
            # would be a KeyError far from here
            problem = MESSAGES["command"].problem({"t": ev.t, **b, "v": 1, "type": "command"})
            if problem is not None:
                raise fail(problem)
            commands[cid] = ev
        elif kind == "utility":  # a what-if's new utility: the block the scenario key takes
            from flexhrc.taskmanager.utility import parse_utility

            block = b.get("utility")
            problems = parse_utility(block, None)[1] if isinstance(block, dict) else [("", None)]
            if problems:
                raise fail(f"'utility' must be a utility block ({problems[0][0] or 'a mapping'})")
        elif kind in ("stop", "suggestion", "options"):  # what the manager sent, read back alike
            problem = MESSAGES[kind].problem({"t": ev.t, **b, "v": 1, "type": kind})
            if problem is not None:
                raise fail(problem)
        elif kind in _MESSAGE_OF:
            problem = MESSAGES[_MESSAGE_OF[kind]].problem(
                {"t": ev.t, **b, "v": 1, "type": _MESSAGE_OF[kind]}
            )
            if problem is not None:
                raise fail(problem)
            agent = b.get("agent")
            if isinstance(agent, str) and agents and agent not in agents:
                raise fail(f"{agent!r} is not an agent of this run ({', '.join(sorted(agents))})")
            if kind == "ack":
                cid = int(b["id"])
                cmd = commands.get(cid)
                if cmd is None:
                    raise fail(f"an ack for command {cid}, which the store never issued")
                if cid in acked:
                    raise fail(f"a second ack for command {cid} (the first is event {acked[cid]})")
                if b["agent"] not in cmd.body.get("agents", ()):
                    raise fail(
                        f"an ack for command {cid} from {b['agent']!r}, not one of its agents"
                    )
                acked[cid] = ev.seq
            elif kind in ("human_action", "percept", "intent"):  # ids the cell dedupes
                seen = ids.setdefault(kind, {})
                if str(b["id"]) in seen:
                    raise fail(
                        f"{kind} {b['id']!r} was already stored in event {seen[str(b['id'])]}"
                    )
                seen[str(b["id"])] = ev.seq
        elif kind in ("agent_up", "agent_down"):
            if not isinstance(b.get("agent"), str) or (agents and b["agent"] not in agents):
                raise fail(f"'agent' must be an agent of this run, got {b.get('agent')!r:.40}")
        elif kind == "human_take" and not isinstance(b.get("element"), str):
            raise fail(f"'element' must be a hyper-arc's name, got {b.get('element')!r:.40}")


def read_store(path: str | Path) -> list[StoredEvent]:
    """Every event of a store, read-only; one clear error for a file that is not a store."""
    p = Path(path)
    if not p.is_file():
        raise FormatError("no such file" if not p.exists() else "is not a file", p)
    if not os.access(p, os.R_OK):
        raise FormatError("cannot read: permission denied", p)
    had_wal = _has_wal(p)
    try:
        db = sqlite3.connect(f"file:{p}?mode=ro", uri=True)
        try:
            if not _has_events_table(db):
                hint = wal_hint(p, had_wal)
                raise FormatError("not a flexhrc event store (no events table)" + hint, p)
            events = list(iter_events(db, p))
        finally:
            db.close()
    except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:
        raise FormatError(f"not a flexhrc event store ({_sqlite_why(exc)})", p) from None
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
    return [ev for _, ev in _log_lines(events)]


def action_start(t: float, command: dict[str, Any]) -> dict[str, Any]:
    """The log's ``action_start`` of a ``command`` (its body) at ``t``."""
    return {
        "t": t,
        "type": "action_start",
        "agents": command["agents"],
        "action": command["action"],
        "command": command["id"],
        "element": command.get("element"),
    }


def action_end(
    t: float, agents: Any, action: Any, status: str, start: float, command: Any = None, **more: Any
) -> dict[str, Any]:
    """The log's ``action_end`` at ``t`` of an action started at ``start``: of a robot
    ``command`` (its id; None for an operator's action), then ``more`` (``reason``,
    ``element``), in the log's key order."""
    return {
        "t": t,
        "type": "action_end",
        "agents": agents,
        "action": action,
        **({"command": command} if command is not None else {}),
        "status": status,
        "start": round(start, 6),
        **more,
    }


def _log_lines(events: list[StoredEvent]) -> list[tuple[int, dict[str, Any]]]:
    """:func:`log_events`, each log event with the ``seq`` of the row it comes from."""
    out: list[dict[str, Any]] = []
    seqs: list[int] = []
    commands: dict[int, tuple[float, dict[str, Any]]] = {}
    ended: set[int] = set()  # commands whose action_end is out (by their ack or their stop)
    prev = 0  # the seq of the row the log events not yet numbered come from
    for ev in events:
        seqs.extend([prev] * (len(out) - len(seqs)))
        prev = ev.seq
        b = ev.body
        t = round(ev.t, 6)
        if ev.kind == "start":
            out.append({"profile": "cell", **b, "t": t, "type": "start"})
        elif ev.kind == "command":
            commands[int(b["id"])] = (ev.t, b)
            out.append({**b, "t": t, "type": "command"})
            out.append(action_start(t, b))
        elif ev.kind == "ack":
            if int(b["id"]) in ended:
                # a process's hold stopped at the very instant its arm finished it: the manager
                # ignored the ack (``ack_ignored``), and the command ended once, at its stop
                continue
            ended.add(int(b["id"]))
            start, cmd = commands.get(int(b["id"]), (ev.t, {"agents": [b.get("agent")]}))
            out.append(
                action_end(
                    t,
                    cmd["agents"],
                    cmd.get("action", "?"),
                    b["status"],
                    min(start, ev.t),
                    command=b["id"],
                    reason=b.get("reason"),
                    element=cmd.get("element"),
                )
            )
        elif ev.kind == "human_action":
            start = min(float(b.get("start", ev.t)), ev.t)
            out.append(action_end(t, [b.get("agent", "human")], b["action"], "done", start))
        elif ev.kind in REPLAY_TYPES:
            out.append({**b, "t": t, "type": ev.kind})
            stopped = commands.pop(int(b["id"]), None) if ev.kind == "stop" else None
            if stopped is not None and int(b["id"]) not in ended:
                # the arm was busy until the stop (its ack never counts)
                ended.add(int(b["id"]))
                start, cmd = stopped
                out.append(
                    action_end(
                        t,
                        cmd["agents"],
                        cmd.get("action", "?"),
                        "stopped",
                        min(start, ev.t),
                        command=b["id"],
                        reason=b.get("reason"),
                    )
                )
    seqs.extend([prev] * (len(out) - len(seqs)))
    return list(zip(seqs, out, strict=True))


def store_log(path: str | Path) -> list[dict[str, Any]]:
    """A store read as a cooperation log, validated like one (``flexhrc replay FILE.db``);
    a bad event is a :class:`FormatError` naming the store and the event's ``seq``."""
    from flexhrc.taskmanager.replay import check_log

    events = read_store(path)
    if not events:
        raise FormatError("empty store" + wal_hint(path, _has_wal(path)), path)
    check_events(events, path)
    lines = _log_lines(events)
    try:
        check_log(lines, path)
    except FormatError as exc:  # its "line" is the seq of the row the log event comes from
        raise FormatError(f"event {exc.line}: {exc.message}", path) from None
    return [ev for _, ev in lines]


def wal_hint(path: str | Path, had_wal: bool) -> str:
    """Why a store may look empty: a copy of a killed cell's store made without its ``-wal``
    file lacks every event not yet checkpointed into the main file (probe ST42). ``had_wal``:
    a ``-wal`` file with something in it was beside the store before SQLite opened it."""
    try:
        with open(path, "rb") as fh:
            wal_mode = fh.read(20)[18:20] == b"\x02\x02"  # the header's WAL format version
    except OSError:
        return ""
    if had_wal or not wal_mode:
        return ""
    name = Path(path).name
    return (
        f"; if it is a copy of a cell's store, copy {name}-wal with it: the events of a cell "
        "that was killed, or still runs, are there"
    )


def _has_wal(path: str | Path) -> bool:
    """Is there a ``-wal`` file with something in it beside the store? (A reader leaves an
    empty one behind.)"""
    try:
        return os.path.getsize(f"{path}-wal") > 0
    except OSError:
        return False


def _sqlite_why(exc: Exception) -> str:
    """SQLite's words for a damaged file. Its message quotes the damaged schema text, which
    Python's sqlite3 decodes as UTF-8: a damaged byte there raises UnicodeDecodeError from the
    query itself (fuzz, store target: ``CREATE`` with one byte changed)."""
    if isinstance(exc, UnicodeDecodeError):
        return "its schema is damaged: SQLite's error message about it is not even UTF-8 text"
    return str(exc)


def _has_events_table(db: sqlite3.Connection) -> bool:
    cols = [r[1] for r in db.execute("PRAGMA table_info(events)")]
    return cols[:4] == ["seq", "t", "kind", "body"]


def summarise_store(path: str | Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """``flexhrc replay FILE.db``: the summary (same keys as ``flexhrc replay LOG``) and the
    events in log form."""
    from flexhrc.taskmanager.replay import summarise_log

    log = store_log(path)
    return summarise_log(log), log
