"""Task-priority controller: activation functions, the regularised pseudo-inverse, priorities,
and the acceptance tests of the issue (reaching, joint limits, obstacles, two-arm transport,
unreachable targets)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexhrc.action.control import (
    DEFAULT_HIERARCHY,
    Box,
    ObjectiveSpec,
    Sphere,
    bell_above,
    bell_below,
    parse_obstacle,
    regularised_pinv,
    rotation_log,
    top_down_rotation,
)
from flexhrc.action.simulator import ActionSpec, KinematicSimulator, Pose
from flexhrc.errors import FlexhrcError, UnknownNameError

# -- activation functions and algebra -------------------------------------------------------------


def test_bell_activation_is_one_past_the_bound_zero_beyond_and_monotone():
    x = np.linspace(-0.1, 0.3, 401)
    a = bell_below(x, 0.0, 0.1)
    assert np.all(a[x <= 0.0] == 1.0) and np.all(a[x >= 0.1] == 0.0)
    assert np.all(np.diff(a) <= 1e-12)  # non-increasing: smooth switch-off
    assert bell_below(0.05, 0.0, 0.1) == pytest.approx(0.5)
    np.testing.assert_allclose(bell_above(-x, 0.0, 0.1), a)


def test_regularised_pinv_is_the_pseudo_inverse_when_fully_active():
    rng = np.random.default_rng(1)
    J = rng.normal(size=(3, 7))
    np.testing.assert_allclose(regularised_pinv(J, None, 1e-10), np.linalg.pinv(J), atol=1e-5)


def test_regularised_pinv_fades_out_continuously_with_activation():
    rng = np.random.default_rng(2)
    J = rng.normal(size=(2, 7))
    norms = [np.linalg.norm(regularised_pinv(J, np.full(2, a), 1e-4)) for a in (1e-6, 1e-3, 0.1)]
    assert norms[0] < 1e-6 < norms[1] < norms[2]
    assert np.all(regularised_pinv(J, np.zeros(2), 1e-4) == 0.0)


def test_rotation_log_round_trip():
    R = top_down_rotation(0.7) @ top_down_rotation(0.2).T
    np.testing.assert_allclose(rotation_log(R), [0, 0, 0.5], atol=1e-12)
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    for _ in range(200):
        v = rng.normal(size=3)
        v *= rng.uniform(0.0, math.pi - 1e-3) / np.linalg.norm(v)
        np.testing.assert_allclose(rotation_log(Rotation.from_rotvec(v).as_matrix()), v, atol=1e-7)
    half_turn = rotation_log(Rotation.from_rotvec([0, 0, math.pi]).as_matrix())
    assert abs(float(np.linalg.norm(half_turn)) - math.pi) < 1e-9


# -- obstacles as data --------------------------------------------------------------------------


def test_obstacle_distances():
    d, n = Sphere((0, 0, 0), 0.1).distance(np.array([0.3, 0, 0]))
    assert d == pytest.approx(0.2) and np.allclose(n, [1, 0, 0])
    d, n = Box((0, 0, 0), (0.1, 0.1, 0.1)).distance(np.array([0.0, 0.0, 0.25]))
    assert d == pytest.approx(0.15) and np.allclose(n, [0, 0, 1])
    d, _ = Box((0, 0, 0), (0.1, 0.1, 0.1)).distance(np.array([0.0, 0.0, 0.05]))
    assert d == pytest.approx(-0.05)


def test_parse_obstacle_forms_and_errors():
    assert parse_obstacle([0.5, 0, 0.2, 0.05]) == Sphere((0.5, 0.0, 0.2), 0.05)
    box = Box((0.5, 0, 0.2), (0.1, 0.1, 0.1))
    assert parse_obstacle(["0.5", "0", "0.2", "0.1", "0.1", "0.1"]) == box
    assert parse_obstacle({"type": "sphere", "center": [1, 2, 3], "radius": 0}).radius == 0
    for bad, msg in [
        ([1, 2, 3], "4 numbers"),
        ([1, 2, "x", 4], "obstacle"),
        ([1, 2, 3, -1], "radius"),
        ({"type": "cone", "center": [0, 0, 0]}, "unknown obstacle type"),
        ({"type": "box", "center": [0, 0, 0], "half_extents": [1, 1]}, "half_extents"),
    ]:
        with pytest.raises(FlexhrcError, match=msg):
            parse_obstacle(bad)


def test_objectives_and_priorities_are_data():
    with pytest.raises(UnknownNameError, match="unknown objective kind"):
        ObjectiveSpec("levitate", 0)
    spec = ActionSpec("careful", hierarchy=DEFAULT_HIERARCHY).with_priorities(ee_position=0)
    assert {s.kind: s.priority for s in spec.hierarchy}["ee_position"] == 0
    assert "human" not in {s.kind for s in spec.without("human").hierarchy}


# -- acceptance: the controller on the model -----------------------------------------------------


def _orientation_error(robot, arm, q, yaw):
    """Angle to the top-down grasp at ``yaw``, modulo the gripper's half-turn symmetry."""
    _, R = robot.arm(arm).pose(q)
    return min(
        float(np.linalg.norm(rotation_log(top_down_rotation(yaw + k * math.pi) @ R.T)))
        for k in (-1, 0, 1)
    )


