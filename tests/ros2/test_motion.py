"""The joint path of a command (flexhrc.ros2.motion): from the arm's joints, for every arm it
moves, lasting the command's duration, whether the kinematic simulator ran it or not."""

from __future__ import annotations

import numpy as np
import pytest

from flexhrc.cell.components import execution_model, ground
from flexhrc.ros2 import motion as mp
from flexhrc.scenario import load_scenario


def test_fit_duration_holds_compresses_and_ends_exactly():
    q = {"left": np.array([[0.0] * 7, [1.0] * 7])}
    t, out = mp.fit_duration(np.array([0.0, 1.0]), q, 2.5)  # shorter: held at its end
    assert t.tolist() == [0.0, 1.0, 2.5] and out["left"][-1].tolist() == [1.0] * 7
    t, out = mp.fit_duration(np.array([1.0, 3.0]), q, 0.5)  # longer: compressed, from 0
    assert t.tolist() == [0.0, 0.5]
    t, out = mp.fit_duration(np.array([0.0]), {"left": q["left"][:1]}, 2.0)  # a stay
    assert t.tolist() == [0.0, 2.0] and (out["left"][0] == out["left"][1]).all()
    t, _ = mp.fit_duration(np.array([0.0, 1.0]), q, 0.0)
    assert t.tolist() == [0.0]


def test_blend_start_begins_where_the_arm_is_and_ends_as_planned():
    t = np.linspace(0.0, 2.0, 21)
    q = np.outer(t, np.ones(7))
    out = mp.blend_start(t, q, [0.01] * 7)
    assert out[0] == pytest.approx([0.01] * 7) and out[-1] == pytest.approx(q[-1])
    assert (np.diff(out[:, 0]) > 0).all()  # still monotone: the offset fades smoothly
    assert mp.min_jerk(np.array([0.0, 0.5, 1.0])).tolist() == [0.0, 0.5, 1.0]


@pytest.fixture(scope="module")
def table():
    sc = load_scenario("table_assembly")
    return sc, execution_model("kinematic", sc)


def _run(sc, ex, text, agents=None):
    kb, dom = sc.world(), sc.domain
    action = ground(dom, text, agents)
    em = ex.execution
    start = {a: q.copy() for a, q in em.state.q.items()}
    since = len(em.log)
    positions = {k: o.position for k, o in kb.objects.items()}
    report = ex.execute(action, dict(positions), kb, dom)
    t, paths = mp.command_path(ex, action, since=since, start=start,
                               duration=report.duration_s, positions=positions)  # fmt: skip
    return report, start, t, paths, since


def test_a_joint_command_moves_both_arms_for_its_whole_duration(table):
    sc, ex = table
    # since issue 21 the tabletop placement is Fig. 8's steps; its first, pick_tabletop, is the
    # composite one (approach, grasp)
    report, start, t, paths, since = _run(sc, ex, "pick_tabletop(tabletop)",
                                          ("left", "right"))  # fmt: skip
    assert report.status == "done" and len(ex.execution.log) - since > 1  # a composite motion
    assert sorted(paths) == ["left", "right"]
    assert t[0] == 0.0 and t[-1] == report.duration_s and (np.diff(t) > 0).all()
    for arm, q in paths.items():
        assert np.abs(q[0] - start[arm]).max() == 0.0
        assert np.abs(q[-1] - q[0]).max() > 0.05  # both arms move
        assert np.abs(q[-1] - ex.execution.state.q[arm]).max() == pytest.approx(0, abs=1e-12)


def test_an_action_the_model_does_not_simulate_gets_a_nominal_path(table):
    sc, ex = table
    before = ex.execution.state.q["left"].copy()
    # a check is timed by the analytic model: the arm goes above the bolt meanwhile
    report, _, t, paths, since = _run(sc, ex, "check(left, bolt_1)")
    assert len(ex.execution.log) == since  # not integrated on the model
    assert list(paths) == ["left"] and t[-1] == report.duration_s > 0
    q = paths["left"]
    assert np.abs(q[0] - before).max() == 0.0 and np.abs(q[-1] - q[0]).max() > 0.01
    step = np.abs(np.diff(q, axis=0)).max(axis=1)
    assert step[0] < step[len(step) // 2] and step[-1] < step[len(step) // 2]  # min jerk
    xyz, _ = ex.execution.sim.robot.arm("left").pose(q[-1])
    bolt = sc.world().position("bolt_1")
    assert np.linalg.norm(np.asarray(xyz[:2]) - np.asarray(bolt[:2])) < 0.01
    # the model's arm is where the path ended: the next command starts there
    assert np.abs(ex.execution.state.q["left"] - q[-1]).max() == 0.0
