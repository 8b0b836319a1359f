"""The Task Manager's percept input (sans-IO): what it makes of a moved object or a retracted
report (issue 13, items 3 and 4)."""

from __future__ import annotations

from flexhrc.scenario.builtin.table import table_assembly
from flexhrc.taskmanager import AnalyticSimulator
from flexhrc.taskmanager.manager import Command, HumanAction, Stop, TaskManager

LAYOUT = [(0.35, 0.30, 0.0), (0.50, 0.32, 0.0), (0.35, -0.30, 0.0), (0.50, -0.32, 0.0)]


def manager():
    sc = table_assembly(segments="legs", leg_positions=LAYOUT)
    kb = sc.world()
    return TaskManager(sc.online_graph(), sc.domain, kb, AnalyticSimulator()), kb


def test_a_moved_object_stops_the_robot_element_using_it_and_it_is_re_planned():
    tm, kb = manager()
    first = [d for d in tm.start(0.0) if isinstance(d, Command)]
    leg = first[0].action.args[1]
    kb.move(leg, (0.40, 0.45, 0.0))  # perception re-anchored it elsewhere
    out = tm.on_percept(1.0, moved=[leg])
    stops = [d for d in out if isinstance(d, Stop)]
    assert [s.command_id for s in stops] == [first[0].id]
    assert stops[0].reason == f"{leg} moved"
    again = [d for d in out if isinstance(d, Command) and d.action.name == "approach"]
    assert again, out  # re-planned at once (some arm goes for a leg again)


def test_an_object_nobody_uses_changes_nothing():
    tm, kb = manager()
    first = [d for d in tm.start(0.0) if isinstance(d, Command)]
    used = {first[0].action.args[1]}
    other = next(o.id for o in kb.objects_of_type("leg") if o.id not in used)
    out = tm.on_percept(1.0, moved=[other])
    assert not [d for d in out if isinstance(d, Stop)]


def test_while_the_base_is_inconsistent_the_manager_waits_and_a_percept_resumes_it():
    tm, kb = manager()
    kb.contradict("leg1", "seen where it cannot be", {"position": (9.0, 9.0, 0.0)})
    assert tm.start(0.0) == [] and tm.waiting_for_consistency
    kb.resolve("leg1", accept=False)
    out = tm.on_percept(1.0)
    assert [d for d in out if isinstance(d, Command)] and not tm.waiting_for_consistency


def test_a_retracted_report_drops_the_human_element_it_started():
    tm, kb = manager()
    tm.start(0.0)
    report = HumanAction("pick_up", ("human", "leg4"))
    tm.on_human_action(1.0, report)
    assert any(ex.owner == "human" for ex in tm.executions.values())
    before = set(kb.facts)
    kb.retract_fact("held_by_human", "leg4")  # what the repair undoes in the base
    kb.assert_fact("on_table", "leg4")
    tm.on_percept(2.0, retracted=[report])
    assert not any(ex.owner == "human" for ex in tm.executions.values())
    assert ("held_by_human", "leg4") in before
