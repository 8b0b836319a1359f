"""``flexhrc plan`` and :func:`flexhrc.planning.solve`: optimal on every shipped scenario, the
schedule checked by an independent validator, an optimum known by hand, the CLI contract."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.planning import hindsight, solve
from flexhrc.scenario import load_scenario

from .validator import validate

pytest.importorskip("ortools")

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(str(p) for p in (ROOT / "examples" / "scenarios").glob("*.yaml"))
TWO_JOBS = ROOT / "tests" / "data" / "planning" / "two_jobs.yaml"
KEYS = ["status", "objective", "bound", "makespan_s", "solve_s", "schedule", "by_agent"]


#: `flexhrc scenario list`'s tasks besides (kitchen_drawer: a hierarchy of three graph layers)
LISTED = ["ball_in_box", "table_two_arms", "kitchen_drawer"]


@pytest.mark.parametrize("name", [*SHIPPED, "table_assembly", "parallel_assembly", *LISTED])
def test_every_shipped_scenario_is_solved_to_optimality_and_the_schedule_is_valid(name):
    sc = load_scenario(name)
    plan = solve(sc, time_limit_s=20)
    assert plan.status == "optimal", (name, plan.status)
    assert plan.bound == pytest.approx(plan.objective)
    assert validate(sc, plan.to_json()) == []


@pytest.mark.parametrize(
    "name", [*SHIPPED, "table_assembly", "parallel_assembly", "kitchen_drawer"]
)
def test_with_the_hands_travel_every_shipped_scenario_is_optimal_and_valid(name):
    sc = load_scenario(name)
    plan = solve(sc, time_limit_s=20, travel=True)
    assert plan.status == "optimal", (name, plan.status)
    assert validate(sc, plan.to_json()) == []
    # travel from where the last hyper-arc left a hand is never longer than from the start
    assert plan.makespan_s <= solve(sc, time_limit_s=20).makespan_s + 1e-6


def test_with_the_hands_travel_the_plan_times_steps_as_a_run_does():
    # the operator picks the ball up, then drops it from where their hand is: the lookahead run
    # of examples/scenarios/ball_in_box.yaml takes 3.663 s, as the plan with --travel says
    sc = load_scenario("examples/scenarios/ball_in_box.yaml")
    assert solve(sc, travel=True).makespan_s == pytest.approx(3.663, abs=1e-3)
    assert solve(sc).makespan_s == pytest.approx(4.131, abs=1e-3)  # from the hand's start


def test_the_optimum_solved_by_hand():
    # tests/data/planning/two_jobs.yaml: the operator does job a (2 s) while the arm does job b
    # (4 s), then the arm checks (1 s): 5 s; every other allocation takes 6 or 8 s.
    sc = load_scenario(TWO_JOBS)
    plan = solve(sc, time_limit_s=5)
    assert plan.status == "optimal" and plan.makespan_s == pytest.approx(5.0)
    assert {h: agents for h, (agents, _) in plan.chosen.items()} == {
        "human_a": ("human",),
        "arm_b": ("arm",),
        "finish": ("arm",),
    }
    rows = [(e.action, e.start_s, e.end_s) for e in plan.schedule]
    assert rows == [
        ("work_arm_long(b)", 0.0, 4.0),
        ("work_human(a)", 0.0, 2.0),
        ("check(a, b)", 4.0, 5.0),
    ]
    assert validate(sc, plan.to_json()) == []


@pytest.mark.parametrize("objective", ["idle", "workload"])
def test_the_other_objectives_give_valid_schedules(objective):
    sc = load_scenario(TWO_JOBS)
    plan = solve(sc, objective=objective, time_limit_s=5)
    assert plan.status == "optimal" and validate(sc, plan.to_json()) == []
    if objective == "workload":  # the arm does everything: the operator idles
        assert plan.objective == 0 and plan.by_agent["human"] == 0
    else:  # idle: 2 agents x makespan - busy time; the 5 s plan leaves 10 - 7 = 3 s idle
        assert plan.objective == pytest.approx(3.0)


def test_the_validator_catches_broken_schedules():
    sc = load_scenario(TWO_JOBS)
    good = solve(sc, time_limit_s=5).to_json()
    overlap = json.loads(json.dumps(good))
    overlap["schedule"][2]["start_s"] = 3.0  # the check before job b is done, on a busy arm
    assert any("before its child" in p for p in validate(sc, overlap))
    assert any("overlaps" in p for p in validate(sc, overlap))
    both = json.loads(json.dumps(good))
    both["schedule"].append(
        {"action": "work_arm(a)", "agents": ["arm"], "hyperarc": "arm_a", "start_s": 5, "end_s": 8}
    )
    assert any("reached by 2" in p for p in validate(sc, both))
    wrong = json.loads(json.dumps(good))
    wrong["schedule"][1]["agents"] = ["arm"]
    assert any("the action names" in p for p in validate(sc, wrong))


def test_hindsight_keeps_the_run_path_and_the_persons_steps():
    sc = load_scenario(TWO_JOBS)
    solved = [
        {"hyperarc": "human_b", "agent": "human"},  # what a deviating operator did
        {"hyperarc": "arm_a", "agent": "arm"},
        {"hyperarc": "finish", "agent": "arm"},
    ]
    plan = hindsight(sc, solved, time_limit_s=5)
    assert plan.status == "optimal" and plan.makespan_s == pytest.approx(6.0)
    assert set(plan.chosen) == {"human_b", "arm_a", "finish"}
    assert validate(sc, plan.to_json()) == []
    with pytest.raises(FlexhrcError, match="no hyper-arc"):
        hindsight(sc, [{"hyperarc": "nope", "agent": "arm"}])


def test_cli_json_has_exactly_the_contract_keys(capsys):
    assert main(["plan", str(TWO_JOBS), "--json", "--time-limit", "5"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data) == KEYS
    assert data["status"] == "optimal" and data["makespan_s"] == 5.0
    assert all(
        list(e) == ["action", "agents", "hyperarc", "start_s", "end_s"] for e in data["schedule"]
    )
    assert data["by_agent"] == {"human": 1, "arm": 2}


def test_cli_text_names_objective_bound_and_status(capsys):
    assert main(["plan", str(TWO_JOBS), "--objective", "idle"]) == 0
    out = capsys.readouterr().out
    assert "idle 3.000 s, proven bound 3.000 s" in out and "status OPTIMAL" in out


def test_cli_plot_draws_a_gantt_chart(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "gantt.png"
    assert main(["plan", str(TWO_JOBS), "--plot", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not [p for p in tmp_path.iterdir() if p.name != "gantt.png"]  # atomic: no leftovers


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["nope.yaml"], "nope.yaml"),
        ([str(TWO_JOBS), "--plot", "gantt.txt"], "unsupported output format"),
        ([str(TWO_JOBS), "--plot", "/no/such/dir/g.png"], "--plot"),
        ([str(TWO_JOBS), "--time-limit", "0"], "--time-limit"),
        ([str(TWO_JOBS), "--time-limit", "nan"], "--time-limit"),
        ([str(TWO_JOBS), "--objective", "speed"], "--objective"),
        ([str(TWO_JOBS), "--simulator", "magic"], "--simulator"),
        ([str(TWO_JOBS), "--human", "lazy"], "--human"),
    ],
)
def test_cli_bad_input_is_one_error_and_exit_2(args, said, capsys):
    assert main(["plan", *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error:") and said in err and "Traceback" not in err


def test_the_kinematic_simulator_times_the_plan():
    pytest.importorskip("pinocchio")
    sc = load_scenario("examples/scenarios/gearbox.yaml")
    plan = solve(sc, simulator="kinematic", time_limit_s=10)
    assert plan.status == "optimal" and validate(sc, plan.to_json()) == []
    analytic = solve(sc, simulator="analytic", time_limit_s=10)
    assert plan.makespan_s != analytic.makespan_s  # timed by the robot model, not the figures


def test_a_hierarchy_of_graphs_is_planned_through_its_lower_instances(capsys):
    # kitchen_drawer: build_drawer is carried out by a DrawerAssembly instance, whose h1 is a
    # DrawerFrontPlankConnectionsAssembly instance and h8, h9 two RollerAssembly instances;
    # each instance is expanded in place of its hyper-arc, named under its path
    assert main(["plan", "kitchen_drawer", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["status"] == "optimal"
    sc = load_scenario("kitchen_drawer")
    assert validate(sc, data) == []
    arcs = {e["hyperarc"] for e in data["schedule"]}
    assert {"build_drawer/h1/h1", "build_drawer/h4", "build_drawer/h9/h4"} <= arcs
    assert "build_drawer" not in arcs  # its lower instance does its work
    # M1 (eq. 15): each RollerAssembly instance is bound to the slide the upper layer names
    for instance, slide in (("build_drawer/h8/", "slide_1"), ("build_drawer/h9/", "slide_2")):
        actions = [e["action"] for e in data["schedule"] if e["hyperarc"].startswith(instance)]
        assert len(actions) == 5 and all(slide in a for a in actions), actions
    # a roller screw is consumed once: six different screws for the two slides
    screws = [e["action"].split(", ")[1] for e in data["schedule"] if "screw_slide" in e["action"]]
    assert len(screws) == len(set(screws)) == 6
    # an instance starts when its hyper-arc's children are met: h8's after h7 ended
    end = {e["hyperarc"]: e["end_s"] for e in data["schedule"]}
    start = {}
    for e in data["schedule"]:
        start.setdefault(e["hyperarc"], e["start_s"])
    assert start["build_drawer/h8/h1"] >= end["build_drawer/h7"] - 1e-6
    assert start["build_drawer/h9/h1"] >= end["build_drawer/h8/h4"] - 1e-6


def test_the_validator_checks_the_instances_of_a_hierarchy():
    sc = load_scenario("kitchen_drawer")
    data = solve(sc).to_json()
    assert validate(sc, data) == []
    # a lower instance's step moved before the instance is active (h7 not done yet)
    early = json.loads(json.dumps(data))
    step = next(e for e in early["schedule"] if e["hyperarc"] == "build_drawer/h9/h1")
    step["end_s"] -= step["start_s"]
    step["start_s"] = 0.0
    assert any("build_drawer/h9/h1" in p for p in validate(sc, early))
    # an instance's step left out: its lower root is not reached
    short = json.loads(json.dumps(data))
    short["schedule"] = [e for e in short["schedule"] if e["hyperarc"] != "build_drawer/h8/h2"]
    assert validate(sc, short)


@pytest.mark.parametrize(
    "name",
    [
        "examples/scenarios/ball_in_box.yaml",
        "examples/scenarios/lid_task.yaml",
        "table_assembly",
        "kitchen_drawer",
    ],
)
@pytest.mark.parametrize("seed", [0, 1])
def test_no_passive_run_beats_the_optimum_with_the_hands_travel(name, seed):
    # the --travel optimum is a lower bound of a run's times (issue 23): the hands' travel from
    # one hyper-arc to the next in a circuit per agent, beyond MAX_CIRCUIT branches relaxed
    # (each branch as if the hand came from where it is quickest)
    from flexhrc.scenario import prepare

    bound = solve(load_scenario(name, seed=seed), time_limit_s=20, travel=True)
    assert bound.status == "optimal"
    for policy in ("paper", "lookahead"):
        sc = load_scenario(name, seed=seed)
        total = (
            prepare(sc, profile="passive", seed=seed, policy=policy)
            .run()
            .summary["timing"]["total_s"]
        )
        # whole milliseconds in the model: each action's time rounded, 0.5 ms at most
        slack = 0.0005 * len(bound.schedule)
        assert total >= bound.makespan_s - slack, (policy, total, bound.makespan_s)
