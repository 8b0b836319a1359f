"""The behaviour-network event log: written line by line while a network runs, read back to replay.

A log is JSON lines (``flexhrc behave ... --log F``)::

    {"type": "behave_start", "kind": "header", "t": 0.0, "target": ..., "task": "(THEN ...)",
     "behaviors": [...], "arms": [...], "seed": 0, "tick_period": 0.1, "robots": 1}
    {"type": "event", "tick": 3, "t": 0.3, "source": "fork", "kind": "state", ...}
    ...
    {"type": "behave_end", "kind": "end", "t": 41.2, "outcome": "done", "ticks": 412,
     "order": [...], "resets": 0, "violations": []}

Every event of :class:`~flexhrc.behavior.messages.LogEvent` is one ``event`` line, appended and
flushed as it happens (:func:`stream_log`, on a :class:`flexhrc.files.EventLogWriter`), so a
run killed mid-way leaves a log that :func:`read_log` reads up to its last event and reports as
cut short (no end line).
:meth:`BehaveLog.result` rebuilds the :class:`~flexhrc.behavior.network.RunResult` from the events
alone — the same runs, order and Gantt chart as the live run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from flexhrc.behavior.messages import LogEvent
from flexhrc.behavior.network import BehaviorNetwork, RunResult
from flexhrc.errors import FormatError

if TYPE_CHECKING:
    from flexhrc.files import EventLogWriter

HEADER = "behave_start"
EVENT = "event"
END = "behave_end"
OUTCOMES = ("done", "timeout", "interrupted")
#: What :class:`BehaveLog` reports for a log without an end line (the run was killed).
CUT_SHORT = "cut short"


def stream_log(
    net: BehaviorNetwork,
    path: str | Path,
    target: str,
    seed: int,
    record: Callable[[LogEvent], dict[str, Any]] | None = None,
    **extra: Any,
) -> EventLogWriter:
    """Open the log of ``net`` at ``path``, write its header (``target`` names the run; ``extra``
    keys are added) and append every event as it happens (``record`` makes its line, default
    :func:`event_record`); the caller writes the :func:`end_record` and closes the writer."""
    from flexhrc.files import EventLogWriter

    writer = EventLogWriter(path)
    task = net.task
    writer.write(
        {
            "type": HEADER,
            "kind": "header",
            "t": 0.0,
            "target": target,
            "task": task.to_prefix(),
            "behaviors": task.behaviors,
            "arms": net.world.arm_names,
            "seed": seed,
            "tick_period": net.params.tick_period,
            **extra,
        }
    )
    line = record or event_record
    net.listeners.append(lambda ev: writer.write(line(ev)))
    return writer


def event_record(ev: LogEvent) -> dict[str, Any]:
    return {"type": EVENT, **ev.to_dict()}


def end_record(
    result: RunResult, violations: list[str], outcome: str | None = None
) -> dict[str, Any]:
    return {
        "type": END,
        "kind": "end",
        "t": result.time,
        "outcome": outcome or result.outcome,
        "ticks": result.ticks,
        "order": list(result.order),
        "resets": result.resets,
        "violations": list(violations),
    }


@dataclass
class BehaveLog:
    """A log read back: its header, its events and its end line (None if the run was cut short)."""

    path: Path
    header: dict[str, Any]
    events: list[LogEvent]
    end: dict[str, Any] | None

    @property
    def outcome(self) -> str:
        return str(self.end["outcome"]) if self.end is not None else CUT_SHORT

    @property
    def time(self) -> float:
        if self.end is not None:
            return float(self.end["t"])
        return self.events[-1].t if self.events else 0.0

    @property
    def ticks(self) -> int:
        if self.end is not None:
            return int(self.end["ticks"])
        return self.events[-1].tick + 1 if self.events else 0

    def result(self) -> RunResult:
        """The run as the live network reported it, rebuilt from the events."""
        behaviors, arms = list(self.header["behaviors"]), list(self.header["arms"])
        return RunResult.of_log(self.outcome, self.ticks, self.time, self.events, behaviors, arms)

    def states_at(self, t: float) -> dict[str, str]:
        """Every node's state at time ``t`` (the last state event at or before ``t``)."""
        states: dict[str, str] = {}
        for ev in self.events:
            if ev.t > t:
                break
            if ev.kind == "state":
                states[ev.source] = str(ev.data["to"])
        return states


def _number(rec: dict[str, Any], key: str, path: Path, line: int, integer: bool = False) -> float:
    value = rec.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FormatError(f"{key!r} must be a number, got {value!r}", path, line)
    if not math.isfinite(value) or value < 0:
        raise FormatError(f"{key!r} must be finite and >= 0, got {value!r}", path, line)
    if integer and not float(value).is_integer():
        raise FormatError(f"{key!r} must be an integer, got {value!r}", path, line)
    return float(value)


def _strings(rec: dict[str, Any], key: str, path: Path, line: int) -> list[str]:
    value = rec.get(key)
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise FormatError(f"{key!r} must be a list of names", path, line)
    return value


def read_log(path: str | Path) -> BehaveLog:
    """Read and check a behaviour log; every problem names the file and line."""
    from flexhrc.jsonl import read_jsonl_lines

    p = Path(path)
    header: dict[str, Any] | None = None
    events: list[LogEvent] = []
    end: dict[str, Any] | None = None
    last_t = 0.0
    for n, rec in read_jsonl_lines(p):  # (a line that is no JSON object: a log cut mid-line)
        kind = rec.get("type")
        if header is None:
            if kind != HEADER:
                raise FormatError(
                    "not a behaviour log (the first line must be a 'behave_start' record; "
                    "cooperation logs are read by `flexhrc replay`)",
                    p,
                    n,
                )
            if not isinstance(rec.get("task"), str):
                raise FormatError("'task' must be the task's prefix form", p, n)
            _strings(rec, "behaviors", p, n)
            _strings(rec, "arms", p, n)
            header = rec
            continue
        if end is not None:
            raise FormatError("a line after the end of the run", p, n)
        if kind == EVENT:
            t = _number(rec, "t", p, n)
            tick = int(_number(rec, "tick", p, n, integer=True))
            if t + 1e-9 < last_t:
                raise FormatError(f"time goes backwards ({t} after {last_t})", p, n)
            last_t = t
            source, ev_kind = rec.get("source"), rec.get("kind")
            if not isinstance(source, str) or not isinstance(ev_kind, str):
                raise FormatError("an event needs a 'source' and a 'kind' (strings)", p, n)
            data = {
                k: v for k, v in rec.items() if k not in ("type", "tick", "t", "source", "kind")
            }
            if ev_kind == "state" and not isinstance(data.get("to"), str):
                raise FormatError("a state event needs 'to' (the new state)", p, n)
            if ev_kind in ("start", "done", "reset") and not isinstance(data.get("arm"), str):
                raise FormatError(f"a {ev_kind} event needs 'arm'", p, n)
            events.append(LogEvent(tick, t, source, ev_kind, data))
        elif kind == END:
            _number(rec, "t", p, n)
            _number(rec, "ticks", p, n, integer=True)
            if rec.get("outcome") not in OUTCOMES:
                raise FormatError(
                    f"unknown outcome {rec.get('outcome')!r} (one of {', '.join(OUTCOMES)})", p, n
                )
            end = rec
        else:
            raise FormatError(f"unknown record type {kind!r}", p, n)
    if header is None:
        raise FormatError("empty log", p)
    return BehaveLog(p, header, events, end)
