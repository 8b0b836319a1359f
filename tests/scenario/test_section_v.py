"""Paper 000 section V in full: preconditions, carried groundings, processes P(n), joint actions,
matching an unsuggested action against the whole action list, the two reactions."""

from __future__ import annotations

import importlib.util

import pytest

from flexhrc import scenario
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager import AnalyticSimulator, Command, HumanAction, Stop, TaskManager
from flexhrc.taskmanager.manager import Ack

from .helpers import base, write
from .invariants import check_invariants


def manager(sc, events):
    kb = sc.world()
    tm = TaskManager(sc.online_graph(), sc.domain, kb, AnalyticSimulator(), log=events.append)
    return tm, kb


def robot_only(doc):
    doc["humans"] = []
    del doc["domain"]["agents"]["human"]
    doc["world"]["facts"] = [f for f in doc["world"]["facts"] if f != "free(human)"]
    return doc


def test_a_branch_failing_a_precondition_is_pruned_with_its_reason(tmp_path):
    doc = robot_only(base())
    doc["domain"]["actions"]["pick"]["pre"] = ["on_table(?p)", "free(?who)", "clean(?p)"]
    doc["world"]["facts"] += ["clean(b)"]
    sc = scenario.load(write(tmp_path, doc))
    events: list = []
    tm, _ = manager(sc, events)
    out = tm.start(0.0)
    decision = next(e for e in events if e["type"] == "decision")
    assert [b["grounding"]["?p"] for b in decision["branches"]] == ["b"]
    assert decision["pruned"] == [
        {
            "grounding": {"?p": "a", "?who": "arm"},
            "agents": ["arm"],
            "success": False,
            "durations": [],
            "utility": 0.0,
            "reason": "pre(pick(arm, a)) does not hold: clean(a)",
        }
    ]
    assert isinstance(out[0], Command) and str(out[0].action) == "pick(arm, b)"


def test_preconditions_are_checked_again_at_dispatch(tmp_path):
    doc = robot_only(base())
    doc["domain"]["actions"]["put"]["pre"] = ["holding(?who, ?p)", "open(?to)"]
    doc["world"]["facts"] += ["open(tray)"]
    sc = scenario.load(write(tmp_path, doc))
    events: list = []
    tm, kb = manager(sc, events)
    (pick,) = tm.start(0.0)
    kb.retract_fact("open", "tray")  # meanwhile someone closed the tray (a percept)
    out = tm.on_ack(2.0, Ack(pick.id, "done"))
    failed = next(e for e in events if e["type"] == "precondition_failed")
    assert failed["element"] == "put_first"
    assert failed["reason"] == "pre(put(arm, a, tray)) does not hold: open(tray)"
    assert not any(isinstance(d, Command) and d.action.name == "put" for d in out)
    assert {"?p": "a", "?who": "arm"} in tm.failed["put_first"]


def test_the_grounding_of_a_hyper_arc_carries_to_its_parent_and_beyond(tmp_path):
    doc = robot_only(base())
    g = doc["graphs"]["two_parts"]
    g["nodes"][2] = {"name": "done", "state": "inspected(?p)"}
    g["hyperarcs"][1] = {
        "name": "inspect",
        "children": ["first_in"],
        "parent": "done",
        "weight": 1,
        "actions": ["look(?who, ?p)"],
    }
    doc["domain"]["actions"]["look"] = {
        "parameters": {"?who": "agent", "?p": "part"},
        "agents": {"choice": "?who"},
        "add": ["inspected(?p)"],
        "duration": 1.0,
    }
    # c lies in the tray from the start: first_in's formula holds for it, but first_in is
    # reached by put_first, so only the part put_first moved counts
    doc["world"]["objects"]["c"] = {"type": "part", "position": [0.55, 0.0, 0.0]}
    doc["world"]["facts"] += ["in(c, tray)"]
    doc["world"]["facts"].remove("on_table(b)")
    sc = scenario.load(write(tmp_path, doc))
    result = scenario.run(sc)
    assert result.outcome == "solved"
    solved = {e["element"]: e["grounding"] for e in result.events if e["type"] == "solved"}
    assert solved["put_first"]["?p"] == "a"
    assert solved["inspect"]["?p"] == "a"  # not c, although in(c, tray) holds too
    check_invariants(sc, result.events)


