"""The ROS 2 bridge (``flexhrc[ros2]``): the cell's manager and arms as ROS 2 nodes.

Nothing here is imported by the core. :mod:`flexhrc.ros2.transport` carries the cell's JSON
protocol on ``std_msgs/String`` topics; the other modules add standard ROS 2 messages (joint
states, poses, markers, joint trajectories, IMU) around it. :mod:`flexhrc.ros2.serve` runs the
nodes of ``flexhrc ros2 cell|arm|human`` from Python (a config in, a report out). Importing this
package does not import ``rclpy``. See ``docs/ros2.md``.
"""

from flexhrc.ros2._deps import available
from flexhrc.ros2.serve import (
    Ros2ArmConfig,
    Ros2CellConfig,
    Ros2HumanConfig,
    Ros2NodeConfig,
    serve_ros2_arm,
    serve_ros2_cell,
    serve_ros2_human,
)

__all__ = [
    "Ros2ArmConfig",
    "Ros2CellConfig",
    "Ros2HumanConfig",
    "Ros2NodeConfig",
    "available",
    "serve_ros2_arm",
    "serve_ros2_cell",
    "serve_ros2_human",
]
