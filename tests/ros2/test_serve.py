"""`flexhrc.ros2.serve`: the nodes of `flexhrc ros2 cell|arm|human` called from Python.

The whole cell in this process: the manager on the main thread, the arm and the operator on
threads of their own, each on its own ROS 2 transport (its own context) in the test's domain.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

import pytest

from flexhrc import scenario as sc
from flexhrc.errors import FlexhrcError
from flexhrc.ros2 import (
    Ros2ArmConfig,
    Ros2CellConfig,
    Ros2HumanConfig,
    serve_ros2_arm,
    serve_ros2_cell,
    serve_ros2_human,
)

BALL_IN_BOX = Path(__file__).resolve().parents[2] / "examples" / "scenarios" / "ball_in_box.yaml"


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: Ros2CellConfig("table_assembly", realtime=float("nan")), "--realtime must be"),
        (lambda: Ros2CellConfig("table_assembly", wait=0), "--wait must be a positive"),
        (lambda: Ros2CellConfig("table_assembly", markers_rate=200), "--markers-rate must be"),
        (lambda: Ros2CellConfig("table_assembly", resume=True), "--resume needs --store"),
        (lambda: Ros2CellConfig("table_assembly", simulator="exact"), "--simulator 'exact'"),
        (lambda: Ros2ArmConfig("table_assembly", arm="left", rate=5), "--rate must be between"),
        (lambda: Ros2ArmConfig("table_assembly", arm="left", execute="real"), "--execute must"),
        (
            lambda: Ros2ArmConfig("table_assembly", arm="left", execute="external"),
            "--execute external needs --trajectory-topic",
        ),
        (lambda: Ros2ArmConfig("table_assembly", arm="left", tolerance=0), "--tolerance must"),
        (lambda: Ros2HumanConfig("table_assembly", name="human", profile="lazy"), "--profile"),
    ],
)
def test_a_bad_config_is_one_error_naming_the_option(make: Any, message: str):
    with pytest.raises(FlexhrcError, match=message):
        make()


@pytest.mark.parametrize(
    ("run", "message"),
    [
        (lambda: serve_ros2_arm(Ros2ArmConfig("table_assembly", arm="human")), "--arm 'human'"),
        (lambda: serve_ros2_human(Ros2HumanConfig("table_assembly", name="left")), "--name 'left'"),
        (lambda: serve_ros2_cell(Ros2CellConfig("table_assembly", cell="a-b")), "ROS 2 name"),
        (lambda: serve_ros2_cell(Ros2CellConfig("nowhere")), "unknown scenario 'nowhere'"),
    ],
)
def test_names_are_checked_before_a_node_joins(run: Any, message: str):
    with pytest.raises(FlexhrcError, match=message):
        run()


@pytest.mark.slow
def test_the_library_runs_a_whole_cell_in_one_process(domain_id: int, cell_name: str):
    common: dict[str, Any] = {
        "scenario": str(BALL_IN_BOX),
        "cell": cell_name,
        "domain_id": domain_id,
    }
    stop = threading.Event()  # ends the agents should the cell fail
    reports: dict[str, dict[str, Any]] = {}
    lines: list[str] = []

    def serve(name: str, run: Any, config: Any) -> None:
        reports[name] = run(config, progress=lines.append, until=stop.is_set)

    threads = [
        threading.Thread(target=serve, args=("left", serve_ros2_arm,
                                             Ros2ArmConfig(**common, arm="left"))),
        threading.Thread(target=serve, args=("human", serve_ros2_human,
                                             Ros2HumanConfig(**common, name="human"))),
    ]  # fmt: skip
    events: list[dict[str, Any]] = []
    for t in threads:
        t.start()
    try:
        data = serve_ros2_cell(
            Ros2CellConfig(**common, simulator="kinematic", wait=60.0),
            trace=events.append,
            progress=lines.append,
        )
    finally:
        stop.set()
        for t in threads:
            t.join(30)
    assert data["outcome"] == "solved", data.get("reason")
    # the cooperation of `flexhrc run` on the same model (the arm node executes on it)
    ref = sc.run(sc.load(str(BALL_IN_BOX)), seed=0, simulator="kinematic").summary
    pairs = [[(h["hyperarc"], h["agent"]) for h in d["solved_hyperarcs"]] for d in (data, ref)]
    assert pairs[0] == pairs[1]
    assert data["by_agent"] == ref["by_agent"]
    assert data["cell"]["events"] > 0 and any(ev["type"] == "command" for ev in events)
    assert any(f"cell {cell_name!r} on ROS 2 (domain {domain_id})" in line for line in lines)
    assert reports["left"]["outcome"] == reports["human"]["outcome"] == "solved"
    assert reports["left"]["executed"] and any(line.startswith("[left] ready") for line in lines)