def test_node_processes_keep_both_arms_busy_until_their_end_condition():
    sc = scenario.load("table_assembly")
    result = scenario.run(sc, seed=0)
    ev = result.events
    activated = next(e for e in ev if e["type"] == "process_activated")
    assert activated["node"] == "tabletop_placed" and activated["processes"] == ["hold(?top)"]
    hold = next(e for e in ev if e["type"] == "command" and e.get("process"))
    assert hold["action"] == "hold(tabletop)" and hold["agents"] == ["left", "right"]
    ended = next(e for e in ev if e["type"] == "process_ended")
    assert ended["reason"] == "its end condition holds" and ended["t"] > hold["t"]
    met = next(
        e
        for e in ev
        if e["type"] == "query" and "tabletop_placed" in e["report"].get("met_nodes", [])
    )
    assert met["t"] == ended["t"]  # n is met when its processes have ended (eq. 5)
    # the arms go to rest only then (Fig. 8 (f)), and the legs come after
    rest = next(e for e in ev if e["type"] == "command" and e["element"] == "arms_to_rest")
    assert rest["t"] >= ended["t"]
    first_leg = next(e for e in ev if e["type"] == "command" and e["element"] == "robot_1")
    assert first_leg["t"] >= ended["t"]


FIG_8 = [
    ("place_tabletop", "pick_tabletop(tabletop)"),  # (a-c) approach and grasp on its stand
    ("place_tabletop", "reorient_tabletop(tabletop)"),  # (d) turned flat
    ("place_tabletop", "place_tabletop(tabletop, assembly_pose)"),  # (e) placed ...
    ("tabletop_placed", "hold(tabletop)"),  # ... and held still by the process of the node
    ("arms_to_rest", "return_to_rest()"),  # (f) both arms back to rest
]


def test_the_tabletop_placement_is_fig_8_in_joint_commands_of_both_arms():
    # issue 21 item 5: picked from its stand, turned flat, placed, held, arms back to rest
    sc = scenario.load("table_assembly")
    result = scenario.run(sc, seed=0)
    cmds = [e for e in result.events if e["type"] == "command"]
    assert [(c.get("element"), c["action"]) for c in cmds[: len(FIG_8)]] == FIG_8
    assert all(c["agents"] == ["left", "right"] for c in cmds[: len(FIG_8)])
    # in the paper's task only the robot places the tabletop: no operator alternative
    assert "human_places_tabletop" not in sc.graph.top_graph.hyperarcs
    assert not any(e["type"] == "suggestion" and "tabletop" in e["element"] for e in result.events)
    # the arms were at rest when the legs fix began
    first_leg = next(c for c in cmds if c.get("element") == "robot_1")
    assert first_leg["t"] >= next(e for e in result.events if e["type"] == "action_end"
                                  and e["action"] == "return_to_rest()")["t"]  # fmt: skip


def test_the_operator_places_the_tabletop_only_when_the_scenario_asks_for_it():
    # the robot cannot grasp the tabletop (its pick fails): without the alternative the task
    # fails; with operator_places_tabletop the operator places it and the task goes on
    from flexhrc.cell.local import InjectedFailure
    from flexhrc.scenario.builtin.table import table_assembly

    fail = [InjectedFailure("pick_tabletop", 1)]
    paper = scenario.run(table_assembly(), simulator="analytic", failures=fail)
    assert paper.outcome == "failed"
    asked = table_assembly(operator_places_tabletop=True)
    assert asked.graph.top_graph.hyperarcs["human_places_tabletop"].weight == 3
    result = scenario.run(asked, simulator="analytic", failures=fail)
    assert result.outcome == "solved"
    solved = [(e["element"], e["agents"]) for e in result.events if e["type"] == "solved"]
    assert solved[0] == ("human_places_tabletop", ["human"])
    # and with nothing failing the robot's cheaper way is taken
    plain = scenario.run(asked, simulator="analytic")
    assert [e["element"] for e in plain.events if e["type"] == "solved"][:2] == [
        "place_tabletop",
        "arms_to_rest",
    ]
    with pytest.raises(FlexhrcError, match="operator_places_tabletop needs an operator"):
        table_assembly(human=False, operator_places_tabletop=True)


