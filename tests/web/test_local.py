"""``flexhrc panel``'s cooperation: the cell's loop in this process, simulated arms on the wall
clock, the operator only at the panel (:class:`flexhrc.web.local.LocalPanel`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from flexhrc.cell import protocol as P
from flexhrc.representation import AndOrGraph, HierarchicalGraph, OnlineGraph
from flexhrc.scenario import SHIPPED
from flexhrc.scenario.starter import STARTER, STARTER_NAME
from flexhrc.web import PanelInputError
from flexhrc.web.snapshot import graph_snapshot
from tests.web.helpers import (
    TABLE,
    TABLE_HUMAN_BOLT_2,
    finish,
    human_next,
    press_done,
    until,
    waiting_for_operator,
)


def test_snapshot_has_the_contract_keys_and_is_plain_json(local_panel: Any) -> None:
    panel = local_panel(TABLE_HUMAN_BOLT_2)
    snap = until(panel, waiting_for_operator)
    for key in ("outcome", "suggestions", "agents", "events", "graph", "timeline", "objects"):
        assert key in snap
    assert snap["outcome"] == "running"
    assert isinstance(snap["events"], int) and snap["events"] == len(panel.cell.events) > 0
    for s in snap["suggestions"]:
        assert {"element", "kind", "cost", "graph"} <= set(s)
    assert {(a["name"], a["kind"]) for a in snap["agents"]} == {
        ("human", "human"),
        ("left", "robot"),
        ("right", "robot"),
    }
    assert all({"name", "kind", "status", "alive"} <= set(a) for a in snap["agents"])
    json.dumps(snap, allow_nan=False)  # standard JSON: no NaN/inf costs


def test_operator_only_through_the_panel_completes_the_assembly(local_panel: Any) -> None:
    panel = local_panel(TABLE_HUMAN_BOLT_2)
    # the arms fix what they reach, then the robot needs the operator for bolt 2
    snap = until(panel, waiting_for_operator)
    assert snap["outcome"] == "running"
    (first,) = human_next(panel)
    assert first.startswith("pick_up(human, ")
    press_done(panel, first)
    (second,) = human_next(panel)
    assert second.startswith("screw(human, ") and second.endswith("bolt_2)")
    press_done(panel, second)
    assert panel.wait(30)
    snap = until(panel, lambda s: s["outcome"] != "running")
    assert snap["outcome"] == "solved", snap["reason"]
    assert panel.cell.kb.holds("filled", "bolt_2")
    done_by_human = [t for t in snap["timeline"] if t["agents"] == ["human"]]
    assert [t["action"] for t in done_by_human] == [first, second]
    assert panel.report().summary["human_actions"] == 2


def test_an_action_that_advances_nothing_is_refused_and_changes_nothing(local_panel: Any) -> None:
    panel = local_panel(TABLE_HUMAN_BOLT_2)
    until(panel, waiting_for_operator)
    before = json.dumps(panel.snapshot(), sort_keys=True)
    events = len(panel.cell.events)
    facts = panel.cell.kb.facts
    # screwing before picking up advances no feasible hyper-arc
    with pytest.raises(PanelInputError) as err:
        panel.submit({"action": "screw(human, leg3, bolt_4)"})
    assert err.value.status == 409
    for bad, status in [
        ("pick_up(human, leg99)", 404),  # unknown object
        ("fly(human, leg2)", 404),  # unknown action
        ("pick_up(human)", 400),  # wrong arity
        ("grasp(left, leg2)", 409),  # a robot's action
    ]:
        with pytest.raises(PanelInputError) as err:
            panel.submit({"action": bad})
        assert err.value.status == status, bad
    for bad_take, status in [("nowhere", 404), ("connected_1", 400), ("human_4", 409)]:
        with pytest.raises(PanelInputError) as err:
            panel.submit({"take": bad_take})
        assert err.value.status == status, bad_take
    assert len(panel.cell.events) == events
    assert panel.cell.kb.facts == facts
    assert json.dumps(panel.snapshot(), sort_keys=True) == before


def test_take_makes_the_robot_leave_that_part(local_panel: Any) -> None:
    panel = local_panel(TABLE, speed=2.0)  # slow arms: the take lands mid-action
    snap = until(
        panel,
        lambda s: (
            any(x["element"] == "robot_1" and x["owner"] == "robot" for x in s["suggestions"])
            and any(a["status"] == "busy" for a in s["agents"])
        ),
    )
    assert "human_1" in snap["takeable"]
    result = panel.submit({"take": "human_1"})
    assert result["actions"][0].startswith("pick_up(human, ")
    snap = until(panel, lambda s: any(t["status"] == "stopped" for t in s["timeline"]))
    owners = {s["element"]: s["owner"] for s in snap["suggestions"]}
    assert owners.get("human_1") == "human"
    assert owners.get("robot_1") is None  # the robot left it
    kinds = [ev.kind for ev in panel.cell.events]
    assert "human_take" in kinds and "stop" in kinds
    taken_at = kinds.index("human_take")
    assert (
        not [  # the arms got no more work on that part
            ev
            for ev in panel.cell.events[taken_at:]
            if ev.kind == "command" and ev.body["element"] == "robot_1"
        ]
    )
    panel.set_speed(1000)
    assert finish(panel) == "solved"
    assert panel.cell.kb.holds("filled", "bolt_1")
    timeline = panel.snapshot()["timeline"]
    assert any(t["agents"] == ["human"] and "bolt_1" in t["action"] for t in timeline)


def test_stop_robot_keeps_the_arm_out_of_use_until_resumed(local_panel: Any) -> None:
    panel = local_panel(TABLE, speed=5.0)
    snap = until(panel, lambda s: any(a["status"] == "busy" for a in s["agents"]))
    busy = next(a["name"] for a in snap["agents"] if a["status"] == "busy")
    stop_at = len(panel.cell.events)
    panel.stop_robot(busy)
    snap = panel.snapshot()
    me = next(a for a in snap["agents"] if a["name"] == busy)
    assert me["status"] == "stopped"
    assert f"stopped by the operator: {busy}" in snap["waiting"]
    with pytest.raises(PanelInputError) as err:
        panel.stop_robot(busy)  # already stopped
    assert err.value.status == 409
    with pytest.raises(PanelInputError) as err:
        panel.stop_robot("human")
    assert err.value.status == 400
    with pytest.raises(PanelInputError) as err:
        panel.stop_robot("nobody")
    assert err.value.status == 404
    # the other arm works on (three more actions done), the stopped one gets nothing
    other = next(a["name"] for a in snap["agents"] if a["kind"] == "robot" and a["name"] != busy)

    def done_by_other(s: dict[str, Any]) -> int:
        return sum(1 for t in s["timeline"] if t["agents"] == [other] and t["status"] == "done")

    so_far = done_by_other(snap)
    until(panel, lambda s: done_by_other(s) >= so_far + 3)
    assert not [
        ev
        for ev in panel.cell.events[stop_at:]
        if ev.kind == "command" and busy in ev.body["agents"] and ev.body["element"] is not None
    ]
    downs = [ev for ev in panel.cell.events if ev.kind == "agent_down"]
    assert downs and downs[-1].body == {**downs[-1].body, "agent": busy, "by": "operator"}
    panel.resume_robot(busy)
    with pytest.raises(PanelInputError):
        panel.resume_robot(busy)  # not stopped any more
    panel.set_speed(1000)
    assert finish(panel) == "solved"


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


def test_the_state_says_why_it_waits_or_failed(local_panel: Any) -> None:
    # a percept that contradicts the knowledge base: the manager waits, the page says why
    panel = local_panel(TABLE_HUMAN_BOLT_2)
    until(panel, waiting_for_operator)
    leg = next(o for o in panel.cell.kb.objects.values() if o.type == "leg" and o.fixed)
    percept = P.message(
        "percept", id="p1", object=leg.id, object_type="leg", pose=[0.9, 0.9, 0.0]
    )  # a fixed leg elsewhere
    panel.call(lambda: panel.bus.publish(P.PERCEPT_TOPIC, percept))
    snap = until(panel, lambda s: (s["waiting"] or "").startswith("knowledge base inconsistent"))
    assert leg.id in snap["waiting"]
    # nobody can reach bolt 1 and there is no operator: the cooperation fails, with the reason
    panel = local_panel("scenario: table_assembly\nunreachable_bolts: [1]\nhuman: false\n")
    assert panel.wait(30)
    snap = until(panel, lambda s: s["outcome"] != "running")
    assert snap["outcome"] == "failed" and snap["reason"]
    assert snap["waiting"] is None


def test_the_panel_runs_the_task_the_name_means_everywhere(local_panel: Any) -> None:
    from flexhrc.scenario import load_scenario

    panel = local_panel("table_assembly", start=False)
    shipped = load_scenario("table_assembly")  # what `flexhrc run` and `flexhrc cell` run
    graph = shipped.online_graph()
    mine = [h["id"] for inst in panel.snapshot()["graph"] for h in inst["hyperarcs"]]
    theirs = [h["id"] for inst in graph_snapshot(graph, {}) for h in inst["hyperarcs"]]
    assert mine == theirs and len(theirs) > 8  # the three segments, not the legs fix alone
    assert panel.snapshot()["scenario"] == "table_assembly"


@pytest.mark.parametrize("name", [*SHIPPED, "starter"])
def test_every_shipped_scenario_and_the_starter_is_solved_at_the_panel(
    name: str, local_panel: Any, tmp_path: Path
) -> None:
    """`flexhrc panel NAME` for each shipped scenario and the file `flexhrc scenario new`
    writes: the arms work, the person presses 'done' on what they are asked, to the end."""
    if name == "starter":
        path = tmp_path / STARTER_NAME
        path.write_text(STARTER)
        name = str(path)
    panel = local_panel(name, speed=1000)
    assert finish(panel) == "solved", panel.snapshot()["reason"]
    assert panel.wait(30)  # the loop has returned its summary
    summary = panel.report().summary
    assert summary["robot_actions"] > 0
    assert summary["human_actions"] == sum(
        1 for ev in panel.cell.events if ev.kind == "human_action"
    )
