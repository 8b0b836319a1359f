"""Action level: robot models, task-priority control, in-the-loop simulator (paper 000, III).

* :mod:`flexhrc.action.robots` — the dual-arm robot (two 7-DoF Panda arms on a torso) from URDF,
  forward kinematics and Jacobians through pinocchio;
* :mod:`flexhrc.action.control` — the kinematic task-priority framework: prioritised equality and
  inequality objectives with activation functions, regularised pseudo-inverses;
* :mod:`flexhrc.action.simulator` — the in-the-loop :class:`KinematicSimulator` (actions as data,
  success / duration / energy / trajectory, faster than real time);
* :mod:`flexhrc.action.execution` — the Robot :class:`ExecutionManager` with disturbances;
* :mod:`flexhrc.action.view` — headless PyBullet rendering of a trajectory;
* :mod:`flexhrc.action.bridge` — :class:`KinematicTaskSimulator`, the simulator and the
  execution model of the Task Manager.

Importing this package is cheap: pinocchio and PyBullet are imported only when a robot is
loaded or a view rendered (both in the ``sim`` extra). The names below are loaded on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "KinematicSimulator": "simulator",
    "ActionSpec": "simulator",
    "ActionOutcome": "simulator",
    "SequenceOutcome": "simulator",
    "Pose": "simulator",
    "RobotState": "simulator",
    "Trajectory": "simulator",
    "ACTIONS": "simulator",
    "MIDDLE_POSE": "simulator",
    "ExecutionManager": "execution",
    "ExecutionReport": "execution",
    "Command": "execution",
    "Disturbance": "execution",
    "ObjectiveSpec": "control",
    "TaskPriorityController": "control",
    "Sphere": "control",
    "Box": "control",
    "DualArmRobot": "robots",
    "load_robot": "robots",
    "KinematicTaskSimulator": "bridge",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'flexhrc.action' has no attribute {name!r}")
    return getattr(importlib.import_module(f"flexhrc.action.{module}"), name)
