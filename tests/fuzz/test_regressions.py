"""Inputs the fuzz targets found, each a case of its own.

Fixed here (the store reader, the ANDOR and YAML readers) or pinned ``xfail(strict=True)`` with
the module that owns the fix (the protocol and event catalogue, ``replay``, the scenario
reader): when that module is fixed the case passes, the xfail turns red, and the entry of
``KNOWN`` in ``targets.py`` that lets the fuzz run past it is removed with the mark.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell.protocol import ProtocolError, parse
from flexhrc.cell.replay import replay
from flexhrc.cell.store import EventStore, StoreError, read_store
from flexhrc.errors import FlexhrcError, FormatError

from .targets import KNOWN, Workspace, alias_bomb, probe_scenario, read_graph, store_rows

DATA = Path(__file__).resolve().parents[1] / "data" / "logs"


# -- the event store (fixed: cell/store.py) ---------------------------------------------------
def _store(path: Path, change: str | None, schema: str | None = None) -> Path:
    """The rows of a store the cell wrote, with one SQL ``change`` (the probe's ST cases:
    a checkpointed copy with one row changed; seq 4 is the first ack)."""
    db = sqlite3.connect(path)
    db.execute(
        schema or "CREATE TABLE events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)"
    )
    if schema is None:
        db.executemany("INSERT INTO events VALUES (?, ?, ?, ?)", store_rows())
    else:
        db.executemany(
            "INSERT INTO events(seq, kind, body) VALUES (?, ?, ?)",
            [(s, k, b) for s, _, k, b in store_rows()],
        )
    if change:
        db.execute(change)
    db.commit()
    db.close()
    return path


_ST = [
    ("st01", "UPDATE events SET body='{not json' WHERE seq=4", "event 4 (ack): the body is not JSON"),
    ("st02", "UPDATE events SET body='[1,2]' WHERE seq=4", "event 4 (ack): the body must be a JSON object"),
    ("st03", "UPDATE events SET t=NULL WHERE seq=4", "event 4 (ack): 't' must be a finite time"),
    ("st04", "UPDATE events SET t='abc' WHERE seq=4", "event 4 (ack): 't' must be a finite time"),
    ("st08", "UPDATE events SET body=json_remove(body, '$.status') WHERE seq=4", "event 4 (ack): ack: missing field 'status'"),
    ("st09", "UPDATE events SET body=json_set(body, '$.id', 'abc') WHERE seq=4", "event 4 (ack): ack: field 'id' must be int"),
    ("st12", "UPDATE events SET body='[]' WHERE seq=1", "event 1 (start): the body must be a JSON object"),
    ("nan", "UPDATE events SET body='{\"id\": NaN}' WHERE seq=4", "event 4 (ack): the body is not JSON"),
    ("deep", "UPDATE events SET body='" + "[" * 100000 + "' WHERE seq=4", "event 4 (ack): the body is nested too deeply"),
    ("kind", "UPDATE events SET kind=NULL WHERE seq=4", "event 4: unknown kind None"),
    ("human", "UPDATE events SET kind='human_action', body='{\"action\": \"a\", \"start\": \"x\"}' WHERE seq=4", "event 4 (human_action): human_action: missing field"),
]  # fmt: skip


@pytest.mark.parametrize(("case", "change", "message"), _ST, ids=[c for c, _, _ in _ST])
def test_st_a_corrupted_store_row_is_one_clear_error(
    case: str, change: str, message: str, tmp_path: Path
) -> None:
    """Probe ST01-ST04, ST08, ST09, ST12 (replay and --resume): one error naming the store and
    the event, never a traceback."""
    path = _store(tmp_path / "x.db", change)
    errors: list[FlexhrcError] = []
    try:
        read_store(path)
        with pytest.raises(FormatError) as exc:
            replay(path)
        errors.append(exc.value)
    except FormatError as read_error:  # the row itself is malformed: every reader says so
        errors.append(read_error)
        with (
            pytest.raises((StoreError, FormatError)) as resumed,
            EventStore(path, resume=True) as s,
        ):
            s.events()
        errors.append(resumed.value)
    for err in errors:
        assert str(path) in str(err) and message in str(err), err


def test_st17_a_store_without_its_t_column_is_refused(tmp_path: Path) -> None:
    """Probe ST17r: ``--resume`` of a store whose table has no ``t`` column (it gave an
    ``sqlite3.OperationalError`` traceback)."""
    path = _store(
        tmp_path / "x.db", None, "CREATE TABLE events(seq INTEGER PRIMARY KEY, kind, body)"
    )
    with pytest.raises(StoreError, match="no events table") as exc:
        EventStore(path, resume=True)
    assert str(path) in str(exc.value)
    with pytest.raises(FormatError, match="no events table"):
        read_store(path)


def test_a_store_of_good_rows_reads_the_same(tmp_path: Path) -> None:
    path = _store(tmp_path / "x.db", None)
    events = read_store(path)
    assert [(e.seq, e.t, e.kind, json.dumps(e.body)) for e in events] == store_rows()
    with EventStore(path, resume=True) as store:
        assert store.events() == events
    assert replay(path).json["outcome"] == "solved"


def test_a_refused_resume_leaves_no_lock(tmp_path: Path) -> None:
    """A store refused on open is closed again: a corrected file can be opened at once."""
    path = _store(tmp_path / "x.db", "DELETE FROM events WHERE seq=5")
    with pytest.raises(StoreError, match="gaps"):
        EventStore(path, resume=True)
    with sqlite3.connect(path) as db:
        db.execute("UPDATE events SET seq=seq-1 WHERE seq>5")
    with EventStore(path, resume=True) as store:
        assert store.last_seq == len(store_rows()) - 1


# -- the ANDOR and YAML readers (fixed: representation/formats/) ------------------------------
def test_an_andor_error_quotes_an_excerpt_of_a_long_line(tmp_path: Path) -> None:
    """The fuzz input: a node line of thousands of characters was quoted whole."""
    path = tmp_path / "g.txt"
    path.write_text("g 2 r\n" + "{a: " * 1500 + "\nr 0\nh 1 r 1 -\nn\n")
    for compiled in (False, True):
        outcome, message = read_graph(path, compiled)
        assert outcome == "refused" and "node line must be" in message
        assert len(message) < 400 and "(5999 characters)" in message


def test_yaml_with_a_control_character_is_a_syntax_error_with_its_line(tmp_path: Path) -> None:
    """The fuzz input: a U+0003 in a scenario file gave a ``yaml.reader.ReaderError``."""
    from flexhrc.scenario.format import check

    path = tmp_path / "s.yaml"
    path.write_bytes(b"flexhrc: 1\nname: x\n\x03 oops\n")
    scenario, faults = check(path)
    assert scenario is None
    assert [str(f) for f in faults] == [
        f"{path}:3: YAML syntax error: character U+0003 is not allowed in YAML"
    ]


# -- findings the fuzz targets made in other modules, fixed there ----------------------------
def _msg(**fields: Any) -> dict[str, Any]:
    base = {"v": 1, "type": "ack", "id": 7, "agent": "left", "status": "done", "t": 3.5}
    return {**base, **fields}


def test_events_a_huge_integer_position_is_refused() -> None:
    """An integer literal of 401 digits in a position (JSON allows it; json_decode gives an
    int): ``OverflowError`` from ``events._finite`` instead of a ProtocolError. Owner:
    ``flexhrc/events.py``; shown by ``cell.protocol.parse`` (agents and the manager)."""
    with pytest.raises(ProtocolError, match="position"):
        parse(_msg(positions={"leg1": [10**400, 0.0, 0.0]}))


def test_protocol_an_infinite_number_in_any_field_is_refused() -> None:
    """``1e999`` is valid JSON that decodes to infinity (``json_decode`` refuses only the
    NaN/Infinity words). In a field the schema does not look into (``sensed``, ``world``,
    ``size`` of a percept as a dict key's value...) it is accepted, and the store, which
    writes strict JSON, then fails on it. Owner: ``flexhrc/events.py`` (or the transports'
    ``json_decode``)."""
    from flexhrc.transport.zenoh import json_decode

    data = (b'{"v": 1, "type": "human_action", "id": "h1", "agent": "human",'
            b' "action": "pick_up(human, leg1)", "t": 1.0, "sensed": {"score": 1e999}}')  # fmt: skip
    with pytest.raises(ValueError, match="out of range"):  # the receiver drops it
        json_decode(data)


def test_replay_a_solved_event_with_a_null_agent_is_refused(tmp_path: Path) -> None:
    """A ``solved`` event with ``"agents": [null]`` passes ``check_log`` and breaks
    ``summarise_log`` (``"+".join``): a traceback of ``flexhrc replay``. Owner:
    ``flexhrc/events.py`` (the ``solved`` schema: agents=AGENTS) / ``taskmanager/replay.py``."""
    lines = (DATA / "ball.jsonl").read_text().splitlines()
    i = next(i for i, line in enumerate(lines) if '"type": "solved"' in line)
    ev = json.loads(lines[i])
    ev["agents"] = [None]
    lines[i] = json.dumps(ev)
    path = tmp_path / "run.jsonl"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match="agents"):
        replay(path)


def test_replay_a_start_event_with_unhashable_humans_is_refused(tmp_path: Path) -> None:
    """A ``start`` event with ``"humans": [[]]`` passes ``check_log`` and breaks
    ``summarise_log`` (``set(humans)``): a traceback of ``flexhrc replay``. Owner:
    ``flexhrc/events.py`` (the ``start`` schema: humans a list of names) /
    ``taskmanager/replay.py``."""
    lines = (DATA / "ball.jsonl").read_text().splitlines()
    start = json.loads(lines[0])
    start["humans"] = [[]]
    lines[0] = json.dumps(start)
    path = tmp_path / "run.jsonl"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match="humans"):
        replay(path)


def test_protocol_a_huge_integer_time_is_refused() -> None:
    """``"t": 10**400`` in a command: the bound check formatted it with ``:g`` and raised
    ``OverflowError`` (``fuzz.py --target protocol --seed 2364653851``). An int too large for a
    float is not a finite number."""
    cmd = {"v": 1, "type": "command", "id": 7, "agents": ["left"], "element": "robot_1",
           "action": "approach(left, leg1)", "t": 10**400}  # fmt: skip
    with pytest.raises(ProtocolError, match=r"'t'.* finite") as err:
        parse(cmd)
    assert len(str(err.value)) < 200  # the 401 digits are cut, not quoted whole
    with pytest.raises(ProtocolError, match=r"'expected_s'.* finite"):
        parse({**cmd, "t": 1.0, "expected_s": -(10**400)})


def test_replay_a_huge_integer_time_is_refused(tmp_path: Path) -> None:
    """A log whose ``start`` has ``"t": 10**400``: ``math.isfinite`` of it raised
    ``OverflowError`` in ``taskmanager/replay.py`` (``fuzz.py --target replay --seed
    2652320755``)."""
    lines = (DATA / "ball.jsonl").read_text().splitlines()
    start = json.loads(lines[0])
    start["t"] = 10**400
    lines[0] = json.dumps(start)
    path = tmp_path / "run.jsonl"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=r"run.jsonl:1: start: 't' must be a finite") as err:
        replay(path)
    assert len(str(err.value)) < 300


def test_store_a_command_without_its_action_is_refused(tmp_path: Path) -> None:
    """A stored ``command`` without ``action`` passed ``check_events`` and broke the log a
    replay or a resume builds (``KeyError: 'action'``; ``fuzz.py --target store --seed
    4041888080``). Every stored command is checked as the message it was."""
    rows = store_rows()
    seq = next(r[0] for r in rows if r[2] == "command")
    path = _store(tmp_path / "cell.db", None)
    db = sqlite3.connect(path)
    db.execute("UPDATE events SET body=json_remove(body, '$.action') WHERE seq=?", (seq,))
    db.commit()
    db.close()
    with pytest.raises(FormatError, match=f"event {seq} \\(command\\): command: .*'action'"):
        replay(path)


@pytest.mark.parametrize("kind", ["stop", "suggestion", "options"])
def test_store_a_sent_message_without_its_id_is_refused(kind: str, tmp_path: Path) -> None:
    """A stored ``stop`` without ``id`` passed ``check_events`` and broke the log a replay or a
    resume builds (``KeyError: 'id'``; ``fuzz.py --target store --seed 1983041639``). What the
    manager sent is read back as the message it was, like a command."""
    rows = store_rows()
    seq = rows[-1][0] + 1
    body = {"stop": {"id": 1, "reason": "x"}, "suggestion": {"id": "s1", "agent": "human"},
            "options": {"id": "o1", "agent": "human"}}[kind]  # fmt: skip
    path = _store(tmp_path / "cell.db", None)
    db = sqlite3.connect(path)
    db.execute("INSERT INTO events VALUES (?, ?, ?, ?)", (seq, rows[-1][1], kind, json.dumps(body)))
    db.execute("UPDATE events SET body=json_remove(body, '$.id') WHERE seq=?", (seq,))
    db.commit()
    db.close()
    with pytest.raises(FormatError, match=f"event {seq} \\({kind}\\): {kind}: missing field 'id'"):
        replay(path)


def test_scenario_a_huge_malformed_literal_is_quoted_in_part() -> None:
    """A scenario of 2 367 bytes whose aliases build a literal of 342 291 characters: the
    error quoted all of it (``fuzz.py --target scenario --seed 294809954``). Literal errors
    quote at most 80 characters and say how long the text was."""
    from flexhrc.logic.terms import parse_conjunction, parse_literal

    for call, text in [
        (parse_literal, "[" + "'Zx, x]', " * 30000),
        (parse_literal, "p(" + "a, " * 30000 + "!)"),
        (parse_conjunction, "a(" * 50000),
        (parse_conjunction, "a)" * 50000),
    ]:
        with pytest.raises(FormatError) as err:
            call(text, "task.yaml", 60)
        message = str(err.value)
        assert message.startswith("task.yaml:60: ") and len(message) < 200, message[:300]
        assert f"({len(text)} characters)" in message


@pytest.mark.parametrize("last", ["rt{", b"rt{", 7.5])
def test_store_a_seq_that_is_no_whole_number_is_refused_at_resume(
    last: Any, tmp_path: Path
) -> None:
    """A table declared without types keeps a text or blob ``seq`` as it is: ``int()`` of it
    was a ValueError traceback of ``--resume`` (``fuzz.py --target store --seed 3782358320``)."""
    path = tmp_path / "cell.db"
    db = sqlite3.connect(path)
    db.execute("CREATE TABLE events(seq, t, kind, body)")
    db.executemany("INSERT INTO events VALUES (?, ?, ?, ?)", store_rows()[:3])
    db.execute("INSERT INTO events VALUES (?, 1.0, 'percept', '{}')", (last,))
    db.commit()
    db.close()
    for _ in range(2):  # the refused store is let go: the same answer again, not "locked"
        with pytest.raises(StoreError, match=r"not a flexhrc event store .*not a whole number"):
            EventStore(path, resume=True)


@pytest.mark.parametrize("case", ["S01", "S02", "S03", "S07"])
def test_scenario_a_value_of_the_wrong_type_is_a_fault(case: str, tmp_path: Path) -> None:
    """Probe S01 ``attrs: abc``, S02 ``attrs: [1, 2]``, S03 ``reachable_by: 5``, S07 agent
    ``types: 5`` in lid_task.yaml: ``ValueError``/``TypeError`` tracebacks of ``check``
    (the fuzz target finds them again from these seeds). Owner: ``flexhrc/scenario/format.py``."""
    from flexhrc.scenario.format import check

    path = tmp_path / "lid_task.yaml"
    path.write_bytes(probe_scenario(case))
    scenario, faults = check(path)
    assert scenario is None and any(f.severity == "error" and f.line for f in faults)


def test_scenario_s32v_an_alias_is_not_expanded_into_a_message(tmp_path: Path) -> None:
    """Probe S32v in small: 6 levels of YAML aliases (1.6 kB) for the facts of lid_task.yaml;
    every fact is quoted expanded, ten faults of 522 kB each (8 levels: 522 MB). Owner:
    ``flexhrc/scenario/format.py`` (``_world``: ``parse_literal(str(f))``, ``{f!r}``)."""
    from flexhrc.scenario.format import check

    path = tmp_path / "lid_task.yaml"
    path.write_bytes(alias_bomb(6))
    _, faults = check(path)
    assert faults and sum(len(str(f)) for f in faults) < 3 * path.stat().st_size


def test_every_known_finding_has_its_xfail_test() -> None:
    names = {name for name in globals() if name.startswith("test_")}
    assert {k.test for k in KNOWN} <= names


def test_the_workspace_puts_a_placed_file_back(tmp_path: Path) -> None:
    folder = tmp_path / "seed"
    folder.mkdir()
    (folder / "a.txt").write_bytes(b"original")
    ws = Workspace(tmp_path / "ws")
    (tmp_path / "ws").mkdir()
    with ws.placed(folder, "a.txt", b"mutated") as p:
        assert p.read_bytes() == b"mutated"
    assert p.read_bytes() == b"original" and (folder / "a.txt").read_bytes() == b"original"


def test_the_watchdog_turns_a_hang_into_a_failure() -> None:
    from .targets import Hang, watchdog

    with pytest.raises(Hang), watchdog(0.05):
        while True:
            pass
