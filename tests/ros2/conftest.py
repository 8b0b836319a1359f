"""ROS 2 test fixtures: every test gets its own ROS domain and cell prefix, discovery stays on
this host, and the whole package skips (with the reason) when rclpy is not importable."""

from __future__ import annotations

import os
import random
import time
import uuid
from collections.abc import Callable, Iterator

import pytest

from flexhrc.ros2 import available

if not available():
    pytest.skip(
        "rclpy or a standard ROS 2 message package is not importable (pip install 'flexhrc[ros2]')",
        allow_module_level=True,
    )

# discovery on loopback only: nothing leaves the machine, and other hosts' nodes never join
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
# UDP on loopback instead of shared memory, here and in the nodes the tests start: a node a
# test SIGKILLs cannot leave Fast DDS segments behind in /dev/shm
os.environ["FASTDDS_BUILTIN_TRANSPORTS"] = "UDPv4"


@pytest.fixture
def domain_id() -> int:
    """A random ROS domain (1..100) so concurrent test runs on one host do not see each other."""
    return random.SystemRandom().randint(1, 100)


@pytest.fixture
def cell_name() -> str:
    return f"t{uuid.uuid4().hex[:8]}"


@pytest.fixture
def ros_env(domain_id: int) -> Iterator[dict[str, str]]:
    """Environment for subprocesses: the test's domain, localhost discovery, the source tree."""
    from tests.conftest import subprocess_env

    env = subprocess_env()
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env["PYTHONUNBUFFERED"] = "1"
    yield env


def wait_for(
    condition: Callable[[], bool], timeout: float, poll: Callable[[], object] | None = None
) -> bool:
    """Wait on a condition (never a fixed sleep): ``poll`` runs between checks (e.g. a
    transport's ``flush``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if poll is not None:
            poll()
        if condition():
            return True
        time.sleep(0.005)
    return condition()


def pytest_configure(config: pytest.Config) -> None:
    # rosidl's parser imports lark, which still uses the deprecated sre_* modules
    for mod in ("sre_parse", "sre_constants"):
        config.addinivalue_line(
            "filterwarnings", f"ignore:module '{mod}' is deprecated:DeprecationWarning"
        )
