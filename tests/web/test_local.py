"""The in-process cooperation the operator drives only through the panel."""

from __future__ import annotations

import json

import pytest

from flexhrc.representation import AndOrGraph, HierarchicalGraph, OnlineGraph
from flexhrc.web import PanelInputError
from flexhrc.web.snapshot import graph_snapshot
from tests.web.helpers import advance, finish, human_next, manual_table, run_robots


def test_snapshot_has_the_contract_keys_and_is_plain_json() -> None:
    coop, _ = manual_table(unreachable_bolts=(2,))
    snap = coop.snapshot()
    for key in ("outcome", "suggestions", "agents", "events", "graph", "timeline", "objects"):
        assert key in snap
    assert snap["outcome"] == "running"
    assert isinstance(snap["events"], int) and snap["events"] == len(coop.events) > 0
    for s in snap["suggestions"]:
        assert {"element", "kind", "cost", "graph"} <= set(s)
    assert {(a["name"], a["kind"]) for a in snap["agents"]} == {
        ("human", "human"),
        ("left", "robot"),
        ("right", "robot"),
    }
    assert all({"name", "kind", "status", "alive"} <= set(a) for a in snap["agents"])
    json.dumps(snap, allow_nan=False)  # standard JSON: no NaN/inf costs


def test_operator_only_through_the_panel_completes_the_assembly() -> None:
    coop, clock = manual_table(unreachable_bolts=(2,))
    run_robots(coop, clock)  # bolt 1 by an arm, then the robot needs the operator for bolt 2
    snap = coop.snapshot()
    assert snap["outcome"] == "running"
    assert snap["waiting"] and snap["waiting"].startswith("waiting for the operator")
    (first,) = human_next(coop)
    assert first.startswith("pick_up(human, ")
    coop.submit({"action": first})
    (second,) = human_next(coop)
    assert second.startswith("screw(human, ") and second.endswith("bolt_2)")
    coop.submit({"action": second})
    run_robots(coop, clock)
    snap = coop.snapshot()
    assert snap["outcome"] == "solved", snap["reason"]
    assert coop.kb.holds("filled", "bolt_2")
    done_by_human = [t for t in snap["timeline"] if t["agents"] == ["human"]]
    assert [t["action"] for t in done_by_human] == [first, second]


def test_an_action_that_advances_nothing_is_refused_and_changes_nothing() -> None:
    coop, clock = manual_table(unreachable_bolts=(2,))
    run_robots(coop, clock)
    before = json.dumps(coop.snapshot(), sort_keys=True)
    events = len(coop.events)
    facts = coop.kb.facts
    # screwing before picking up advances no feasible hyper-arc
    with pytest.raises(PanelInputError) as err:
        coop.submit({"action": "screw(human, leg3, bolt_4)"})
    assert err.value.status == 409
    for bad, status in [
        ("pick_up(human, leg99)", 404),  # unknown object
        ("fly(human, leg2)", 404),  # unknown action
        ("pick_up(human)", 400),  # wrong arity
        ("grasp(left, leg2)", 409),  # a robot's action
    ]:
        with pytest.raises(PanelInputError) as err:
            coop.submit({"action": bad})
        assert err.value.status == status, bad
    for bad_take, status in [("nowhere", 404), ("connected_1", 400), ("human_4", 409)]:
        with pytest.raises(PanelInputError) as err:
            coop.submit({"take": bad_take})
        assert err.value.status == status, bad_take
    assert len(coop.events) == events
    assert coop.kb.facts == facts
    assert json.dumps(coop.snapshot(), sort_keys=True) == before


def test_take_makes_the_robot_leave_that_part() -> None:
    coop, clock = manual_table()
    advance(coop, clock, 2)  # an arm is on its way to a leg for bolt 1
    snap = coop.snapshot()
    robot_part = next(s for s in snap["suggestions"] if s["owner"] == "robot")
    busy = [a["name"] for a in snap["agents"] if a["status"] == "busy"]
    assert robot_part["element"] == "robot_1" and busy
    assert "human_1" in snap["takeable"]
    result = coop.submit({"take": "human_1"})
    assert result["actions"][0].startswith("pick_up(human, ")
    snap = coop.snapshot()
    owners = {s["element"]: s["owner"] for s in snap["suggestions"]}
    assert owners.get("human_1") == "human"
    assert owners.get("robot_1") is None  # the robot left it
    assert any(t["status"] == "stopped" for t in snap["timeline"])
    assert any(ev["type"] == "stop" for ev in coop.events)
    assert finish(coop, clock) == "solved"
    assert coop.kb.holds("filled", "bolt_1")
    assert any(t["agents"] == ["human"] and "bolt_1" in t["action"] for t in coop.timeline)