@pytest.mark.skipif(importlib.util.find_spec("pinocchio") is None, reason="sim extra")
def test_the_joint_placement_runs_on_both_arms_with_the_relative_pose_objective():
    from flexhrc.action import control
    from flexhrc.action.bridge import KinematicTaskSimulator

    sc = scenario.load("table_assembly")
    kin = KinematicTaskSimulator()
    kb = sc.world()
    from flexhrc.taskmanager.domain import GroundAction

    both = ("left", "right")
    steps = [
        GroundAction(sc.domain.actions["pick_tabletop"], ("tabletop",), both),
        GroundAction(sc.domain.actions["reorient_tabletop"], ("tabletop",), both),
        GroundAction(sc.domain.actions["place_tabletop"], ("tabletop", "assembly_pose"), both),
        GroundAction(sc.domain.actions["return_to_rest"], (), both),
    ]
    seen: list[str] = []
    original = control.RelativePose.evaluate

    def spy(self, ctx):
        seen.append("relative_pose")
        return original(self, ctx)

    control.RelativePose.evaluate = spy  # type: ignore[method-assign]
    try:
        sim = kin.simulate(steps, kb, sc.domain)
        positions: dict = {}
        reports = [kin.execute(step, positions, kb, sc.domain) for step in steps]
    finally:
        control.RelativePose.evaluate = original  # type: ignore[method-assign]
    assert sim.success, sim.reason
    assert all(r.status == "done" for r in reports), [r.reason for r in reports]
    assert seen  # the turn and the carry kept the two hands' relative pose
    assert set(kin.simulated.values()) == {"kinematic"}
    arms = [r.command.arm for r in kin.execution.log]
    actions = [r.command.action for r in kin.execution.log]
    assert arms == ["both"] * 6
    assert actions == ["approach", "grasp", "reorient", "transport", "ungrasp", "rest"]


def test_an_unsuggested_action_matches_anywhere_in_the_action_list(tmp_path):
    doc = base()
    # the operator already holds b: its put is the second action of put_first
    doc["world"]["facts"] = ["on_table(a)", "holding(human, b)", "free(arm)"]
    sc = scenario.load(write(tmp_path, doc))
    events: list = []
    tm, _ = manager(sc, events)
    tm.start(0.0)
    tm.on_human_action(1.0, HumanAction("put", ("human", "b", "tray")))
    rec = next(e for e in events if e["type"] == "recognised")
    assert rec["element"] == "put_first" and rec["index"] == 1
    solved = next(e for e in events if e["type"] == "solved")
    assert solved["element"] == "put_first" and solved["grounding"]["?p"] == "b"
    assert solved["agents"] == ["human"]


