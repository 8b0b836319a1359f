"""`flexhrc ros2 ...`: bad input is one clear error (exit 2, no traceback); without rclpy the
bridge says which extra to install and the rest of flexhrc does not notice."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import subprocess_env

_NO_RCLPY = (
    "import sys; sys.modules['rclpy'] = None; "  # an import of rclpy now fails
    "from flexhrc.cli import main; sys.exit(main(sys.argv[1:]))"
)


def _run(*args: str, code: str | None = None) -> subprocess.CompletedProcess[str]:
    argv = [sys.executable, "-c", code, *args] if code else [sys.executable, "-m", "flexhrc", *args]
    return subprocess.run(argv, env=subprocess_env(), capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["table_assembly", "--arm", "middle"], "--arm 'middle': no robot agent"),
        (["nowhere", "--arm", "left"], "unknown scenario 'nowhere'"),
        (["table_assembly", "--arm", "left", "--rate", "5"], "--rate must be between 30"),
        (["table_assembly", "--arm", "left", "--cell", "my-cell"], "not a valid ROS 2 name"),
        (["table_assembly", "--arm", "left", "--domain-id", "300"], "domain id must be in 0..232"),
        (["table_assembly", "--arm", "left", "--execute", "external"], "--trajectory-topic"),
        (["parallel_assembly", "--arm", "arm1"], "needs the kinematic simulator"),
    ],
)
def test_bad_arm_options_are_one_clear_error(args: list[str], message: str):
    out = _run("ros2", "arm", *args)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr
    assert "Traceback" not in out.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--name", "left"], "--name 'left': no human agent"),
        (["--name", "human", "--profile", "lazy"], "--profile 'lazy': unknown operator profile"),
    ],
)
def test_bad_human_options_are_one_clear_error(args: list[str], message: str):
    out = _run("ros2", "human", "table_assembly", *args)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and "Traceback" not in out.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--realtime", "nan"], "finite number >= 0"),
        (["--realtime", "-1"], "finite number >= 0"),
        (["--resume"], "--resume needs --store"),
        (["--markers-rate", "0"], "--markers-rate must be in"),
        (["--wait", "-1"], "--wait must be a positive"),
        (["--store", "/nonexistent/dir/c.db"], "/nonexistent/dir"),
        (["--cell", "a-b"], "not a valid ROS 2 name"),
        (["--web", "0.0.0.0:8080"], "--token"),
        (["--token", "abcdefgh12"], "--token is only used with --web"),
    ],
)
def test_bad_cell_options_are_one_clear_error(args: list[str], message: str):
    out = _run("ros2", "cell", "table_assembly", *args)
    assert out.returncode == 2, out.stderr
    assert message in out.stderr and "Traceback" not in out.stderr


def test_without_rclpy_the_bridge_names_the_extra_and_the_rest_still_works():
    out = _run("ros2", "arm", "table_assembly", "--arm", "left", code=_NO_RCLPY)
    assert out.returncode == 2
    assert "pip install 'flexhrc[ros2]'" in out.stderr and "Traceback" not in out.stderr
    helped = _run("--help", code=_NO_RCLPY)
    assert helped.returncode == 0 and "ros2" in helped.stdout
    core = subprocess.run(
        [sys.executable, "-c", "import sys, flexhrc.taskmanager, flexhrc.transport, flexhrc.cli; "
         "flexhrc.cli.build_parser(); assert 'rclpy' not in sys.modules"],
        env=subprocess_env(), capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert core.returncode == 0, core.stderr
