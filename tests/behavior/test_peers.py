"""Two robots, one task, in one process over the in-process peer bus: claims and progress keep
every constraint and do nothing twice; when one robot dies the other finishes."""

from __future__ import annotations

import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexhrc.behavior import check_run, random_world
from flexhrc.behavior.messages import to_wire
from flexhrc.behavior.peers import PeerClaim, PeerDone, PeerReply, from_wire, run_team
from flexhrc.cli import main
from flexhrc.scenario.builtin.table_setting import load_scenario
from tests.behavior.test_compile import shapes, to_task


def completed(runs):
    return [r.behavior for r in runs if r.outcome == "done"]


@pytest.mark.parametrize("layout", [1, 2, 3])
def test_two_robots_set_the_table_sharing_the_work(layout):
    sc = load_scenario("table-setting", layout)
    team = run_team(sc.task, sc.world, 2)
    assert team.outcome == "done"
    assert check_run(sc.task, team.runs) == []
    done = completed(team.runs)
    assert len(done) == len(set(done)) == 7  # nothing picked twice
    by_robot = {r.arm.split("/")[0] for r in team.runs if r.outcome == "done"}
    assert by_robot == {"robot1", "robot2"}  # both worked
    alone = load_scenario("table-setting", layout)
    from flexhrc.behavior import run_task

    assert team.time < run_task(alone.task, alone.world).time  # and faster than one


@pytest.mark.parametrize("layout", [1, 2, 3])
@pytest.mark.parametrize("when", [5.0, 15.0, 30.0])
def test_when_a_robot_dies_mid_task_the_other_completes(layout, when):
    sc = load_scenario("table-setting", layout)
    team = run_team(sc.task, sc.world, 2, lose={"robot1": lambda net: net.clock.now() >= when})
    assert team.lost == ["robot1"]
    assert team.outcome == "done"
    assert check_run(sc.task, team.runs) == []
    done = completed(team.runs)
    assert len(done) == len(set(done))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    shape=shapes(12),
    seed=st.integers(0, 10_000),
    robots=st.sampled_from([2, 3]),
    lose_at=st.one_of(st.none(), st.floats(0.0, 40.0)),
)
def test_random_tasks_with_a_team_respect_every_constraint(shape, seed, robots, lose_at):
    task = to_task(shape)
    world = random_world(task.behaviors, seed=seed)
    for arm in world.arms.values():
        arm.speed = 1.0
    world.grasp_time = world.place_time = 0.5
    lose = None if lose_at is None else {"robot2": lambda net: net.clock.now() >= lose_at}
    team = run_team(task, world, robots, lose=lose, max_ticks=20_000)
    assert team.outcome == "done", task.to_prefix()
    assert check_run(task, team.runs) == [], task.to_prefix()
    done = completed(team.runs)
    assert len(done) == len(set(done)), task.to_prefix()


def test_peer_messages_survive_json():
    for msg in (
        PeerClaim("r1", "fork", 3),
        PeerReply("r2", "r1", "fork", 3, True),
        PeerDone("r1", "a"),
    ):
        assert from_wire(json.loads(json.dumps(to_wire(msg)))) == msg
    for bad in ([], {"type": "PeerClaim", "robot": "r1"}, {"type": "Nope"}):
        with pytest.raises(ValueError):
            from_wire(bad)


def test_cli_two_robots_in_one_process(capsys, tmp_path):
    png = tmp_path / "team.png"
    argv = [
        "behave",
        "table-setting",
        "--layout",
        "2",
        "--robots",
        "2",
        "--json",
        "--plot",
        str(png),
    ]
    assert main(argv) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    data = json.loads(capsys.readouterr().out)
    assert data["outcome"] == "done" and data["violations"] == []
    assert sorted(data["robots"]) == ["robot1", "robot2"]
    assert len(data["order"]) == len(set(data["order"])) == 7


def test_team_logs_are_streamed_per_robot_and_replay(capsys, tmp_path):
    log = tmp_path / "team.jsonl"
    assert main(["behave", "table-setting", "--robots", "2", "--log", str(log)]) == 0
    capsys.readouterr()
    for robot in ("robot1", "robot2"):
        per_robot = tmp_path / f"team.{robot}.jsonl"
        assert main(["behave", "replay", str(per_robot), "--json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert data["robot"] == robot and data["violations"] == [] and data["outcome"] == "done"
        assert data["done_elsewhere"]  # the other robot's share


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["(AND a b)", "--robots", "5"], "--robots must be in 1..4"),
        (["(AND a b)", "--transport", "zenoh"], "--transport needs --robots"),
        (["(AND a b)", "--robots", "2", "--arms", "2"], "--arms does not apply with --robots"),
        (["(AND a b)", "--robots", "2", "--plot", "x.xyz"], "unsupported output format"),
        (["(AND a b)", "--robot", "robot1"], "--robot and --peer-port are for"),
        (["replay", "x.jsonl", "--robots", "2"], "--robots does not apply"),
    ],
)
def test_team_options_are_checked(capsys, argv, fragment):
    assert main(["behave", *argv]) == 2
    err = capsys.readouterr().err
    assert fragment in err and err.count("\n") == 1
