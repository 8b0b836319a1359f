"""Standard ROS 2 messages built from flexhrc data and read back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg
from flexhrc.scenario.builtin.table import table_assembly


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


@pytest.mark.parametrize("angle", [0.0, 0.3, -2.0, math.pi - 1e-9])
def test_quaternion_of_a_yaw_rotation_round_trips(angle: float):
    q = rm.quaternion_from_matrix(_rot_z(angle))
    assert math.isclose(sum(v * v for v in q), 1.0, rel_tol=1e-9)
    assert math.isclose(math.cos(rm.yaw_from_quaternion(*q) - angle), 1.0, abs_tol=1e-9)


def test_quaternion_of_a_half_turn_about_x_is_accurate():
    R = np.array([[1.0, 0, 0], [0, -1, 0], [0, 0, -1]])  # top-down gripper: trace = -1
    x, _y, _z, w = rm.quaternion_from_matrix(R)
    assert math.isclose(abs(x), 1.0, abs_tol=1e-12) and abs(w) < 1e-12


def test_joint_state_and_pose_carry_names_values_and_stamps():
    js = rm.joint_state(rm.joint_names("left"), [0.1] * 7, 12.25)
    assert js.name[0] == "left_joint1" and len(js.position) == 7
    assert js.header.stamp.sec == 12 and js.header.stamp.nanosec == 250_000_000
    ps = rm.pose_stamped((0.5, 0.1, 0.2), 1.0)
    assert ps.header.frame_id == "world" and ps.pose.position.y == pytest.approx(0.1)
    with pytest.raises(ValueError, match="finite"):
        rm.joint_state(rm.joint_names("left"), [float("nan")] + [0.0] * 6, 0.0)
    with pytest.raises(ValueError, match="7 joint names but 6"):
        rm.joint_state(rm.joint_names("left"), [0.0] * 6, 0.0)
    with pytest.raises(ValueError, match="stamp"):
        rm.pose_stamped((0, 0, 0), float("inf"))


def test_joint_trajectory_keeps_ends_times_and_rests_at_both_ends():
    t = np.linspace(0.0, 2.0, 201)
    q = np.stack([np.sin(t)] * 7, axis=1)
    m = rm.joint_trajectory(rm.joint_names("right"), t.tolist(), q.tolist(), 0.0, max_points=20)
    assert 2 <= len(m.points) <= 20
    first, last = m.points[0], m.points[-1]
    assert first.time_from_start.sec == 0 and first.time_from_start.nanosec == 0
    assert last.time_from_start.sec == 2 and list(last.positions) == pytest.approx(q[-1].tolist())
    assert list(first.velocities) == [0.0] * 7 and list(last.velocities) == [0.0] * 7
    mid = m.points[len(m.points) // 2]
    tm = mid.time_from_start.sec + mid.time_from_start.nanosec * 1e-9
    assert mid.velocities[0] == pytest.approx(math.cos(tm), abs=0.02)
    with pytest.raises(ValueError, match="as many times"):
        rm.joint_trajectory(rm.joint_names("right"), [0.0, 1.0], [[0.0] * 7], 0.0)


def test_marker_array_shows_objects_labels_and_command_arrows_with_stable_ids():
    kb = table_assembly(segments="legs").world()
    a = rm.marker_array(kb.objects.values(), 0.0, commands={3: ("left", (0.5, 0.1, 0.0))})
    b = rm.marker_array(kb.objects.values(), 1.0, commands={3: ("left", (0.5, 0.1, 0.0))})
    Marker = msg("visualization_msgs.msg", "Marker")
    kinds = [m.type for m in a.markers]
    shown = {m.text for m in a.markers if m.type == Marker.TEXT_VIEW_FACING}
    assert {"leg1", "leg4", "tabletop", "bolt_1", "middle"} <= shown
    assert "left" not in shown and "human" not in shown  # arms and people are not objects
    assert kinds.count(Marker.CYLINDER) >= 4 and Marker.CUBE in kinds and Marker.ARROW in kinds
    assert [m.id for m in a.markers] == [m.id for m in b.markers]
    assert len({m.id for m in a.markers}) == len(a.markers)


def test_object_pose_and_imu_readings_become_plain_percepts():
    ps = rm.pose_stamped((0.4, -0.2, 0.0), 3.5, rm.quaternion_from_matrix(_rot_z(0.5)))
    p = rm.percept_from_pose("leg2", ps)
    q = p.pop("orientation")
    assert p == {"object": "leg2", "position": [0.4, -0.2, 0.0], "yaw": 0.5, "t": 3.5}
    assert q == pytest.approx([0.0, 0.0, math.sin(0.25), math.cos(0.25)])
    ps.header.frame_id = "camera"
    with pytest.raises(ValueError, match="frame 'camera'"):
        rm.percept_from_pose("leg2", ps)
    ps.header.frame_id = "world"
    ps.pose.orientation.w = 0.0
    ps.pose.orientation.z = 0.0
    ps.pose.orientation.x = ps.pose.orientation.y = 0.0
    assert rm.percept_from_pose("leg2", ps)["yaw"] == 0.0  # unset orientation = identity
    imu = msg("sensor_msgs.msg", "Imu")()
    imu.linear_acceleration.z = 9.81
    imu.angular_velocity.x = 0.1
    imu.header.stamp = rm.stamp(2.0)
    assert rm.imu_sample(imu) == {"t": 2.0, "accel": [0.0, 0.0, 9.81], "gyro": [0.1, 0.0, 0.0]}
    imu.linear_acceleration.x = float("nan")
    with pytest.raises(ValueError, match="linear_acceleration"):
        rm.imu_sample(imu)


def test_markers_show_every_object_by_type_and_size_and_delete_finished_commands():
    from flexhrc.knowledge.base import ObjectRecord

    objs = [
        ObjectRecord(
            "housing", "housing", (0.4, 0.0, 0.0), {"length": 0.2, "width": 0.16, "height": 0.12}
        ),
        ObjectRecord("shaft", "shaft", (0.5, 0.1, 0.0), {"radius": 0.01, "length": 0.1}),
        ObjectRecord("ball", "ball", (0.5, -0.1, 0.0), {"diameter": 0.05}),
        ObjectRecord("screw", "screw", (0.6, 0.0, 0.1)),
        ObjectRecord("left", "arm", (0.3, 0.15, 0.5)),
        ObjectRecord("human", "human", (1.1, 0.0, 0.1)),
        ObjectRecord("helper", "gear", (0.0, 0.0, 0.0)),
    ]
    Marker = msg("visualization_msgs.msg", "Marker")
    a = rm.marker_array(objs, 0.0, commands={7: ("left", (0.4, 0.0, 0.0))}, deleted=[3, 5],
                        skip=["helper"])  # fmt: skip
    shapes = {m.text: m for m in a.markers if m.ns == "flexhrc" and m.type != m.TEXT_VIEW_FACING}
    assert sorted(shapes) == ["ball", "housing", "screw", "shaft"]  # agents left out
    h = shapes["housing"]
    assert h.type == Marker.CUBE and (h.scale.x, h.scale.y, h.scale.z) == (0.2, 0.16, 0.12)
    assert shapes["shaft"].type == Marker.CYLINDER and shapes["shaft"].scale.z == 0.1
    assert shapes["shaft"].scale.x == pytest.approx(0.02)
    assert shapes["ball"].type == Marker.SPHERE and shapes["ball"].scale.x == 0.05
    assert shapes["screw"].type == Marker.CUBE and shapes["screw"].scale.x == rm.DEFAULT_SIZE
    arrows = [m for m in a.markers if m.ns == "flexhrc/commands" and m.action == Marker.ADD]
    assert [(m.id, m.type, m.text) for m in arrows] == [(7, Marker.ARROW, "left")]
    gone = [m for m in a.markers if m.action == Marker.DELETE]
    assert [(m.ns, m.id) for m in gone] == [("flexhrc/commands", 3), ("flexhrc/commands", 5)]
    # ids by name: the same object keeps its id whatever else is in the array
    b = rm.marker_array(objs[:1], 1.0)
    assert b.markers[0].id == h.id
