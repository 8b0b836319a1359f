"""``flexhrc.action.api.simulate_action`` equals ``flexhrc sim --json`` for the same arguments
(less the wall-clock timings), and says which ``after`` action failed."""

from __future__ import annotations

import json

import pytest

from flexhrc.action.api import simulate_action
from flexhrc.action.control import Sphere
from flexhrc.action.simulator import Pose
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError

TIMINGS = ("wall_s", "real_time_factor", "total_wall_s")


def _untimed(report: dict) -> dict:
    return {k: v for k, v in report.items() if k not in TIMINGS}


def test_simulate_action_equals_flexhrc_sim(capsys):
    target = Pose((0.45, 0.1, 0.3), 0.0)
    report, outcome = simulate_action(
        "transport", "both", target, after=["approach", "grasp"],
        after_target=Pose((0.5, 0.0, 0.1), 0.0), obstacles=[Sphere((0.2, 0.5, 0.6), 0.05)],
    )  # fmt: skip
    assert main(["sim", "transport", "--arm", "both", "--target", "0.45", "0.1", "0.3",
                 "--after", "approach", "--after", "grasp", "--from", "0.5", "0", "0.1",
                 "--obstacle", "0.2", "0.5", "0.6", "0.05", "--json"]) == 0  # fmt: skip
    assert _untimed(report) == _untimed(json.loads(capsys.readouterr().out))
    assert outcome.success and [a["action"] for a in report["after"]] == ["approach", "grasp"]


def test_a_failing_after_action_is_named():
    with pytest.raises(FlexhrcError, match="--after approach failed"):
        simulate_action("grasp", "left", Pose((1.5, 0.0, 0.1), 0.0), after=["approach"])
