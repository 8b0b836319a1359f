"""Guarded import of ROS 2's Python client: the core of flexhrc never needs it."""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

from flexhrc.errors import OptionalDependencyError

_HINT = "ros-rclpy"


def require(module: str = "rclpy", feature: str = "the ROS 2 bridge") -> ModuleType:
    """Import ``module`` (``rclpy`` or a message package) or raise
    :class:`~flexhrc.errors.OptionalDependencyError` naming the ``ros2`` extra."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise OptionalDependencyError(
            feature, "ros2", _HINT if module.startswith("rclpy") else f"ros-{_pkg(module)}"
        ) from exc


def _pkg(module: str) -> str:
    return module.split(".", 1)[0].replace("_", "-")


def available() -> bool:
    """Whether rclpy and the standard message packages the bridge uses import."""
    try:
        for name in _MODULES:
            importlib.import_module(name)
    except ImportError:
        return False
    return True


_MODULES = (
    "rclpy",
    "std_msgs.msg",
    "geometry_msgs.msg",
    "sensor_msgs.msg",
    "trajectory_msgs.msg",
    "visualization_msgs.msg",
)


def msg(module: str, name: str) -> Any:
    """A message class, e.g. ``msg("sensor_msgs.msg", "JointState")``."""
    return getattr(require(module), name)