def _assert_within_limits(robot, outcome):
    for arm in outcome.trajectory.arms:
        m = robot.arm(arm)
        q = outcome.trajectory.arm_q(arm)
        assert np.all(q >= m.q_min) and np.all(q <= m.q_max), f"{arm} left its joint range"


def test_reaching_random_reachable_targets(sim, robot):
    """Random top-down targets in the workspace box with any yaw, each reached from where the
    previous one left the arm: < 1 mm and < 0.01 rad at the end (the grasp yaw is taken modulo
    a half turn, see ``ActionSpec.yaw_period``), joint limits never exceeded (seeded)."""
    rng = np.random.default_rng(2024)
    state = sim.rest_state()
    for i in range(24):
        arm = ("left", "right")[i % 2]
        xyz = rng.uniform([0.35, -0.2, 0.05], [0.65, 0.2, 0.35])
        yaw = float(rng.uniform(-math.pi, math.pi))
        out = sim.simulate(arm, "transport", Pose(tuple(xyz), yaw), start=state)
        assert out.success, (xyz, yaw, out.reason)
        q = out.final_state.q[arm]
        p, _ = robot.arm(arm).pose(q)
        assert np.linalg.norm(p - xyz) < 1e-3
        assert _orientation_error(robot, arm, q, yaw) < 0.01
        assert out.duration_s < sim.time_budget_s
        _assert_within_limits(robot, out)
        state = out.final_state


def test_exact_yaw_when_the_grasp_is_not_symmetric(sim, robot):
    spec = ActionSpec("place_oriented", goal="target", yaw_period=0.0)
    out = sim.simulate("left", spec, Pose((0.5, 0.1, 0.2), 2.5))
    assert out.success, out.reason
    _, R = robot.arm("left").pose(out.final_q["left"])
    assert float(np.linalg.norm(rotation_log(top_down_rotation(2.5) @ R.T))) < 0.01


def test_joint_limits_hold_when_the_goal_pulls_against_them(sim, robot):
    """A target the arm cannot reach without folding past joint 4's limit: the arm stops at the
    limit, never beyond, and the failure says why."""
    out = sim.simulate("left", "transport", [0.05, 0.15, 0.3])
    assert not out.success and "stalled" in out.reason and "joint" in out.reason
    _assert_within_limits(robot, out)


def test_obstacle_on_the_straight_line_keeps_distance_and_reaches(sim, robot):
    start = sim.simulate("left", "approach", [0.4, 0.15, 0.1]).final_state  # TCP (0.4, 0.15, 0.2)
    goal = np.array([0.6, -0.05, 0.2])
    for obstacle in (Sphere((0.5, 0.05, 0.2), 0.04), Box((0.5, 0.05, 0.2), (0.03, 0.03, 0.03))):
        free = sim.simulate("left", "transport", goal, start=start)
        out = sim.simulate("left", "transport", goal, start=start, obstacles=[obstacle])
        assert out.success, out.reason
        # The straight line passes through the obstacle; the arm went around it ...
        assert min(obstacle.distance(p)[0] for p in free.trajectory.tcp["left"]) < 0
        # ... keeping the set minimum distance (5 cm) at every step,
        dists = [obstacle.distance(p)[0] for p in out.trajectory.tcp["left"]]
        assert min(dists) >= 0.05 - 1e-3
        assert out.min_distance_m == pytest.approx(min(dists))
        # ... and still reached the goal, at the cost of a little time.
        assert np.linalg.norm(robot.arm("left").pose(out.final_state.q["left"])[0] - goal) < 1e-3
        assert out.duration_s >= free.duration_s


