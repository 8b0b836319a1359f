"""What the wrist sensor senses and what it says of what it does not (issue 21, item 11): the
HMP stand-ins are the documented ones; ``put_down`` is sensed by the synthetic model, and an
action no motion plays (``check``; ``put_down`` with HMP) is taken as reported, with the reason
in the sensed record and the live trace — not "check -> recognised None"."""

from __future__ import annotations

import re
import subprocess
import sys

import pytest

pytest.importorskip("sklearn")
pytest.importorskip("scipy")

from flexhrc.app.run import trace_line
from flexhrc.perception.human.sensing import WearableHumanSensor
from flexhrc.sensing.har_real import HMP_PROXIES, HmpReplaySensor

from ..conftest import subprocess_env
from .conftest import REPO

NO_MODEL = "check: no wrist model, taken as reported"


@pytest.fixture(scope="module")
def wearable() -> WearableHumanSensor:
    return WearableHumanSensor(seed=0)


def test_the_synthetic_wrist_model_senses_put_down_and_says_why_it_does_not_sense_check(
    wearable,
):
    put = wearable.sense("put_down")
    assert put.recognised == "put_down" and put.samples > 0 and put.why is None
    assert "why" not in put.to_dict()  # a sensed action's figures keep their shape
    check = wearable.sense("check")
    assert (check.recognised, check.samples, check.why) == (None, 0, NO_MODEL)
    assert check.to_dict()["why"] == NO_MODEL


def test_hmp_stand_ins_are_the_documented_ones_and_the_others_are_taken_as_reported(hmp):
    docs = (REPO / "docs" / "perception.md").read_text()
    rows = dict(re.findall(r"^\| `(\w+)` \| \*(\w+)\* \|", docs, flags=re.M))
    assert rows == HMP_PROXIES == {"pick_up": "drink_glass", "screw": "pour_water"}
    for action in ("put_down", "check"):
        assert re.search(rf"^\| `{action}` \| — \(not sensed\) \|", docs, flags=re.M)
    sensor = HmpReplaySensor(hmp, seed=0)
    for action in ("put_down", "check"):
        sensed = sensor.sense(action)
        assert sensed.recognised is None and sensed.samples == 0
        assert sensed.why == (
            f"{action}: no wrist model, taken as reported (no HMP motion stands for it)"
        )


def test_the_trace_says_why_an_action_is_not_sensed():
    uncovered = {"t": 60.59, "type": "human_sensed", "performed": "check", "recognised": None,
                 "motion": None, "confidence": 0.0, "samples": 0, "latency_s": 0.0,
                 "why": NO_MODEL}  # fmt: skip
    assert trace_line(uncovered) == f"  60.59s  wrist sensor: {NO_MODEL}"
    missed = {**uncovered, "performed": "pick_up", "samples": 705}
    del missed["why"]
    assert (
        trace_line(missed) == "  60.59s  wrist sensor: pick_up -> recognised nothing (705 samples)"
    )
    sensed = {**missed, "recognised": "pick_up", "confidence": 0.6}
    assert trace_line(sensed) == (
        "  60.59s  wrist sensor: pick_up -> recognised pick_up (confidence 0.60, 705 samples)"
    )


@pytest.mark.parametrize("mode", ["har", "har-real"])
def test_the_in_loop_demo_says_why_check_is_not_sensed(mode, request):
    args = ["--human-sensing", mode]
    if mode == "har-real":  # (skipped without the dataset; the synthetic model needs none)
        args += ["--hmp", str(request.getfixturevalue("hmp"))]
    res = subprocess.run(
        [sys.executable, "-m", "flexhrc", "demo", "table", *args],
        capture_output=True,
        text=True,
        env=subprocess_env(),
        timeout=300,
    )
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "recognised None" not in out
    lines = [ln for ln in out.splitlines() if "wrist sensor: check" in ln]
    assert len(lines) == 4  # the operator checks the four connections (Fig. 13)
    assert all(NO_MODEL in ln for ln in lines), lines
    assert "outcome: SOLVED" in out
