"""Fuzz targets of flexhrc's readers (issue 20, "Fuzzing").

Each :class:`Target` is a Hypothesis strategy of inputs — the shipped files (and the probe's
cases) mutated: bytes flipped, lines dropped or repeated, files cut short, deep nesting, huge
numbers, NaN and infinity — and a property every input must keep: the reader gives **a clear
error** (a :class:`~flexhrc.errors.FlexhrcError` of the expected kind, one message of
reasonable size that names the input) **or a correct result**, never another exception and
never a hang (a watchdog turns a run longer than :data:`HANG_S` into a failure).

The same targets run twice: ``tests/fuzz/test_fuzz.py`` draws a fixed number of examples of
each (the deterministic profile of ``tests/conftest.py``: CI cannot fail by luck), and
``benchmarks/fuzz.py --minutes M`` runs them long with random seeds.

Targets (:data:`TARGETS`):

* ``protocol`` — bytes as they arrive on a topic: :func:`flexhrc.transport.zenoh.json_decode`
  then :func:`flexhrc.cell.protocol.parse`. Accepted: the message passes its schema in
  :data:`flexhrc.events.MESSAGES` and can be stored (strict JSON: no NaN or infinity).
* ``events`` — log records against :data:`flexhrc.events.LOG_EVENTS`
  (:meth:`flexhrc.events.Event.from_dict`): an :class:`~flexhrc.events.EventError` or an
  event that gives back the same JSON.
* ``andor`` — ANDOR text files: the compiled reader (``_andor_fast.c``) and the pure-Python one
  accept with the same hierarchy or both refuse with the same :class:`FormatError`.
* ``scenario`` — scenario files and the domain and graph files they name:
  :func:`flexhrc.scenario.format.check` and :func:`~flexhrc.scenario.format.parse` agree.
* ``store`` — cell event stores with corrupted rows, schemas and bytes:
  :func:`flexhrc.cell.store.read_store`, ``flexhrc replay FILE.db`` and a resume's read.
* ``replay`` — JSON-lines cooperation logs: :func:`flexhrc.cell.replay.replay`.
"""

from __future__ import annotations

import contextlib
import copy
import itertools
import json
import math
import shutil
import signal
import sqlite3
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hypothesis import strategies as st

from flexhrc.errors import FormatError

REPO = Path(__file__).resolve().parents[2]
SHARED = REPO.parent / "shared"
ANCHORS = SHARED / "anchors" / "andor-graphs"
DATA = REPO / "tests" / "data" / "logs"
BUILTIN = REPO / "src" / "flexhrc" / "scenario" / "builtin" / "data"

#: A run of one input longer than this is a hang (no input of these readers needs a second).
HANG_S = 20.0
#: A clear error is one message, not an expansion of the input (probe S32v: a 522 MB line).
MAX_MESSAGE = 4000


class Hang(BaseException):
    """One input ran longer than :data:`HANG_S` (a BaseException: no reader swallows it)."""


class Unclear(AssertionError):
    """An error of the expected kind that does not say clearly what is wrong where."""


@contextlib.contextmanager
def watchdog(seconds: float = HANG_S) -> Iterator[None]:
    """Raise :class:`Hang` in the main thread when the block runs longer than ``seconds``
    (a no-op off the main thread, where no signal can be delivered)."""
    try:
        previous = signal.signal(signal.SIGALRM, _on_alarm)
    except ValueError:  # not the main thread
        yield
        return
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _on_alarm(signum: int, frame: object) -> None:
    raise Hang(f"one input ran longer than {HANG_S} s")


def clear(exc: BaseException, *names: str, size: int = 0) -> None:
    """Check that an expected error is a clear one: a non-empty message that names one of
    ``names`` (the file it is about) when names are given, and that does not amplify its input
    (of ``size`` bytes): at most :data:`MAX_MESSAGE` characters or three times the input.
    Quoting a faulty line is fine; the probe's S32v (400 bytes of YAML aliases, a 522 MB
    message) is not."""
    text = str(exc)
    if not text.strip():
        raise Unclear(f"{type(exc).__name__} without a message")
    if len(text) > max(MAX_MESSAGE, 3 * size):
        raise Unclear(
            f"{type(exc).__name__}: a message of {len(text)} characters for an input of "
            f"{size} bytes: {text[:200]}"
        )
    if names and not any(n in text for n in names):
        raise Unclear(f"{type(exc).__name__} does not name the input ({names}): {text[:300]}")


# -- workspace --------------------------------------------------------------------------------
class Workspace:
    """A scratch folder for file-based targets, holding copies of the seed folders (so that a
    mutated file is read beside the files it names). One per test session or fuzz run."""

    def __init__(self, root: Path | None = None):
        self._owned = root is None
        self.root = Path(tempfile.mkdtemp(prefix="flexhrc-fuzz-")) if root is None else root
        self._copies: dict[Path, Path] = {}
        self._n = 0

    def copy_of(self, folder: Path) -> Path:
        """A private copy of ``folder`` (made once)."""
        out = self._copies.get(folder)
        if out is None:
            out = self.root / f"seed{len(self._copies)}"
            shutil.copytree(folder, out, symlinks=True)
            self._copies[folder] = out
        return out

    def fresh(self) -> Path:
        """A new empty folder."""
        self._n += 1
        out = self.root / f"in{self._n}"
        out.mkdir()
        return out

    @contextlib.contextmanager
    def placed(self, folder: Path, rel: str, data: bytes) -> Iterator[Path]:
        """``data`` written as ``rel`` in the copy of ``folder`` for the block; the copy's
        original file is put back afterwards."""
        copy = self.copy_of(folder)
        target = copy / rel
        original = target.read_bytes()
        target.write_bytes(data)
        try:
            yield target
        finally:
            target.write_bytes(original)

    def close(self) -> None:
        if self._owned:
            shutil.rmtree(self.root, ignore_errors=True)


