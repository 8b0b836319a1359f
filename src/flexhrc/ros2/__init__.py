"""The ROS 2 bridge (``flexhrc[ros2]``): the cell's manager and arms as ROS 2 nodes.

Nothing here is imported by the core. :mod:`flexhrc.ros2.transport` carries the cell's JSON
protocol on ``std_msgs/String`` topics; the other modules add standard ROS 2 messages (joint
states, poses, markers, joint trajectories, IMU) around it. See ``docs/ros2.md``.
"""

from flexhrc.ros2._deps import available

__all__ = ["available"]
