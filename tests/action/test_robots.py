"""Robot model: URDF, kinematics, limits and the workspace promised by the frame convention."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from flexhrc.action import robots
from flexhrc.errors import FlexhrcError, UnknownNameError


def test_shipped_urdf_is_the_generated_one():
    assert robots.DEFAULT_URDF.read_text(encoding="utf-8") == robots.dual_arm_urdf()


def test_two_seven_dof_arms_with_limits(robot):
    assert robot.arm_names == ("left", "right")
    for arm in robot.arms.values():
        assert arm.dof == 7
        assert np.all(arm.q_min < arm.q_max)
        assert np.all(arm.v_max > 0)
        assert np.all(arm.q_min <= arm.q_rest) and np.all(arm.q_rest <= arm.q_max)
    assert robot.arm("left").shoulder_xyz[1] > 0 > robot.arm("right").shoulder_xyz[1]


def test_rest_pose_is_top_down_in_front_of_each_arm(robot):
    for name, arm in robot.arms.items():
        p, R = arm.pose(arm.q_rest)
        assert p[0] > 0.2 and p[2] > 0.3  # forward of the base, above the table
        assert np.sign(p[1]) == (1 if name == "left" else -1)
        np.testing.assert_allclose(R[:, 2], [0, 0, -1], atol=1e-9)  # approach axis down


def test_jacobian_matches_finite_differences(robot):
    arm = robot.arm("right")
    rng = np.random.default_rng(0)
    q = arm.q_rest + rng.uniform(-0.3, 0.3, 7)
    p, R, J = arm.kinematics(q)
    eps = 1e-6
    for j in range(7):
        dq = np.zeros(7)
        dq[j] = eps
        p2, R2 = arm.pose(q + dq)
        np.testing.assert_allclose((p2 - p) / eps, J[:3, j], atol=1e-5)
        dR = (R2 - R) / eps @ R.T  # = skew(omega)
        np.testing.assert_allclose([dR[2, 1], dR[0, 2], dR[1, 0]], J[3:, j], atol=1e-5)


def test_unknown_arm_is_named():
    robot = robots.load_robot()
    with pytest.raises(UnknownNameError, match=r"unknown arm 'middle'.*argument 'arm'"):
        robot.arm("middle")


def test_missing_urdf_is_a_user_error(tmp_path):
    with pytest.raises(FlexhrcError, match="no such URDF"):
        robots.load_robot(tmp_path / "nope.urdf")


def test_workspace_box_reachable_by_both_arms_on_a_grid(sim):
    """Frame convention of the issue: x in [0.35, 0.65], y in [-0.2, 0.2], z in [0.05, 0.35]
    reachable by both arms with a top-down grasp (7 x 9 x 7 grid, corners included)."""
    xs = np.linspace(0.35, 0.65, 7)
    ys = np.linspace(-0.2, 0.2, 9)
    zs = np.linspace(0.05, 0.35, 7)
    missed = [
        (arm, p)
        for arm in ("left", "right")
        for p in itertools.product(xs, ys, zs)
        if not sim.reachable(arm, p)
    ]
    assert missed == []


def test_far_points_unreachable_and_one_sided_points(sim):
    assert not sim.reachable("left", (1.5, 0.0, 0.1))
    assert not sim.reachable("right", (0.0, 0.0, 1.6))
    # Far to one side: only the arm on that side gets there.
    assert sim.reachable("left", (0.3, 0.7, 0.1)) and not sim.reachable("right", (0.3, 0.7, 0.1))
    assert sim.reachable("right", (0.3, -0.7, 0.1)) and not sim.reachable("left", (0.3, -0.7, 0.1))


def test_workspace_geometry_is_measured_on_the_model(robot):
    for arm in robot.arms.values():
        assert 0.70 < arm.reach_m < 0.75  # Panda: 0.316 m and 0.384 m links with 8.25 cm offsets
        assert arm.hand_along_m == pytest.approx(0.107 + 0.1034)
        assert arm.hand_lateral_m == pytest.approx(0.088)
        p, _ = arm.pose(arm.q_rest)
        assert arm.wrist_distance(p) < arm.reach_m
