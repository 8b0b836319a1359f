"""The Task Manager with the kinematic simulator (issue 5): reachability decides the allocation."""

from __future__ import annotations

import pytest

pytest.importorskip("pinocchio")

from flexhrc.action import KinematicTaskSimulator
from flexhrc.cell.local import LocalCell
from flexhrc.scenario import Scenario
from flexhrc.scenario.builtin.table import table_assembly

from ..taskmanager.helpers import LAYOUT, check_invariants, first, solved


def run(scenario: Scenario, kin: KinematicTaskSimulator | None = None, **kw):
    kin = kin or KinematicTaskSimulator()
    r = LocalCell(scenario, simulator=kin, execution=kin, **kw)
    return r.run()


def test_a_leg_reachable_by_one_arm_only_goes_to_that_arm():
    # (0.45, 0.55): far on the robot's left; the right arm cannot get there
    result = run(table_assembly(segments="legs", legs=1, leg_positions=[(0.45, 0.55, 0.0)]))
    decision = first(result.events, "decision")
    by_arm = {b["grounding"]["?arm"]: b for b in decision["branches"]}
    assert by_arm["left"]["success"] and by_arm["left"]["utility"] > 0
    assert not by_arm["right"]["success"] and by_arm["right"]["utility"] == 0
    assert "approach(right, leg1)" in by_arm["right"]["reason"]
    assert solved(result) == [("robot_1", ("left",))]


def test_a_leg_neither_arm_can_connect_is_asked_of_the_human_via_the_middle_pose():
    # a fixture over bolt 1: no arm reaches it; the robot brings the leg to the middle pose
    result = run(
        table_assembly(
            segments="legs", legs=1, leg_positions=[(0.40, 0.30, 0.0)], unreachable_bolts=(1,)
        )
    )
    assert result.outcome == "solved"
    seq = solved(result)
    assert [e for e, _ in seq] == ["to_middle_1", "human_from_middle_1"]
    assert seq[0][1][0] in ("left", "right") and seq[1][1] == ("human",)
    infeasible = [e["element"] for e in result.events if e["type"] == "infeasible"]
    assert infeasible == ["robot_1", "robot_from_middle_1"]
    first_tree = first(result.events, "decision")
    assert all(
        "path blocked" in b["reason"] or "reach" in b["reason"] for b in first_tree["branches"]
    )
    assert first(result.events, "suggestion")["element"] == "human_from_middle_1"


def test_branch_utilities_come_from_simulated_durations():
    result = run(table_assembly(segments="legs", legs=4, leg_positions=LAYOUT))
    decision = first(result.events, "decision")
    assert len(decision["branches"]) == 8
    for b in decision["branches"]:
        assert b["success"]
        assert b["utility"] == pytest.approx(1.0 / sum(b["durations"]), rel=1e-5)
    # the controller's timings, not the analytic constants (grasp 1.0 s, screw 4.0 s)
    grasp_times = {b["durations"][1] for b in decision["branches"]}
    assert grasp_times != {1.0}
    best = max(decision["branches"], key=lambda b: b["utility"])
    assert decision["branches"][decision["chosen"]] == best
    assert result.outcome == "solved"
    check_invariants(result, 4)


def test_a_disturbance_during_execution_fails_the_action_and_the_manager_replans():
    kin = KinematicTaskSimulator()
    kin.schedule("transport", 1, kind="blocked_path", at_s=0.3, once=True)
    result = run(table_assembly(segments="legs", legs=4, leg_positions=LAYOUT), kin)
    failed = first(result.events, "action_failed")
    assert failed["element"] == "robot_1" and "blocked" in failed["reason"]
    later = [e for e in result.events if e["type"] == "decision" and e["t"] >= failed["t"]]
    assert later[0]["element"] == "robot_1"
    assert all(b["grounding"] != failed["grounding"] for b in later[0]["branches"])
    assert result.outcome == "solved"
    assert [e for e, _ in solved(result)] == ["robot_1", "robot_2", "robot_3", "robot_4"]
    check_invariants(result, 4)


def test_a_slow_arm_times_out_and_the_manager_replans():
    kin = KinematicTaskSimulator()
    kin.schedule("approach", 1, kind="slow_arm", factor=0.2, once=True)
    result = run(table_assembly(segments="legs", legs=2, leg_positions=LAYOUT[:2]), kin)
    failed = first(result.events, "action_failed")
    assert failed["status"] == "timed_out"
    assert result.outcome == "solved"


def test_the_kinematic_simulator_is_the_default_when_installed():
    from flexhrc.app import RunConfig, TableDemo, run_scenario

    report = run_scenario(RunConfig(TableDemo(legs=1), segments="legs", quiet=True))
    assert report.json["simulator"] == "kinematic"


def test_auto_picks_the_kinematic_simulator_at_the_edge():
    # the choice is made above the Task Manager (scenarios.simulators), which stays unaware of
    # the action level: given no simulator it uses the analytic one (STYLE.md: no import circle)
    from flexhrc.scenario.simulators import choose_simulator
    from flexhrc.taskmanager import AnalyticSimulator, TaskManager

    name, kin = choose_simulator("auto")
    assert name == "kinematic" and isinstance(kin, KinematicTaskSimulator)
    sc = table_assembly(segments="legs", legs=1, leg_positions=LAYOUT[:1])
    tm = TaskManager(sc.online_graph(), sc.domain, sc.world(), kin)
    directives = tm.start(0.0)
    assert directives[0].action.name == "approach"
    assert tm.branches_simulated == 2
    bare = TaskManager(sc.online_graph(), sc.domain, sc.world())
    assert isinstance(bare.simulator, AnalyticSimulator)


def test_the_taskmanager_package_does_not_import_the_action_level():
    import subprocess
    import sys

    from ..conftest import subprocess_env

    code = (
        "import sys, flexhrc.taskmanager as t; from flexhrc.scenario.builtin import table; "
        "t.default_simulator(); "
        "print(sorted(m for m in sys.modules if m.startswith('flexhrc.action')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=subprocess_env()
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_cli_disturbance_and_simulator_errors(capsys):
    import json

    from flexhrc.cli import main

    code = main(["demo", "table", "--legs", "2", "--simulator", "kinematic", "--disturb",
                 "blocked_path:transport:1", "--json", "--quiet"])  # fmt: skip
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["outcome"] == "solved"
    assert main(["demo", "table", "--disturb", "earthquake"]) == 2
    assert "KIND is blocked_path, slow_arm or push" in capsys.readouterr().err
    assert main(["demo", "table", "--simulator", "analytic", "--disturb", "slow_arm"]) == 2
    assert "--disturb needs --simulator kinematic" in capsys.readouterr().err