def test_stop_robot_keeps_the_arm_out_of_use_until_resumed() -> None:
    coop, clock = manual_table()
    advance(coop, clock, 1)
    busy = next(a["name"] for a in coop.snapshot()["agents"] if a["status"] == "busy")
    coop.stop_robot(busy)
    snap = coop.snapshot()
    me = next(a for a in snap["agents"] if a["name"] == busy)
    assert me["status"] == "stopped"
    assert f"stopped by the operator: {busy}" in snap["waiting"]
    with pytest.raises(PanelInputError):
        coop.stop_robot(busy)  # already stopped
    with pytest.raises(PanelInputError) as err:
        coop.stop_robot("human")
    assert err.value.status == 400
    with pytest.raises(PanelInputError) as err:
        coop.stop_robot("nobody")
    assert err.value.status == 404
    stop_at = len(coop.events)
    for _ in range(30):
        advance(coop, clock)
    # no new work for the stopped arm (only the 'rest' the manager sends it at once)
    assert not [
        ev
        for ev in coop.events[stop_at:]
        if ev["type"] == "command" and busy in ev["agents"] and ev["element"] is not None
    ]
    coop.resume_robot(busy)
    with pytest.raises(PanelInputError):
        coop.resume_robot(busy)  # not stopped any more
    # what the remaining arm could not reach was given to the operator meanwhile
    assert finish(coop, clock) == "solved"


def test_lower_graph_instances_are_listed_for_folding() -> None:
    lower = AndOrGraph("Sub", root="s_done")
    for n in ("s_a", "s_done"):
        lower.add_node(n)
    lower.add_hyperarc("s_h", ["s_a"], "s_done", 1)
    top = AndOrGraph("Top", root="done")
    for n in ("a", "done"):
        top.add_node(n)
    top.add_hyperarc("h1", ["a"], "done", 1, lower="Sub")
    top.add_hyperarc("h2", ["a"], "done", 1, lower="Sub")
    graph = OnlineGraph(HierarchicalGraph({"Top": top, "Sub": lower}, "Top"))
    graph.update(met_nodes=["a"])
    insts = graph_snapshot(graph, graph.query().feasible)
    assert [(i["path"], i["name"], i["upper"]) for i in insts] == [
        ("", "Top", None),
        ("h1", "Sub", "h1"),
        ("h2", "Sub", "h2"),
    ]
    h1 = next(h for h in insts[0]["hyperarcs"] if h["id"] == "h1")
    assert h1["lower"] == "h1"
    a = next(n for n in insts[0]["nodes"] if n["id"] == "a")
    assert a["status"] == "met"
    leaf = next(n for n in insts[1]["nodes"] if n["id"] == "h1/s_a")
    assert leaf["status"] in ("feasible", "met")


def test_the_state_says_why_it_waits_or_failed() -> None:
    # a percept that contradicts the knowledge base: the manager waits, the page says why
    coop, clock = manual_table(unreachable_bolts=(2,))
    run_robots(coop, clock)
    leg = next(o for o in coop.kb.objects.values() if o.type == "leg" and o.fixed)
    assert not coop.kb.update_object(leg.id, "leg", (0.9, 0.9, 0.0))  # a fixed leg elsewhere
    waiting = coop.snapshot()["waiting"]
    assert waiting.startswith("knowledge base inconsistent: ") and leg.id in waiting
    # nobody can reach bolt 1 and there is no operator: the cooperation fails, with the reason
    coop, clock = manual_table(unreachable_bolts=(1,), human=False)
    run_robots(coop, clock)
    snap = coop.snapshot()
    assert snap["outcome"] == "failed" and snap["reason"]
    assert snap["waiting"] is None