def test_human_hand_minimum_distance(sim):
    start = sim.simulate("left", "approach", [0.4, 0.15, 0.1]).final_state
    hand = np.array([0.5, 0.05, 0.32])  # 12 cm above the straight path
    goal = [0.6, -0.05, 0.2]
    free = sim.simulate("left", "transport", goal, start=start)
    assert np.linalg.norm(free.trajectory.tcp["left"] - hand, axis=1).min() < 0.15
    out = sim.simulate("left", "transport", goal, start=start, human_hand=hand)
    assert out.success, out.reason
    d = np.linalg.norm(out.trajectory.tcp["left"] - hand, axis=1)
    assert d.min() >= 0.15 - 1e-3  # the human minimum distance (15 cm)
    # A goal inside the human's safety distance is refused, with the reason.
    near = hand + np.array([0.05, 0.0, 0.0])
    out = sim.simulate("left", "transport", near, start=start, human_hand=hand)
    assert not out.success and "human hand" in out.reason


def test_two_arm_transport_keeps_the_relative_pose(sim, robot):
    grasp = sim.simulate_sequence("both", [("approach", [0.5, 0, 0.1]), ("grasp", [0.5, 0, 0.1])])
    assert grasp.success, grasp.reason
    out = sim.simulate("both", "transport", [0.45, 0.1, 0.3], start=grasp.final_state)
    assert out.success, out.reason
    L, R = out.trajectory.arm_q("left"), out.trajectory.arm_q("right")
    pl, Rl = robot.arm("left").pose(L[0])
    pr, Rr = robot.arm("right").pose(R[0])
    r0, R0 = Rl.T @ (pr - pl), Rl.T @ Rr
    worst_p = worst_o = 0.0
    for ql, qr in zip(L, R, strict=True):
        pl, Rl = robot.arm("left").pose(ql)
        pr, Rr = robot.arm("right").pose(qr)
        worst_p = max(worst_p, float(np.linalg.norm(Rl.T @ (pr - pl) - r0)))
        worst_o = max(worst_o, float(np.linalg.norm(rotation_log(R0.T @ Rl.T @ Rr))))
    assert worst_p < 1e-3 and worst_o < 0.01
    mid = 0.5 * (robot.arm("left").pose(L[-1])[0] + robot.arm("right").pose(R[-1])[0])
    assert np.linalg.norm(mid - [0.45, 0.1, 0.3]) < 1e-3
    _assert_within_limits(robot, out)


@pytest.mark.parametrize(
    ("target", "expect"),
    [
        ((1.5, 0.0, 0.2), "out of reach"),  # 1.5 m away: rejected without integrating
        ((-0.35, 0.15, 0.1), "stalled"),  # behind the robot: the shoulder joint limit stops it
        ((0.05, 0.15, 0.3), "stalled"),  # inside the folded elbow
    ],
)
def test_unreachable_targets_fail_within_the_budget_with_a_reason(sim, robot, target, expect):
    out = sim.simulate("left", "transport", target, time_budget_s=8.0)
    assert not out.success
    assert expect in out.reason
    assert out.duration_s <= 8.0
    _assert_within_limits(robot, out)


def test_time_budget_exhausted_is_a_timeout(sim):
    out = sim.simulate("left", "transport", [0.65, -0.2, 0.05], time_budget_s=0.4)
    assert not out.success and out.reason.startswith("timed out")
    assert out.duration_s == pytest.approx(0.4)


def test_simulation_is_deterministic():
    sim = KinematicSimulator(cache_size=0)
    a = sim.simulate("right", "transport", [0.5, -0.1, 0.2], obstacles=[[0.5, -0.1, 0.35, 0.03]])
    b = sim.simulate("right", "transport", [0.5, -0.1, 0.2], obstacles=[[0.5, -0.1, 0.35, 0.03]])
    assert a.duration_s == b.duration_s and np.array_equal(a.trajectory.q, b.trajectory.q)
    assert math.isfinite(a.energy) and a.energy > 0