def _independent(tmp_path, reaction):
    """The arm works on put_a, the operator was asked put_b; it does pick(human, c) instead."""
    doc = base()
    nodes, arcs = [], []
    for p, w in (("a", 1), ("b", 2), ("c", 3)):
        nodes += [
            {"name": f"{p}_ready", "state": f"on_table({p})"},
            {"name": f"{p}_in", "state": f"in({p}, tray)"},
        ]
        arcs.append(
            {"name": f"put_{p}", "children": [f"{p}_ready"], "parent": f"{p}_in", "weight": w,
             "actions": [f"pick(?who, {p})", f"put(?who, {p}, tray)"]}
        )  # fmt: skip
    nodes.append({"name": "done", "state": "in(a, tray) & in(b, tray) & in(c, tray)"})
    arcs.append({"name": "finish", "children": ["a_in", "b_in", "c_in"], "parent": "done"})
    doc["graphs"]["two_parts"] = {"root": "done", "nodes": nodes, "hyperarcs": arcs}
    doc["world"]["objects"]["c"] = {"type": "part", "position": [0.4, 0.0, 0.0]}
    doc["world"]["facts"] += ["on_table(c)"]
    doc["domain"]["agents"]["human"]["hand"] = [3.0, 0.0, 0.1]  # far away: the robot is asked
    # ... except for b, which the arm cannot reach: the operator is needed for it (a person is
    # not asked for what the busy arm does better)
    doc["world"]["objects"]["b"]["reachable_by"] = []
    doc["domain"]["actions"]["rest"] = {"parameters": {"?r": "robot"}, "agents": {"choice": "?r"}}
    sc = scenario.load(write(tmp_path, doc))
    kb = sc.world()
    tm = TaskManager(sc.online_graph(), sc.domain, kb, AnalyticSimulator(), reaction=reaction)
    first = tm.start(0.0)
    assert [type(d).__name__ for d in first] == ["Command", "Suggest"]
    assert first[0].element == "put_a" and first[1].element == "put_b"
    return tm, tm.on_human_action(1.0, HumanAction("pick", ("human", "c")))


def test_reaction_conflicts_keeps_robot_actions_that_do_not_conflict(tmp_path):
    tm, out = _independent(tmp_path, "conflicts")
    assert not any(isinstance(d, Stop) for d in out)
    assert tm.executions["put_a"].owner == "robot" and tm.executions["put_a"].command.id == 1
    assert tm.executions["put_c"].owner == "human"


def test_reaction_paper_stops_every_robot_action_and_rests(tmp_path):
    tm, out = _independent(tmp_path, "paper")
    stops = [d for d in out if isinstance(d, Stop)]
    assert [s.agent for s in stops] == ["arm"]
    rests = [d for d in out if isinstance(d, Command) and d.action.name == "rest"]
    assert [str(r.action) for r in rests] == ["rest(arm)"]
    assert "put_c" in tm.executions and tm.executions["put_c"].owner == "human"
    assert "put_a" not in tm.executions or tm.executions["put_a"].command.id != 1


def test_two_named_operators_share_the_work_never_one_object(tmp_path):
    doc = base()
    doc["domain"]["agents"]["bob"] = {"kind": "human", "types": ["human"], "hand": [1.0, -0.3, 0.1]}
    doc["world"]["facts"] += ["free(bob)"]
    doc["humans"] = [
        {"name": "human", "profile": "takeover", "speed": 1.0},
        {"name": "bob", "profile": "takeover", "speed": 1.2},
    ]
    sc = scenario.load(write(tmp_path, doc))
    for seed in range(10):
        result = scenario.run(sc, seed=seed)
        assert result.outcome == "solved", result.reason
        check_invariants(sc, result.events)


@pytest.mark.parametrize("profile", ["passive", "takeover", "cooperative", "random"])
def test_the_check_segment_is_done_by_the_operator(profile):
    sc = scenario.load("table_assembly")
    result = scenario.run(sc, profile=profile, seed=4)
    last = result.summary["solved_hyperarcs"][-1]
    assert last["hyperarc"] == "check_connections" and last["agent"] == "human"
    checks = [
        e["action"]
        for e in result.events
        if e["type"] == "action_end" and e["action"].startswith("check(")
    ]
    assert checks == [f"check(human, bolt_{k})" for k in range(1, 5)]


@pytest.mark.parametrize("profile", ["passive", "takeover", "cooperative", "random"])
def test_whoever_picked_the_ball_drops_it_the_agent_carries_too(profile):
    from ..conftest import REPO

    sc = scenario.load(REPO / "examples" / "scenarios" / "ball_in_box.yaml")
    for seed in range(5):
        result = scenario.run(sc, profile=profile, seed=seed)
        assert result.outcome == "solved", result.reason
        (pick, drop) = result.summary["solved_hyperarcs"]
        assert drop["hyperarc"] == "drop_in" and drop["agent"] == pick["agent"]
        check_invariants(sc, result.events)


