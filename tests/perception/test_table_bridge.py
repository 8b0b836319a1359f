"""Issue 6 bridge: a human action recognised from a synthesised wrist signal drives the Task
Manager exactly as if it had been injected."""

from __future__ import annotations

import pytest

pytest.importorskip("sklearn")
pytest.importorskip("scipy")

from flexhrc.perception.human.sensing import WearableHumanSensor, train_toy_model

from ..taskmanager.helpers import run_table, solved

DECISIONS = ("decision", "command", "suggestion", "recognised", "abort", "solved", "outcome")


@pytest.fixture(scope="module")
def model():
    return train_toy_model(seed=0)


def trace(result):
    keep = []
    for e in result.events:
        if e["type"] in DECISIONS:
            keep.append({k: v for k, v in e.items() if k not in ("branches",)})
    return keep


@pytest.mark.parametrize(
    ("profile", "run_kw"),
    [("passive", {"human_takes": [2, 4]}), ("takeover", {})],
)
def test_recognised_actions_drive_the_manager_like_injected_ones(model, profile, run_kw):
    injected, _ = run_table(profile, run_kw=dict(run_kw))
    sensor = WearableHumanSensor(model, seed=3)
    sensed, _ = run_table(profile, run_kw={**run_kw, "human_sensing": sensor})
    assert sensed.outcome == injected.outcome == "solved"
    assert solved(sensed) == solved(injected)
    assert trace(sensed) == trace(injected)  # same decisions, commands and times
    readings = [e for e in sensed.events if e["type"] == "human_sensed"]
    assert readings and all(e["recognised"] == e["performed"] for e in readings)
    assert {e["performed"] for e in readings} == {"pick_up", "screw"}
    assert all(e["samples"] > 32 for e in readings)  # > 1 s of signal at 32 Hz


def test_sensor_reports_nothing_for_unknown_motions(model):
    sensor = WearableHumanSensor(model, mapping={"pick_up": "pick_up"}, seed=0)
    assert sensor.sense("screw").recognised is None
    assert sensor.sense("pick_up").recognised == "pick_up"


def test_cli_human_sensing_har(capsys):
    import json

    from flexhrc.cli import main

    code = main(
        [
            "demo",
            "table",
            "--simulator",
            "analytic",
            "--human-sensing",
            "har",
            "--human-takes",
            "1",
            "--json",
            "--quiet",
        ]
    )
    data = json.loads(capsys.readouterr().out)
    assert code == 0 and data["outcome"] == "solved" and data["legs_by_agent"]["human"] == 1
