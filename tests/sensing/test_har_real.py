"""Human action recognition from real HMP data in the loop (issue 13, item 5).

Reads ../shared/datasets/hmp in place (or $FLEXHRC_HMP) and skips when it is absent.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

pytest.importorskip("sklearn")
pytest.importorskip("scipy")
pytest.importorskip("pybullet")

from flexhrc.sensing.har_real import HMP_PROXIES, TRAIN_VOLUNTEERS, HmpReplaySensor

from ..conftest import subprocess_env
from .test_loop import run_table


@pytest.fixture(scope="module")
def sensor(hmp):
    return HmpReplaySensor(hmp, seed=0)


def test_replayed_volunteers_are_not_those_the_model_was_trained_on(sensor):
    assert sensor.train_volunteers == sorted(TRAIN_VOLUNTEERS)
    assert sensor.replay_volunteers and not set(sensor.replay_volunteers) & set(TRAIN_VOLUNTEERS)
    assert set(sensor.model.classes_) == set(HMP_PROXIES.values())
    for action in ("pick_up", "screw", "pick_up"):
        sensed = sensor.sense(action)
        assert sensed.performed == action and sensed.samples > 32
    replayed = [r["trial"] for r in sensor.replayed]
    assert all(t.split("-")[-1].removesuffix(".txt") not in TRAIN_VOLUNTEERS for t in replayed)
    assert sensor.sense("put_down").recognised is None  # no HMP motion plays it


def test_held_out_trials_are_mostly_recognised(sensor):
    hits = sum(sensor.sense(a).recognised == a for a in ("pick_up", "screw") * 6)
    assert hits >= 8  # out-of-sample: not all, but most


@pytest.mark.slow
@pytest.mark.parametrize("profile", ["takeover", "cooperative"])
def test_cooperation_with_real_wrist_signals_ends_and_reports_figures(sensor, profile):
    for seed in range(3):
        result, _run, _ = run_table(profile, seed, human_sensing=sensor)
        assert result.outcome in ("solved", "failed")
        if result.outcome == "failed":
            assert result.reason  # never silently, never waiting for ever
        hs = result.summary["human_sensing"]
        assert hs["performed"] == hs["recognised"] + hs["missed"] + hs["false_reports"]
        assert hs["performed"] > 0


def test_a_miss_is_a_miss():
    class Deaf:
        def sense(self, action):
            from flexhrc.perception.human.sensing import Sensed

            return Sensed(action, None, None, 0.0, 100, 0.0)

    result, run, _ = run_table("takeover", 0, human_sensing=Deaf())
    # the manager is never told: every report the cell stored says nothing was recognised,
    # and the manager recognised no human action
    reports = [e.body for e in run.cell.events if e.kind == "human_action"]
    assert reports and all(b["recognised"] is False for b in reports)
    assert not [e for e in result.events if e["type"] == "recognised"]
    hs = result.summary["human_sensing"]
    assert hs["missed"] == hs["performed"] > 0 and hs["recognised"] == 0
    assert result.outcome in ("solved", "failed") and (result.outcome == "solved" or result.reason)


def test_cli_har_real(hmp):
    out = subprocess.run(
        [
            sys.executable, "-m", "flexhrc", "demo", "table", "--perception", "scene",
            "--simulator", "analytic", "--human", "takeover", "--human-sensing", "har-real",
            "--hmp", str(hmp), "--json", "--quiet",
        ],
        capture_output=True, text=True, env=subprocess_env(), timeout=900,
    )  # fmt: skip
    assert out.returncode in (0, 1), out.stderr
    data = json.loads(out.stdout)
    assert data["outcome"] in ("solved", "failed") and (
        data["outcome"] == "solved" or data["reason"]
    )
    hs = data["human_sensing"]
    assert set(hs) >= {"performed", "recognised", "missed", "false_reports"}
    assert hs["mode"] == "har-real" and hs["performed"] > 0