# -- who is asked: a person only for what they are needed for or best at (eq. 21) ----------------
def _three_parts(tmp_path, hand):
    """put_a, put_b, put_c: three independent steps anyone may do; one arm, one operator."""
    doc = base()
    nodes, arcs = [], []
    for p, w in (("a", 1), ("b", 2), ("c", 3)):
        nodes += [
            {"name": f"{p}_ready", "state": f"on_table({p})"},
            {"name": f"{p}_in", "state": f"in({p}, tray)"},
        ]
        arcs.append(
            {"name": f"put_{p}", "children": [f"{p}_ready"], "parent": f"{p}_in", "weight": w,
             "actions": [f"pick(?who, {p})", f"put(?who, {p}, tray)"]}
        )  # fmt: skip
    nodes.append({"name": "done", "state": "in(a, tray) & in(b, tray) & in(c, tray)"})
    arcs.append({"name": "finish", "children": ["a_in", "b_in", "c_in"], "parent": "done"})
    doc["graphs"]["two_parts"] = {"root": "done", "nodes": nodes, "hyperarcs": arcs}
    doc["world"]["objects"]["c"] = {"type": "part", "position": [0.4, 0.0, 0.0]}
    doc["world"]["facts"] += ["on_table(c)"]
    doc["domain"]["agents"]["human"]["hand"] = hand
    return scenario.load(write(tmp_path, doc))


def test_a_step_a_busy_arm_does_better_waits_for_it_and_is_free_for_the_operator(tmp_path):
    sc = _three_parts(tmp_path, [3.0, 0.0, 0.1])  # the operator stands far away: slower
    events: list = []
    tm, _ = manager(sc, events)
    first = tm.start(0.0)
    # the arm takes put_a; put_b and put_c wait for it instead of going to the free operator
    assert [type(d).__name__ for d in first] == ["Command"]
    assert first[0].element == "put_a"
    assert not any(e["type"] == "suggestion" for e in events)
    # ... so an operator who acts on their own may take one meanwhile, without a race
    from flexhrc.taskmanager.operator import SimulatedOperator

    op = SimulatedOperator("human", "takeover")
    assert set(op.options(tm)) == {"b_in", "c_in", "a_in"}
    assert op.candidate_branches(tm, tm.kb, "put_b")  # nobody is on b
    assert not op.candidate_branches(tm, tm.kb, "put_a")  # the arm is picking a
    # a passive operator is never asked: the arm does all three in turn
    result = scenario.run(sc, profile="passive", seed=0)
    assert result.outcome == "solved"
    assert result.summary["by_agent"] == {"human": 0, "arm": 3}
    taken = scenario.run(sc, profile="takeover", seed=0)
    assert taken.outcome == "solved" and taken.summary["by_agent"]["human"] >= 1


class _EvenSimulator:
    """Every action takes 1 s, whoever does it: every branch ties."""

    def simulate(self, steps, kb, domain):
        from flexhrc.taskmanager.simulator import SimulationResult

        return SimulationResult(True, [1.0] * len(steps))


def test_a_tie_goes_to_the_arm(tmp_path):
    sc = _three_parts(tmp_path, [0.5, 0.0, 0.1])
    events: list = []
    tm = TaskManager(sc.online_graph(), sc.domain, sc.world(), _EvenSimulator(), log=events.append)
    first = tm.start(0.0)
    decision = next(e for e in events if e["type"] == "decision")
    utilities = {b["agents"][0]: b["utility"] for b in decision["branches"]}
    assert utilities["human"] == utilities["arm"]
    assert decision["branches"][decision["chosen"]]["agents"] == ["arm"]
    assert isinstance(first[0], Command) and first[0].agents == ("arm",)
