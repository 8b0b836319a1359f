"""`flexhrc ros2 human`: the cell's simulated operator as a ROS 2 node."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from flexhrc.ros2.transport import Ros2Transport
from tests.ros2.conftest import wait_for


@pytest.mark.slow
def test_the_operator_node_reports_each_suggested_step_and_exits_at_the_end(
    ros_env: dict[str, str], domain_id: int, cell_name: str
):
    proc = subprocess.Popen(
        [sys.executable, "-m", "flexhrc", "ros2", "human", "table_assembly", "--name", "human",
         "--cell", cell_name, "--json", "--quiet"],
        env=ros_env, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        with Ros2Transport(prefix=f"flexhrc/{cell_name}", domain_id=domain_id) as bus:
            alive: list[str] = []
            reports: list[dict] = []
            bus.watch_liveliness("alive/*", lambda k, a: alive.append(k) if a else None)
            bus.subscribe("human", reports.append)
            assert wait_for(lambda: "alive/human" in alive, 30.0, bus.flush)
            assert bus.wait_matched("suggest/human", minimum=1, timeout=10.0)
            actions = ["pick_up(human, leg2)", "screw(human, leg2, bolt_1)"]
            for k in range(2):  # the manager names one step at a time
                bus.publish("suggest/human", {
                    "v": 1, "type": "suggestion", "id": "s1", "element": "human_1",
                    "actions": actions, "cost": 3, "t": 1.5 + 2 * k, "step": k, "realtime": 0,
                })  # fmt: skip
                assert wait_for(lambda k=k: len(reports) == k + 1, 10.0, bus.flush)
            assert [r["action"] for r in reports] == actions
            assert [r["step"] for r in reports] == [0, 1]
            assert all(r["suggestion"] == "s1" and r["agent"] == "human" for r in reports)
            assert reports[0]["start"] == 1.5 and reports[1]["t"] > reports[1]["start"] == 3.5
            bus.publish("state", {"v": 1, "type": "end", "outcome": "solved"})
            out, _ = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
    assert proc.returncode == 0 and json.loads(out)["outcome"] == "solved"