# -- mutations --------------------------------------------------------------------------------
#: Byte sequences that trip readers: odd whitespace and line ends, NUL, bytes that are not
#: UTF-8, a BOM, comment and flow characters, YAML anchors and tags, numbers of every oddity.
ODD_BYTES: tuple[bytes, ...] = (
    b"\r\n", b"\r", b"\t", b"  ", b"\n\n", b"\x00", b"\x0c", b"\x1c", b"\x85", b"#", b"/",
    "é".encode(), "²".encode(), b"\xff", b"\xef\xbb\xbf", b"-", b"+1", b"1_0", b"9" * 16,
    b"9" * 400, b"0x1f", b"1e308", b"1e400", b"-1e400", b"1e-400", b"-0", b"nan", b"NaN",
    b"inf", b"-inf", b"Infinity", b".nan", b".inf", b"-.inf", b"null", b"~", b"true", b"'no'",
    b"[", b"]", b"{", b"}", b",", b":", b": ", b"- ", b"&a ", b"*a", b"!!python/object ",
    b"!!binary ", b"<<: ", b"'", b'"', b"\\", b"..", b"../", b"/etc/passwd",
)  # fmt: skip


@dataclass(frozen=True)
class Mutation:
    """One edit of a byte string: ``op`` picks the kind, ``at`` and ``arg`` where and what
    (both reduced modulo what fits, so every draw is valid and shrinks towards the seed)."""

    op: int
    at: int
    arg: int

    def apply(self, data: bytes) -> bytes:
        n = len(data)
        at = self.at % (n + 1)
        op = self.op % 11
        lines = data.split(b"\n")
        li = self.at % len(lines)
        if op == 0:  # flip bits of one byte
            if n == 0:
                return data
            i = self.at % n
            return data[:i] + bytes([data[i] ^ (self.arg % 255 + 1)]) + data[i + 1 :]
        if op == 1:  # an odd byte sequence inserted
            return data[:at] + ODD_BYTES[self.arg % len(ODD_BYTES)] + data[at:]
        if op == 2:  # a span deleted
            return data[:at] + data[at + 1 + self.arg % 64 :]
        if op == 3:  # cut short
            return data[:at]
        if op == 4:  # a line dropped
            del lines[li]
            return b"\n".join(lines)
        if op == 5:  # a line repeated (a name twice, a row too many)
            lines.insert(li, lines[li])
            return b"\n".join(lines)
        if op == 6:  # two lines swapped
            k = self.arg % len(lines)
            lines[li], lines[k] = lines[k], lines[li]
            return b"\n".join(lines)
        if op == 7:  # a number replaced by an odd one
            return _replace_number(data, self.at, self.arg)
        if op == 8:  # a word of another line copied in (a repeated name, a wrong reference)
            words = data.split()
            if not words:
                return data
            word = words[self.arg % len(words)]
            return data[:at] + word + data[at:]
        if op == 9:  # deep nesting in front of a value
            depth = 1 + self.arg % 3000
            opener = b"[" if self.arg % 2 else b"{a: "
            return data[:at] + opener * depth + data[at:]
        # a line's indentation changed (YAML structure)
        lines[li] = b" " * (self.arg % 9) + lines[li].lstrip(b" ")
        return b"\n".join(lines)


#: Numbers that trip readers: zero, negative, huge, beyond a double, NaN and infinity.
ODD_NUMBERS: tuple[bytes, ...] = (
    b"0", b"-1", b"1", b"2", b"7", b"-0", b"0.5", b"2.7", b"1e300", b"-1e300", b"1e400",
    b"9007199254740993", b"99999999999", b"9" * 40, b".nan", b"nan", b"NaN", b".inf", b"-.inf",
    b"Infinity", b"1e-400",
)  # fmt: skip


