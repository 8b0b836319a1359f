"""The manager's standard interfaces: MarkerArray out, object poses and wrist IMU in."""

from __future__ import annotations

import math

import pytest

from flexhrc.ros2 import messages as rm
from flexhrc.ros2._deps import msg
from flexhrc.ros2.extras import DELETE_LINGER_S, ManagerInterfaces
from flexhrc.ros2.transport import Ros2Transport
from flexhrc.scenario.builtin.table import table_assembly
from tests.ros2.conftest import wait_for


def test_markers_out_poses_and_imu_in(domain_id: int, cell_name: str):
    kb = table_assembly(segments="legs").world()
    prefix = f"flexhrc/{cell_name}"
    with (
        Ros2Transport(prefix=prefix, domain_id=domain_id) as manager,
        Ros2Transport(prefix=prefix, domain_id=domain_id) as outside,
    ):
        percepts: list[dict] = []
        samples: list[tuple[str, dict]] = []
        now = [0.0]  # the interfaces' clock, moved by hand
        ifaces = ManagerInterfaces(
            manager, kb, operators=["human"], on_percept=percepts.append,
            on_imu=lambda who, s: samples.append((who, s)), rate_hz=20.0, clock=lambda: now[0],
        )  # fmt: skip
        arrays: list = []
        outside.create_subscription(
            msg("visualization_msgs.msg", "MarkerArray"), "markers", arrays.append
        )
        ifaces.command_started(2, "left", kb.position("leg1"))
        assert manager.wait_matched("markers", minimum=1, timeout=10.0)
        assert wait_for(lambda: bool(arrays), 5.0, lambda: (ifaces.poll(), outside.flush()))
        arrows = [m for m in arrays[-1].markers if m.type == m.ARROW]
        assert len(arrows) == 1 and arrows[0].text == "left"
        assert len(arrays[-1].markers) > 10
        # a command's arrow while it runs; when it ends, its DELETE for DELETE_LINGER_S
        ifaces.command_started(4, "right", kb.position("leg3"))
        ifaces.publish_markers()
        ifaces.command_finished(4)
        for dt in (0.0, DELETE_LINGER_S, 0.1):
            now[0] += dt
            ifaces.publish_markers()
        Marker = msg("visualization_msgs.msg", "Marker")

        def ours() -> list:  # command 4's markers in each array, from its first on
            seen = [[(m.action, m.type) for m in a.markers
                     if m.ns == "flexhrc/commands" and m.id == 4] for a in arrays]  # fmt: skip
            return seen[next((i for i, x in enumerate(seen) if x), len(seen)) :]

        assert wait_for(lambda: len(ours()) >= 4, 5.0, outside.flush)
        delete = [(Marker.DELETE, Marker.ARROW)]
        assert ours()[:4] == [[(Marker.ADD, Marker.ARROW)], delete, delete, []]

        PoseStamped = msg("geometry_msgs.msg", "PoseStamped")
        Imu = msg("sensor_msgs.msg", "Imu")
        pose_pub = outside.create_publisher(PoseStamped, "objects/leg2/pose")
        imu_pub = outside.create_publisher(Imu, "human/human/imu")
        assert outside.wait_matched("objects/leg2/pose", minimum=1, timeout=10.0)
        assert outside.wait_matched("human/human/imu", minimum=1, timeout=10.0)
        bad = rm.pose_stamped((0.1, 0.2, 0.0), 1.0, frame_id="camera")
        pose_pub.publish(bad)
        pose_pub.publish(rm.pose_stamped((0.41, -0.3, 0.0), 2.0))
        imu = Imu()
        imu.linear_acceleration.z = 9.8
        imu_pub.publish(imu)
        assert wait_for(lambda: bool(percepts) and bool(samples), 5.0, manager.flush)
        assert percepts == [
            {"object": "leg2", "position": [0.41, -0.3, 0.0], "orientation": [0.0, 0.0, 0.0, 1.0],
             "yaw": 0.0, "t": 2.0}
        ]  # fmt: skip
        assert samples[0][0] == "human" and math.isclose(samples[0][1]["accel"][2], 9.8)
        assert ifaces.dropped == 1  # the pose in the camera frame
        with pytest.raises(ValueError, match="rate"):
            ManagerInterfaces(manager, kb, rate_hz=0)
