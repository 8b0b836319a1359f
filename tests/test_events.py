"""The one catalogue of events, messages and vocabularies (``flexhrc.events``, issue 19 item 4).

Every type round-trips key for key; an unknown type or a broken field is one clear error; every
record the shipped scenarios write — through ``flexhrc.scenario.run`` and through the in-process
cell, its store and its bus — is catalogued and follows its schema; the sets the consumers read
are the catalogue's; logs and stores written by older versions still replay to the summary
those versions printed.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest

from flexhrc import events, scenario
from flexhrc.cell import Cell, EventStore, HumanAgent, RobotAgent
from flexhrc.cell import protocol as P
from flexhrc.cell.components import execution_model
from flexhrc.cli import main
from flexhrc.events import (
    LOG_EVENTS,
    MESSAGES,
    STORE_KINDS,
    AckStatus,
    Event,
    EventError,
    Outcome,
    Profile,
    SimulatorName,
)
from flexhrc.scenario import load_scenario
from flexhrc.transport import InProcessBus

from .cell.helpers import pump_of

DATA = Path(__file__).parent / "data" / "logs"
DOCS = Path(__file__).parents[1] / "docs" / "protocol.md"

# values that the rules of a few fields need (any other field gets one of its types' sample)
SPECIAL: dict[str, Any] = {
    "agents": ["left", "right"],
    "actions": ["grasp(leg1)"],
    "branches": [],
    "pose": [0.1, 0.2, 0.0],
    "size": [0.1, 0.1, 0.1],
    "steps": [{"step": "s1", "arcs": [{"hyperarc": "a", "cost": 1, "branches": [["x(y)"]]}]}],
    "decided": ["s0"],
    "positions": {"leg1": [0.0, 0.1, 0.2]},
    "timing": {"total_s": 3.0, "simulator_s": 0.25},
    "t": 3.0,
    "start": 1.5,
    "act": False,
    "answer": "no",
    "on_failure": "paper",
    "policy": "lookahead",
    "reply": "decline",
}
BY_TYPE: dict[type, Any] = {str: "x", int: 2, float: 0.5, bool: False, list: ["a"], dict: {}}


def _sample(schema: events.EventSchema, *, optional: bool) -> dict[str, Any]:
    out: dict[str, Any] = {"type": schema.type}
    for name, f in schema.fields.items():
        if not (f.required or optional):
            continue
        if name == "status":
            out[name] = "done"
        elif name == "outcome":
            out[name] = "solved"
        elif name in SPECIAL:
            out[name] = SPECIAL[name]
        else:
            out[name] = BY_TYPE[next(t for t in f.types if t is not type(None))]
    return out


ALL = [(LOG_EVENTS, t) for t in LOG_EVENTS] + [(MESSAGES, t) for t in MESSAGES]


@pytest.mark.parametrize(
    ("catalogue", "kind"), ALL, ids=[f"{'msg' if c is MESSAGES else 'log'}-{k}" for c, k in ALL]
)
@pytest.mark.parametrize("optional", [False, True])
def test_every_type_round_trips_key_for_key(catalogue, kind, optional) -> None:
    record = _sample(catalogue[kind], optional=optional)
    if catalogue is MESSAGES:
        record = {"v": P.VERSION, **record}
        assert P.parse(record) is record
    ev = Event.from_dict(record, catalogue)
    assert ev.type == kind
    assert json.dumps(ev.to_dict()) == json.dumps(record)  # same keys, same order
    with pytest.raises(TypeError):
        ev.data["type"] = "other"  # type: ignore[index]


@pytest.mark.parametrize("catalogue", [LOG_EVENTS, MESSAGES])
def test_an_unknown_type_is_refused_with_a_clear_message(catalogue) -> None:
    what = "message" if catalogue is MESSAGES else "event"
    with pytest.raises(EventError, match=f"^unknown {what} type 'teleport': not in the catal"):
        Event.from_dict({"type": "teleport", "t": 1.0}, catalogue)
    with pytest.raises(EventError, match=f"unknown {what} type None"):
        Event.from_dict({"t": 1.0}, catalogue)
    with pytest.raises(EventError, match="must be a JSON object, not list"):
        Event.from_dict([], catalogue)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("record", "expected"),
    [
        ({"type": "solved", "t": 1.0}, "solved: 'element' must be a hyper-arc name"),
        ({"type": "solved", "t": -1, "element": "a"},
         "solved: 't' must be a finite time >= 0, got -1"),
        ({"type": "fixed", "t": 1, "object": "leg1", "agents": []},
         "fixed: 'agents' must be a list of agent names"),
        ({"type": "outcome", "t": 1, "outcome": "won"},
         "outcome: 'outcome' must be one of solved, failed, interrupted, got 'won'"),
        ({"type": "action_end", "t": 1, "agents": ["h"], "action": "a", "status": "stopped",
          "start": 2}, "action_end: 'start' must be a finite time between 0 and t = 1, got 2"),
        ({"type": "command", "t": 1, "id": True}, "command: 'id' must be a whole number"),
        ({"type": "decision", "t": 1, "branches": [{}], "chosen": 1},
         "decision: 'chosen' is not one of its 1 branches"),
    ],
)  # fmt: skip
def test_a_broken_field_is_one_line_naming_the_type_and_the_field(record, expected) -> None:
    with pytest.raises(EventError) as err:
        Event.from_dict(record)
    assert str(err.value) == expected


def test_the_vocabularies_are_the_strings_on_disk() -> None:
    from flexhrc.scenario import model, simulators
    from flexhrc.taskmanager import operator

    assert events.PROFILES == ("passive", "takeover", "cooperative", "random", "reluctant")
    for profiles in (operator.PROFILES, model.PROFILES):
        assert tuple(profiles) == tuple(Profile)
    assert tuple(Outcome) == ("solved", "failed", "interrupted")
    assert model.SIMULATORS == simulators.SIMULATORS == tuple(SimulatorName)
    assert events.ACK_STATUSES == ("done", "failed", "timed_out")
    assert (*events.ACK_STATUSES, AckStatus.STOPPED) == events.ACTION_STATUSES
    assert json.dumps({"p": Profile.TAKEOVER}) == '{"p": "takeover"}'


def test_the_consumers_read_the_catalogue() -> None:
    from flexhrc.app import run
    from flexhrc.cell import store, supervisor
    from flexhrc.representation import online

    assert supervisor.STORED_LOG_TYPES is events.STORED_LOG_TYPES
    assert store.INPUT_KINDS is events.INPUT_KINDS
    assert online.GRAPH_EVENTS == ("met", "solved", "infeasible")
    assert run.TRACE_TYPES is events.TRACE_TYPES  # the live trace of `run` and `demo`
    assert set(run.TRACE_LINES) < events.TRACE_TYPES
    assert set(STORE_KINDS) == events.INPUT_KINDS | events.OUTPUT_KINDS | events.RECORD_KINDS
    assert set(LOG_EVENTS) >= events.RECORD_KINDS and set(LOG_EVENTS) >= events.REPLAY_TYPES
    # the set replay has accepted since section V, and human_declined (issue 22)
    assert (
        len(events.REPLAY_TYPES) == 45
    )  # human_reply: the person's answers are in the log (issue 22)


def test_the_type_tags_are_the_schemas_and_the_module_sits_at_the_bottom() -> None:
    import ast
    from typing import get_args

    assert get_args(events.LogEventType) == tuple(LOG_EVENTS)  # same types, same order
    assert get_args(events.MessageType) == tuple(MESSAGES)
    assert set(get_args(events.StoreKind)) == set(STORE_KINDS)
    tree = ast.parse(Path(events.__file__).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)} | {
        a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names
    }
    assert {m for m in imported if m and m.startswith("flexhrc")} == {"flexhrc.errors"}


def test_the_docs_list_the_catalogue_as_the_code_declares_it() -> None:
    text = DOCS.read_text()
    assert events.catalogue_markdown() in text, "regenerate: events.catalogue_markdown()"


# -- every record the system writes is catalogued ------------------------------------------------
class RecordingBus(InProcessBus):
    def __init__(self) -> None:
        super().__init__()
        self.sent: list[Any] = []

    def publish(self, topic: str, payload: Any) -> None:
        self.sent.append(payload)
        super().publish(topic, payload)


def _checked(records: list[dict[str, Any]], catalogue: Any = None) -> set[str]:
    for r in records:
        try:
            Event.from_dict(r, catalogue)
        except EventError as exc:
            raise AssertionError(f"{exc}: {r}") from None
    return {r["type"] for r in records}


@pytest.mark.parametrize("name", scenario.SHIPPED)
def test_every_event_a_run_writes_is_catalogued_and_replayable(name: str) -> None:
    sc = scenario.load(name)
    seen: set[str] = set()
    for profile in events.PROFILES:
        log: list[dict[str, Any]] = []
        result = scenario.run(sc, profile=profile, seed=1, sink=log.append)
        assert result.summary["outcome"] == "solved"
        seen |= _checked(log)
    assert seen <= events.REPLAY_TYPES
    assert {"start", "decision", "command", "action_end", "solved", "outcome"} <= seen


@pytest.mark.parametrize("name", scenario.SHIPPED)
def test_every_record_message_and_stored_kind_of_a_cell_is_catalogued(name, tmp_path) -> None:
    sc = load_scenario(name)
    bus = RecordingBus()
    traced: list[dict[str, Any]] = []
    store = EventStore(tmp_path / "cell.db")
    cell = Cell(
        sc, bus, store=store, liveliness=False, simulator=execution_model("analytic"),
        trace=traced.append,
    )  # fmt: skip
    agents: list[Any] = []
    for a in sc.domain.agents.values():
        model = execution_model("analytic")
        if a.is_human:  # an operator that acts on its own: options, intent, operator messages
            agents.append(HumanAgent(a.name, sc, bus, profile="takeover", execution=model))
        else:
            agents.append(RobotAgent(a.name, sc, bus, execution=model))
    bus.flush()
    assert cell.run(pump=pump_of(cell, bus, agents))["outcome"] == "solved"
    # the trace carries stored records as they are stored: catalogued types; their log form
    # (what `flexhrc replay FILE.db` reads) follows the log schemas, checked below
    assert {ev["type"] for ev in traced} <= set(LOG_EVENTS)
    assert {ev.kind for ev in cell.events} <= set(STORE_KINDS)
    messages = [m for m in bus.sent if isinstance(m, dict) and "v" in m]
    assert messages and _checked(messages, MESSAGES) <= set(MESSAGES)
    log = main_replay(tmp_path / "cell.db")
    assert log["outcome"] == "solved"


def main_replay(path: Path) -> dict[str, Any]:
    from flexhrc.cell.store import summarise_store

    summary, log = summarise_store(path)
    _checked(log)
    return summary


# -- old logs and stores ------------------------------------------------------------------------
# Written by older versions and committed: old_table.jsonl by `flexhrc demo table --legs 2
# --human takeover` at ad584b2 (before 'fixed' events), ball.jsonl by `flexhrc run ball_in_box
# --human takeover` at 3f2ad9c, old_cell_store.jsonl (the rows of a store) by `flexhrc cell
# table_assembly --store` at 9007802, where the store began. Each *.replay.json is what
# `flexhrc replay --json` printed for it at 3f2ad9c, before this catalogue.
@pytest.mark.parametrize("name", ["old_table.jsonl", "ball.jsonl"])
def test_an_old_log_replays_to_the_same_summary(name, capsys) -> None:
    assert main(["replay", str(DATA / name), "--json"]) == 0
    _same_summary(json.loads(capsys.readouterr().out), DATA / f"{name}.replay.json")


def _same_summary(now: dict, printed_then: Path) -> None:
    """Every key printed then is printed now with the same value; keys are only ever added
    (``fixed_by_agent``, the generic count of ``legs_by_agent``)."""
    then = json.loads(printed_then.read_text())
    assert {k: now.get(k) for k in then} == then
    assert now["fixed_by_agent"] == then["legs_by_agent"]


def test_an_old_store_replays_to_the_same_summary(tmp_path, capsys) -> None:
    db = tmp_path / "old.db"
    with sqlite3.connect(db) as con:  # the schema contract of the store (issue 11)
        con.execute("CREATE TABLE events(seq INTEGER PRIMARY KEY, t REAL, kind TEXT, body TEXT)")
        for line in (DATA / "old_cell_store.jsonl").read_text().splitlines():
            row = json.loads(line)
            con.execute(
                "INSERT INTO events VALUES (?, ?, ?, ?)",
                (row["seq"], row["t"], row["kind"], json.dumps(row["body"])),
            )
    con.close()
    assert main(["replay", str(db), "--json"]) == 0
    _same_summary(json.loads(capsys.readouterr().out), DATA / "old_cell_store.replay.json")


def test_every_type_an_emitter_names_in_the_source_is_catalogued() -> None:
    """Statically, for the emitters no run above reaches (perception in the loop, the panel):
    the first argument of ``_emit``/``_event``/``_record``/``_input`` and the ``"type"`` of a
    dict literal in the packages that write records."""
    import ast

    src = Path(events.__file__).parent
    known = set(LOG_EVENTS) | set(MESSAGES) | set(STORE_KINDS)
    found: dict[str, str] = {}
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src).as_posix()
        writes = rel.split("/")[0] in ("taskmanager", "cell", "sensing", "web")
        for node in ast.walk(ast.parse(path.read_text())):
            tag: Any = None
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in ("_emit", "_event", "_record", "_input")
                and node.args
                and isinstance(node.args[0], ast.Constant)
            ):
                tag = node.args[0].value
            elif writes and isinstance(node, ast.Dict):
                for k, v in zip(node.keys, node.values, strict=True):
                    if isinstance(k, ast.Constant) and k.value == "type":
                        tag = v.value if isinstance(v, ast.Constant) else None
            if isinstance(tag, str):
                found.setdefault(tag, f"{rel}:{getattr(node, 'lineno', '?')}")
    assert len(found) > 40  # the scan sees the emitters
    missing = {tag: where for tag, where in found.items() if tag not in known}
    assert not missing, f"types emitted but not catalogued in flexhrc.events: {missing}"


@pytest.mark.parametrize(
    "facts, ok",
    [
        ([], True),
        ([["free", "left"], ["on_table", "leg1"]], True),
        ([["free", "left"], []], False),  # an empty fact
        ([["free", ""]], False),  # an empty name
        ([["free", 3]], False),
        ([("free", "left")], False),  # not a JSON list
        (["free"], False),
        ([["free", "left"], None], False),
    ],
)
def test_a_command_world_takes_facts_of_names_only(facts: list[Any], ok: bool) -> None:
    msg = {"v": P.VERSION, "type": "command", "id": 1, "agents": ["left"]}
    msg.update(action="rest(left)", t=0.0, expected_s=1.0, world={"facts": facts})
    if ok:
        assert P.parse(msg, expect="command") is msg
    else:
        with pytest.raises(P.ProtocolError, match="world 'facts' must be a list of facts"):
            P.parse(msg, expect="command")