def _replace_number(data: bytes, at: int, arg: int) -> bytes:
    import re

    spans = [m.span() for m in re.finditer(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", data)]
    if not spans:
        return data
    a, b = spans[at % len(spans)]
    return data[:a] + ODD_NUMBERS[arg % len(ODD_NUMBERS)] + data[b:]


MUTATIONS = st.builds(
    Mutation,
    st.integers(0, 10),
    st.integers(0, 1 << 20),
    st.integers(0, 1 << 16),
)


def mutated(seeds: list[bytes], max_edits: int = 4) -> st.SearchStrategy[bytes]:
    """A seed with up to ``max_edits`` mutations (none: the seed itself)."""

    def edit(seed: bytes, edits: list[Mutation]) -> bytes:
        for m in edits:
            seed = m.apply(seed)
        return seed

    return st.builds(edit, st.sampled_from(seeds), st.lists(MUTATIONS, max_size=max_edits))


#: JSON values that trip the code behind a schema: wrong types, empty and huge values, numbers
#: beyond a double, NaN and infinity (Python's json writes those), deep nesting.
ODD_VALUES: tuple[Any, ...] = (
    None, True, False, 0, -1, 1, 2**53 + 1, 10**30, 10**400, -(10**400), 0.5, -0.0, 1e300,
    -1e300, 1e-320, math.nan, math.inf, -math.inf, "", "x", "abc", "done", "left", "human",
    "a/b", "é", "\x00", "x" * 300, [], [1, 2], [None], ["left"], [1e300, 0, 0],
    [math.nan, 0, 0], {}, {"a": 1}, {"leg1": [1e300, 0, 0]}, {"leg1": "abc"},
    [[[[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]]],
)  # fmt: skip


def _deep(depth: int) -> Any:
    out: Any = []
    for _ in range(depth):
        out = [out]
    return out


@st.composite
def json_edits(draw: st.DrawFn, value: Any) -> Any:
    """``value`` (a JSON object) with one field replaced, removed or added, anywhere in it."""

    def paths(v: Any, here: tuple[Any, ...]) -> Iterator[tuple[Any, ...]]:
        yield here
        if isinstance(v, dict):
            for k, x in v.items():
                yield from paths(x, (*here, k))
        elif isinstance(v, list):
            for i, x in enumerate(v):
                yield from paths(x, (*here, i))

    with _deep_calls():
        value = copy.deepcopy(value)  # a private copy
    where = draw(st.sampled_from(list(paths(value, ()))))
    kind = draw(st.integers(0, 3))
    if kind == 3:  # deep nesting
        new: Any = _deep(draw(st.sampled_from([50, 400, 950])))
    else:
        new = draw(st.sampled_from(ODD_VALUES))
    if not where:
        return new if kind == 3 else value
    parent = value
    for k in where[:-1]:
        parent = parent[k]
    last = where[-1]
    if kind == 0 and isinstance(parent, dict):
        del parent[last]  # a field missing
    elif kind == 1 and isinstance(parent, dict):
        parent[draw(st.sampled_from(["extra", "v", "type", "t", "id", "agent"]))] = new
    else:
        parent[last] = new
    return value


class Doc:
    """A JSON value drawn as an input, shown as (bounded) JSON: Hypothesis's own printer
    recurses into deep nesting and overflows the stack."""

    __slots__ = ("value",)

    def __init__(self, value: Any):
        self.value = value

    def __repr__(self) -> str:
        try:
            text = _dumps(self.value).decode()
        except (ValueError, RecursionError):
            text = repr(type(self.value))
        return f"Doc({text[:2000]}{'...' if len(text) > 2000 else ''})"


def edited_json(seeds: list[dict[str, Any]], max_edits: int = 3) -> st.SearchStrategy[Doc]:
    """A seed object with up to ``max_edits`` structural edits."""

    @st.composite
    def build(draw: st.DrawFn) -> Doc:
        v: Any = draw(st.sampled_from(seeds))
        for _ in range(draw(st.integers(0, max_edits))):
            if not isinstance(v, dict | list):
                break
            v = draw(json_edits(v))
        return Doc(v)

    return build()


# -- the targets ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Target:
    """A reader under fuzz: its inputs and the property each must keep. ``check(ws, x)``
    raises on a violation (an unexpected exception, :class:`Unclear`, an ``AssertionError``
    for a wrong result); a refusal it judges clear returns normally."""

    name: str
    doc: str
    inputs: Callable[[], st.SearchStrategy[Any]]
    check: Callable[[Workspace, Any], None]

    def run(self, ws: Workspace, value: Any, *, known: bool = False) -> Known | None:
        """One input under the watchdog. With ``known``, a failure that is a :data:`KNOWN`
        finding (a bug of a module this fuzzing does not fix, pinned by an ``xfail`` test) is
        returned instead of raised."""
        try:
            with watchdog():
                self.check(ws, value)
        except Exception as exc:
            finding = known_finding(self.name, exc) if known else None
            if finding is None:
                raise
            return finding
        return None


@dataclass(frozen=True)
class Known:
    """A finding left to the module that owns it: ``targets`` it shows in, the exception type
    and message (a regular expression) it raises, and the test that pins it
    (``tests/fuzz/test_regressions.py``, ``xfail(strict=True)``)."""

    module: str
    targets: tuple[str, ...]
    error: type[BaseException] | tuple[type[BaseException], ...]
    message: str
    test: str
    where: str = ""  # a file the traceback passes through (``scenario/format.py``)


def known_finding(target: str, exc: BaseException) -> Known | None:
    import re
    import traceback

    files = [f.filename for f in traceback.extract_tb(exc.__traceback__)]
    for k in KNOWN:
        if (
            target in k.targets
            and isinstance(exc, k.error)
            and re.search(k.message, str(exc))
            and (not k.where or any(f.endswith(k.where) for f in files))
        ):
            return k
    return None


#: Findings not fixed yet, each pinned by a strict xfail test in test_regressions.py.
KNOWN: list[Known] = []  # each finding so far is fixed (tests/fuzz/test_regressions.py)


def _dumps(v: Any) -> bytes:
    """JSON as a sender might write it (Python's: NaN and infinity included, and nesting
    deeper than Python's recursion limit)."""
    with _deep_calls():
        return json.dumps(v).encode()


@contextlib.contextmanager
def _deep_calls() -> Iterator[None]:
    """Room for the recursion of copying and writing a deeply nested input (one of them)."""
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20000))
    try:
        yield
    finally:
        sys.setrecursionlimit(limit)


# protocol -------------------------------------------------------------------------------------
_WORLD = {"positions": {"leg1": [0.5, 0.1, 0.0]}, "held": {}, "facts": ["on_table(leg1)"]}
#: One valid message of every type (the docs' examples) and the probe's spoofed ones.
MESSAGE_SEEDS: list[dict[str, Any]] = [
    {"v": 1, "type": "command", "id": 7, "agents": ["left"], "action": "approach(left, leg1)",
     "element": "robot_1", "t": 1.5, "expected_s": 2.0, "world": _WORLD, "realtime": 0.0,
     "joints": {"left": [0.0, 0.1, 0.2]}},
    {"v": 1, "type": "stop", "id": 7, "reason": "replan", "t": 2.0},
    {"v": 1, "type": "ack", "id": 7, "agent": "left", "status": "done", "reason": None,
     "t": 3.5, "duration": 2.0, "positions": {"leg1": [0.5, 0.2, 0.1]},
     "joints": {"left": [0.1, 0.2]}},
    {"v": 1, "type": "suggestion", "id": "s1", "element": "human_1",
     "actions": ["check(human, bolt_1)"], "cost": 3, "t": 0.0, "world": _WORLD, "step": 1,
     "own": False},
    {"v": 1, "type": "human_action", "id": "human:s1:0", "agent": "human",
     "action": "pick_up(human, leg3)", "suggestion": "s1", "step": 0, "start": 1.0, "t": 2.0,
     "positions": {"leg3": [0.1, 0.2, 0.3]}, "recognised": True, "sensed": {"score": 0.9}},
    {"v": 1, "type": "percept", "id": "p1", "object": "leg1", "object_type": "leg",
     "pose": [0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], "size": {"x": 0.1}, "t": 1.0,
     "why": "look", "moved": False, "contradicts": None},
    {"v": 1, "type": "answer", "id": "a1", "agent": "human", "report": "human:s1:0",
     "object": "leg1", "question": "did you?", "answer": "yes", "t": 1.0},
    {"v": 1, "type": "looked", "agent": "camera", "upto": 3, "t": 1.0, "at": 2.0},
    {"v": 1, "type": "options", "id": "o1", "t": 0.0, "world": _WORLD,
     "steps": [{"step": "s1", "arcs": [{"hyperarc": "h1", "cost": 2,
                                          "branches": [["pick_up(human, leg1)"]]}]}]},
    {"v": 1, "type": "operator", "agent": "human", "profile": "takeover", "scripted": False},
    {"v": 1, "type": "intent", "id": "i1", "agent": "human", "options": "o1", "act": True,
     "decided": ["s1"], "t": 0.5, "step": "s1", "hyperarc": "h1",
     "actions": ["pick_up(human, leg1)"], "delay": 0.2},
    {"v": 1, "type": "state"},
    {"v": 1, "type": "end", "outcome": "solved"},
    {"v": 1, "type": "follow", "id": 3, "leader": "left", "times": [0.0, 0.5],
     "joints": [[0.0, 0.1], [0.1, 0.2]], "realtime": 1.0},
    {"v": 1, "type": "follow_stop", "id": 3, "by": "left"},
    # the probe's (spoof.py): well formed, hostile values
    {"v": 99, "type": "end", "outcome": "x"},
    {"v": 1, "type": "percept", "id": "far", "object": "leg1", "object_type": "leg",
     "pose": [1e300, -1e300, 0.0]},
    {"v": 1, "type": "ack", "id": 20, "agent": "left", "status": "done", "t": 7.6,
     "positions": {"leg1": [1e300, 0.0, 0.0]}},
    {"v": 1, "type": "command", "id": 900, "agents": ["right"], "action": "rest(right)",
     "t": 0.0, "world": {"positions": {"leg1": "abc"}}},
    {"v": 1, "type": "human_action", "id": "odd0", "agent": "human",
     "action": "screw(human, human, human)", "t": 1.0},
]  # fmt: skip


def _protocol_inputs() -> st.SearchStrategy[bytes]:
    objects = edited_json(MESSAGE_SEEDS).map(lambda d: _dumps(d.value))
    return st.one_of(objects, objects.flatmap(lambda b: mutated([b], 2)))


def _protocol_check(ws: Workspace, data: bytes) -> None:
    from flexhrc.cell.protocol import ProtocolError, parse
    from flexhrc.events import MESSAGES
    from flexhrc.transport.zenoh import json_decode

    try:
        msg = json_decode(data)  # what a receiver does first; ValueError is its refusal
    except ValueError as exc:  # (UnicodeDecodeError and JSONDecodeError among them)
        clear(exc, size=len(data))
        return
    except RecursionError:  # nested too deeply: the transports drop it like a ValueError
        return
    try:
        got = parse(msg)
    except ProtocolError as exc:
        clear(exc, size=len(data))
        return
    assert got is msg
    assert MESSAGES[got["type"]].problem(got) is None
    # an accepted message is stored (strict JSON) and may be forwarded: it must serialise
    json.dumps(got, allow_nan=False)


PROTOCOL = Target(
    "protocol",
    "bytes on a topic: json_decode + cell.protocol.parse (events.MESSAGES)",
    _protocol_inputs,
    _protocol_check,
)


# log events ------------------------------------------------------------------------------------
def _log_seeds() -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    seen: set[str] = set()
    for f in sorted(DATA.glob("*.jsonl")):
        for line in f.read_text().splitlines():
            ev = json.loads(line)
            ev = ev.get("body", ev) | ({"type": ev["kind"], "t": ev["t"]} if "kind" in ev else {})
            if ev.get("type") not in seen:  # one of each type keeps the corpus small
                seen.add(ev["type"])
                out.append(ev)
    return out


def _events_inputs() -> st.SearchStrategy[Any]:
    return edited_json(_log_seeds())


def _events_check(ws: Workspace, doc: Doc) -> None:
    from flexhrc.events import MESSAGES, Event, EventError

    data = doc.value
    for catalogue in (None, MESSAGES):
        try:
            ev = Event.from_dict(data, catalogue)
        except EventError as exc:
            clear(exc, size=len(_dumps(data)))
            continue
        assert ev.to_dict() == data


EVENTS = Target(
    "events",
    "records against the catalogue: events.Event.from_dict (LOG_EVENTS and MESSAGES)",
    _events_inputs,
    _events_check,
)


# ANDOR text ------------------------------------------------------------------------------------
def andor_seeds() -> list[tuple[Path, str]]:
    """(folder, file relative to it) of every shipped ANDOR text file and, when ``../shared``
    is there, the authors' files; the folder is what a lower-graph reference is resolved in."""
    out = [
        (REPO / "examples" / "graphs", f.name) for f in (REPO / "examples" / "graphs").glob("*.txt")
    ]
    for f in sorted(BUILTIN.rglob("*.txt")):
        folder = BUILTIN / f.relative_to(BUILTIN).parts[0]
        out.append((folder, str(f.relative_to(folder))))
    if ANCHORS.is_dir():
        for top in sorted(p for p in ANCHORS.iterdir() if p.is_dir()):
            for f in sorted(top.rglob("*.txt")):
                if f.stat().st_size < 20000:
                    out.append((top, str(f.relative_to(top))))
    return sorted(out)


@dataclass(frozen=True)
class AndorEdit:
    """An edit that knows the ANDOR layout (header, node lines, hyper-arc lines and their
    children), so the input gets past the syntax into the structure checks: ``op`` picks it,
    ``line`` and ``arg`` where and what (reduced modulo what fits)."""

    op: int
    line: int
    arg: int

    def apply(self, data: bytes) -> bytes:
        lines = data.split(b"\n")
        rows = [i for i, ln in enumerate(lines) if ln.strip()]
        if not rows:
            return data
        i = rows[self.line % len(rows)]
        words = lines[i].split()
        arcs = [k for k in rows if len(lines[k].split()) == 5]
        op = self.op % 5
        if op == 0:  # a field of another line of its kind (a repeated name, a wrong parent)
            alike = [lines[k].split() for k in rows if len(lines[k].split()) == len(words)]
            j = self.arg % max(len(words), 1)
            if words:
                words[j] = alike[self.arg % len(alike)][j]
        elif op == 1 and arcs:  # a hyper-arc's parent made one of its children, or the root
            k = arcs[self.arg % len(arcs)]
            words = lines[k].split()
            i = k
            child = lines[k + 1].strip() if k + 1 < len(lines) else b""
            words[2] = child if self.arg % 2 and child else lines[rows[0]].split()[-1]
        elif op == 2 and len(lines[rows[0]].split()) == 3:  # another node made the root
            words = lines[rows[0]].split()
            i = rows[0]
            names = [lines[k].split()[0] for k in rows if len(lines[k].split()) in (1, 2)]
            if names:
                words[2] = names[self.arg % len(names)]
        elif op == 3 and arcs:  # a lower-graph reference: none, missing, odd, itself
            i = arcs[self.arg % len(arcs)]
            words = lines[i].split()
            refs = [b"-", b"Sub", b"a/b", b"--", b"../x", b"/etc/passwd", b".", b"", b"g"]
            words[4] = refs[self.arg % len(refs)] or b"-"
        elif words:  # a count one more or less (nodes of the header, children of a hyper-arc)
            j = 1 if len(words) in (3, 5) else len(words) - 1
            if words[j].isdigit():
                words[j] = str(max(int(words[j]) + (1 if self.arg % 2 else -1), 0)).encode()
        lines[i] = b" ".join(words)
        return b"\n".join(lines)


ANDOR_EDITS = st.builds(
    AndorEdit, st.integers(0, 4), st.integers(0, 1 << 16), st.integers(0, 1 << 16)
)


def _andor_inputs() -> st.SearchStrategy[tuple[Path, str, bytes]]:
    seeds = andor_seeds()

    @st.composite
    def build(draw: st.DrawFn) -> tuple[Path, str, bytes]:
        folder, rel = draw(st.sampled_from(seeds))
        data = (folder / rel).read_bytes()
        for edit in draw(st.lists(ANDOR_EDITS, max_size=3)):
            data = edit.apply(data)
        data = draw(mutated([data], 3))
        return folder, rel, data

    return build()


def _graph_dump(h: Any) -> Any:
    out = [h.top]
    for key, g in sorted(h.graphs.items()):
        nodes = [(n.name, n.weight, n.line) for n in g.nodes.values()]
        arcs = [
            (a.name, a.children, a.parent, a.weight, a.lower, a.line) for a in g.hyperarcs.values()
        ]
        out.append((key, g.name, g.root, g.root_line, nodes, arcs))
    out.append([str(w) for w in h.validate()])
    return out


def read_graph(path: Path, compiled: bool, size: int = 0) -> tuple[str, Any]:
    """The hierarchy of ``path`` (as data) read with or without the compiled reader, or the
    message of the :class:`FormatError` it was refused with (checked :func:`clear` for an
    input of ``size`` bytes)."""
    from flexhrc.representation.formats import andor_text, load

    saved = andor_text._parse_compiled
    if not compiled:
        andor_text._parse_compiled = None
    try:
        h = load(path)
    except FormatError as exc:
        clear(exc, size=size)
        assert exc.source, f"a FormatError that names no file: {exc}"
        return "refused", str(exc)
    finally:
        andor_text._parse_compiled = saved
    return "read", _graph_dump(h)


def _compiled_available() -> bool:
    from flexhrc.representation.formats import andor_text

    return andor_text._parse_compiled is not None


def _andor_check(ws: Workspace, value: tuple[Path, str, bytes]) -> None:
    folder, rel, data = value
    with ws.placed(folder, rel, data) as path:
        python = read_graph(path, False, len(data))
        if _compiled_available():
            compiled = read_graph(path, True, len(data))
            assert compiled == python, (
                f"the compiled and the Python reader differ:\n{compiled}\n{python}"
            )
        _same_single_file(path, data)


def _same_single_file(path: Path, data: bytes) -> None:
    """The compiled parse of one file's bytes declines them or builds the graph the Python
    reader builds of that file (its references included); never accepts what it refuses."""
    from flexhrc.representation.formats import andor_text

    try:
        from flexhrc.representation.formats import _andor_fast
    except ImportError:
        return
    flat = _andor_fast.parse(data)
    if flat is None:
        return
    saved = andor_text._parse_compiled
    andor_text._parse_compiled = None
    try:
        ref, ref_refs = andor_text.parse_graph(path)
    except FormatError as exc:
        raise AssertionError(f"the compiled reader accepts what Python refuses: {exc}") from None
    finally:
        andor_text._parse_compiled = saved
    g, refs = andor_text._from_compiled(path, flat)
    assert refs == ref_refs
    for graph in (g, ref):
        graph.validate()
    dump = [(x.name, x.root, x.root_line, [(n.name, n.weight, n.line) for n in x.nodes.values()],
             [(a.name, a.children, a.parent, a.weight, a.lower, a.line)
              for a in x.hyperarcs.values()], [str(w) for w in x.validate()])
            for x in (g, ref)]  # fmt: skip
    assert dump[0] == dump[1], dump


ANDOR = Target(
    "andor",
    "ANDOR text files: the compiled and the pure-Python reader agree (load)",
    _andor_inputs,
    _andor_check,
)


# scenarios ------------------------------------------------------------------------------------
_LID = "lid: {type: lid, position: [0.40, 0.25, 0.0], size: [0.30, 0.20, 0.01]}"
#: The probe's scenario cases (sections 16 and 18), as edits of examples/scenarios/lid_task.yaml.
PROBE_SCENARIO_EDITS: dict[str, tuple[str, str]] = {
    "S01": (_LID, _LID[:-1] + ", attrs: abc}"),
    "S02": (_LID, _LID[:-1] + ", attrs: [1, 2]}"),
    "S03": (_LID, _LID[:-1] + ", reachable_by: 5}"),
    "S04": (_LID, _LID[:-1] + ", reachable_by: arm}"),
    "S05": (_LID, _LID[:-1] + ", fixed: 'no'}"),
    "S07": ("types: [robot]", "types: 5"),
    "S08": ("reach: 0.9}", "reach: far}"),
    "S09": ("reach: 0.9}", "reach: -1}"),
    "S10": ("reach: 0.9}", "reach: .nan}"),
    "S11": ("speed: 1.0", "speed: 0"),
    "S17": ("flexhrc: 1", "flexhrc: true"),
    "S22": ("world:\n", "world:\n  supertypes: {lid: thing, thing: lid}\n"),
}


def alias_bomb(levels: int) -> bytes:
    """lid_task.yaml whose facts are ``levels`` nested YAML aliases of ten (probe S32v had 8:
    400 bytes standing for 10**8 strings)."""
    import re

    names = "abcdefghij"[: levels + 1]
    head = "a: &a [x, x, x, x, x, x, x, x, x, x]\n"
    for p, n in itertools.pairwise(names):
        head += f"{n}: &{n} [" + ", ".join([f"*{p}"] * 10) + "]\n"
    text = (REPO / "examples" / "scenarios" / "lid_task.yaml").read_text()
    text = re.sub(r"\n  facts: .*\n", f"\n  facts: *{names[-1]}\n", text, count=1)
    return (head + text).encode()


def probe_scenario(case: str) -> bytes:
    """lid_task.yaml with the change of probe case ``case``."""
    text = (REPO / "examples" / "scenarios" / "lid_task.yaml").read_text()
    old, new = PROBE_SCENARIO_EDITS[case]
    assert old in text, case
    return text.replace(old, new, 1).encode()


def scenario_seeds() -> list[tuple[Path, str, str, bytes]]:
    """(folder, file to mutate, scenario file to check — relative to the folder —, the file's
    bytes): every shipped scenario file, each file it sits beside (its domain, its graph), and
    the probe's cases (edits of lid_task.yaml)."""
    from flexhrc.scenario.format import is_scenario_file

    examples = REPO / "examples" / "scenarios"
    out = [
        (examples, "lid_task.yaml", "lid_task.yaml", probe_scenario(c))
        for c in PROBE_SCENARIO_EDITS
    ]
    out.append((examples, "lid_task.yaml", "lid_task.yaml", alias_bomb(5)))
    for folder in [
        *sorted(p for p in BUILTIN.iterdir() if p.is_dir()),
        REPO / "examples" / "scenarios",
    ]:
        files = sorted(f for f in folder.rglob("*") if f.suffix in (".yaml", ".txt"))
        for entry in files:
            if not is_scenario_file(entry):
                continue
            e = str(entry.relative_to(folder))
            out.append((folder, e, e, entry.read_bytes()))
            if folder.parent == BUILTIN:  # a built-in's own folder: its domain and graph files
                out += [
                    (folder, str(f.relative_to(folder)), e, f.read_bytes())
                    for f in files
                    if f != entry
                ]
    return out


def _scenario_inputs() -> st.SearchStrategy[tuple[Path, str, str, bytes]]:
    seeds = scenario_seeds()

    @st.composite
    def build(draw: st.DrawFn) -> tuple[Path, str, str, bytes]:
        folder, rel, entry, data = draw(st.sampled_from(seeds))
        return folder, rel, entry, draw(mutated([data], 3))

    return build()


def _scenario_check(ws: Workspace, value: tuple[Path, str, str, bytes]) -> None:
    from flexhrc.scenario.format import ScenarioError, check, parse

    folder, rel, entry, data = value
    with ws.placed(folder, rel, data):
        path = ws.copy_of(folder) / entry
        scenario, faults = check(path)
        for f in faults:
            assert f.source and f.message.strip(), f
            clear(ValueError(str(f)), size=len(data))
        errors = [f for f in faults if f.severity == "error"]
        assert (scenario is None) == bool(errors), (scenario, faults)
        try:
            parsed = parse(path)
        except ScenarioError as exc:
            clear(exc, size=len(data))
            assert errors, "parse refuses what check finds no error in"
            return
        assert not errors and parsed.name == scenario.name  # type: ignore[union-attr]


SCENARIO = Target(
    "scenario",
    "scenario files and the files they name: scenario.format.check / parse",
    _scenario_inputs,
    _scenario_check,
)


# event store ----------------------------------------------------------------------------------
def store_rows() -> list[tuple[int, float, str, str]]:
    """The rows of a store the cell wrote (tests/data/logs/old_cell_store.jsonl)."""
    rows = []
    for line in (DATA / "old_cell_store.jsonl").read_text().splitlines():
        r = json.loads(line)
        rows.append((r["seq"], r["t"], r["kind"], json.dumps(r["body"])))
    return rows


#: Odd values of a column (SQLite keeps whatever it is given): the probe's ST cases among them.
ODD_CELLS: tuple[Any, ...] = (
    None, "", "abc", "{not json", "[1,2]", "[]", "null", "1", '"x"', "{}", "NaN", "1e400",
    '{"id": "abc", "status": "done"}', '{"id": 999, "status": "done", "agent": "left"}',
    '{"id": 1, "status": "exploded", "agent": "left"}', "[" * 100000, "teleport", "ack",
    "start", "outcome", "summary", "command", "stop", -1, 0, 10**18, 1.5, 1e300, math.nan,
    math.inf, -math.inf, b"\x00\xff", "\udcff",
)  # fmt: skip


@dataclass(frozen=True)
class RowEdit:
    """One corruption of a store: ``op`` picks it, ``row``, ``col`` and ``arg`` the place and
    the value."""

    op: int
    row: int
    col: int
    arg: int


ROW_EDITS = st.builds(
    RowEdit, st.integers(0, 5), st.integers(0, 200), st.integers(0, 3), st.integers(0, 1 << 16)
)


def edit_rows(rows: list[tuple[Any, ...]], e: RowEdit) -> list[tuple[Any, ...]]:
    rows = list(rows)
    if not rows:
        return rows
    i = e.row % len(rows)
    op = e.op % 6
    if op == 0:  # one cell replaced by an odd value
        r = list(rows[i])
        r[e.col % 4] = ODD_CELLS[e.arg % len(ODD_CELLS)]
        if e.col % 4 == 0 and not isinstance(r[0], int):
            r[0] = rows[i][0]  # (seq is the primary key: only integers)
        rows[i] = tuple(r)
    elif op == 1:  # a row deleted (a gap, a missing start)
        del rows[i]
    elif op == 2:  # a row repeated at the end (ST15r: an ack applied twice)
        rows.append((rows[-1][0] + 1, *rows[i][1:]))
    elif op == 3:  # the body edited inside (a field missing, of the wrong type, odd)
        r = list(rows[i])
        r[3] = _edit_body(r[3], e.arg)
        rows[i] = tuple(r)
    elif op == 4:  # cut short
        rows = rows[: i + 1]
    else:  # two rows' times or kinds swapped
        k = e.arg % len(rows)
        c = 1 + e.col % 2
        a, b = list(rows[i]), list(rows[k])
        a[c], b[c] = b[c], a[c]
        rows[i], rows[k] = tuple(a), tuple(b)
    return rows


def _edit_body(text: Any, arg: int) -> Any:
    try:
        body = json.loads(text)
    except (TypeError, ValueError, RecursionError):  # a row already "[" * 100000 (ODD_CELLS)
        return text
    if not isinstance(body, dict) or not body:
        return text
    keys = sorted(body)
    key = keys[arg % len(keys)]
    if arg % 3 == 0:
        del body[key]
    else:
        body[key] = ODD_VALUES[(arg // 3) % len(ODD_VALUES)]
    try:
        return json.dumps(body)
    except ValueError:
        return text


#: Tables a store file might hold instead of the right one (ST17: no ``t``).
SCHEMAS: tuple[str, ...] = (
    "CREATE TABLE events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)",
    "CREATE TABLE events(seq, t, kind, body)",
    "CREATE TABLE events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT, extra)",
    "CREATE TABLE events(seq INTEGER PRIMARY KEY, kind TEXT, body TEXT)",
    "CREATE TABLE events(seq INTEGER PRIMARY KEY, kind TEXT, t REAL, body TEXT)",
    "CREATE TABLE other(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)",
    "CREATE VIEW events AS SELECT 1 AS seq, 0.0 AS t, 'start' AS kind, '{}' AS body",
)


@dataclass(frozen=True)
class StoreCase:
    """A store to write: its rows (edited), its table, and byte edits of the file."""

    rows: tuple[tuple[Any, ...], ...]
    schema: int
    file_edits: tuple[Mutation, ...]

    def write(self, path: Path) -> None:
        db = sqlite3.connect(path)
        schema = SCHEMAS[self.schema % len(SCHEMAS)]
        db.execute(schema)
        if schema.startswith("CREATE TABLE events"):
            cols = schema[schema.index("(") + 1 : -1].split(", ")
            names = [c.split()[0] for c in cols]
            for r in self.rows:
                row = dict(zip(("seq", "t", "kind", "body"), r, strict=True))
                values = [row.get(n) for n in names]
                db.execute(
                    f"INSERT INTO events({', '.join(names)}) VALUES ({', '.join('?' * len(names))})",
                    values,
                )
        db.commit()
        db.close()
        if self.file_edits:
            data = path.read_bytes()
            for m in self.file_edits:
                data = m.apply(data)
            path.write_bytes(data)


def _store_inputs() -> st.SearchStrategy[StoreCase]:
    seed = store_rows()

    @st.composite
    def build(draw: st.DrawFn) -> StoreCase:
        rows: list[tuple[Any, ...]] = list(seed)
        for e in draw(st.lists(ROW_EDITS, max_size=3)):
            rows = edit_rows(rows, e)
        schema = draw(st.integers(0, len(SCHEMAS) - 1) | st.just(0))
        edits = draw(st.lists(MUTATIONS, max_size=2) | st.just([]))
        return StoreCase(tuple(rows), schema, tuple(edits))

    return build()


def _store_check(ws: Workspace, case: StoreCase) -> None:
    folder = ws.fresh()
    try:
        _check_store_file(folder / "cell.db", case)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _check_store_file(path: Path, case: StoreCase) -> None:
    from flexhrc.cell.replay import replay
    from flexhrc.cell.store import EventStore, StoreError, read_store

    try:
        case.write(path)
    except (sqlite3.Error, ValueError, OverflowError):
        return  # sqlite refused to hold the value: no such store exists
    size = path.stat().st_size
    try:
        events = read_store(path)
    except FormatError as exc:
        clear(exc, path.name, size=size)
    else:
        for ev in events:  # what a reader hands on is what the schema says
            assert isinstance(ev.seq, int) and isinstance(ev.kind, str), ev
            assert isinstance(ev.body, dict) and math.isfinite(ev.t), ev
    try:
        report = replay(path)
    except FormatError as exc:
        clear(exc, path.name, size=size)
    else:
        assert report.text and report.json["events"] == len(report.events)
    try:
        store = EventStore(path, resume=True)  # what --resume reads
    except StoreError as exc:
        clear(exc, path.name, size=size)
        return
    try:
        store.events()
    except (StoreError, FormatError) as exc:  # a damaged row is a FormatError naming its seq
        clear(exc, path.name, size=size)
    finally:
        store.close()


STORE = Target(
    "store",
    "cell event stores (rows, schema, bytes corrupted): read_store, replay FILE.db, resume",
    _store_inputs,
    _store_check,
)


# replay ---------------------------------------------------------------------------------------
def _log_files() -> list[bytes]:
    return [
        f.read_bytes() for f in sorted(DATA.glob("*.jsonl")) if f.name != "old_cell_store.jsonl"
    ]


def _replay_inputs() -> st.SearchStrategy[bytes]:
    seeds = _log_files()

    @st.composite
    def structured(draw: st.DrawFn) -> bytes:
        lines = draw(st.sampled_from(seeds)).split(b"\n")
        for _ in range(draw(st.integers(1, 3))):
            i = draw(st.integers(0, len(lines) - 1))
            try:
                ev = json.loads(lines[i])
            except ValueError:
                continue
            lines[i] = _dumps(draw(json_edits(ev)))
        return b"\n".join(lines)

    return st.one_of(mutated(seeds), structured())


def _replay_check(ws: Workspace, data: bytes) -> None:
    from flexhrc.cell.replay import replay

    path = ws.fresh() / "run.jsonl"
    path.write_bytes(data)
    try:
        report = replay(path)
    except FormatError as exc:
        clear(exc, path.name, size=path.stat().st_size)
        return
    assert report.text and report.json["events"] == len(report.events)
    json.dumps(report.json, allow_nan=False)  # replay --json prints it


REPLAY = Target(
    "replay",
    "JSON-lines cooperation logs: cell.replay.replay (check_log, summarise_log)",
    _replay_inputs,
    _replay_check,
)


TARGETS: dict[str, Target] = {t.name: t for t in (PROTOCOL, EVENTS, ANDOR, SCENARIO, STORE, REPLAY)}

__all__ = ["TARGETS", "Hang", "Target", "Unclear", "Workspace", "watchdog"]
