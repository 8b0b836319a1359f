"""``--policy paper|lookahead`` and the scenario key ``policy:`` reach the one engine."""

from __future__ import annotations

import pytest

from flexhrc.app import RunConfig
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError
from flexhrc.scenario import load

from ..scenario.helpers import base, line_of, write


def test_the_scenario_key_policy_is_read_and_checked_at_its_line(tmp_path, capsys):
    doc = base()
    doc["policy"] = "lookahead"
    assert load(write(tmp_path, doc)).policy == "lookahead"
    doc["policy"] = "greedy"
    path = write(tmp_path, doc)
    assert main(["scenario", "validate", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"{path}:{line_of(path, 'policy: greedy')}: policy 'greedy': choose one of paper, lookahead"
    ]


def test_run_config_checks_the_policy() -> None:
    assert RunConfig(policy="lookahead").policy == "lookahead"
    with pytest.raises(FlexhrcError, match="--policy 'x': choose one of paper, lookahead"):
        RunConfig(policy="x")


def test_a_bad_policy_on_the_command_line_exits_2(capsys) -> None:
    assert main(["run", "table_assembly", "--policy", "greedy"]) == 2
    assert "--policy" in capsys.readouterr().err
