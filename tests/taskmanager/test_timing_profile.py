"""Table I made comparable: the ``paper`` timing profile (issue 21, item 8).

The profile is configured once (``flexhrc.taskmanager.kinds.TIMINGS``, chosen by
``choose_simulator``, a scenario's ``timing:`` key or :class:`RunConfig.timing`); the CLI's
``--timing`` only translates. Every figure checked here is on the simulated clock (deterministic),
never the wall clock.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from flexhrc.app import RunConfig, TableDemo, run_scenario
from flexhrc.cli import main
from flexhrc.errors import FlexhrcError, FormatError
from flexhrc.scenario import load_scenario
from flexhrc.scenario.simulators import choose_simulator
from flexhrc.taskmanager.kinds import PAPER_TIMING, Timing, timing_profile
from flexhrc.taskmanager.replay import PAPER_TABLE_I

REPO = Path(__file__).resolve().parents[2]


def _run(timing: str | None, simulator: str = "analytic") -> dict:
    report = run_scenario(
        RunConfig(TableDemo(), simulator=simulator, timing=timing, quiet=True, seed=0)
    )
    assert report.result.outcome == "solved"
    return {"json": report.json, "text": report.text}


def test_profiles_by_name() -> None:
    assert timing_profile("default") == Timing()
    paper = timing_profile("paper")
    assert paper == PAPER_TIMING
    assert paper.joint_speed_limit == 0.6  # the paper's Baxter, §VII-C
    assert paper.robot_speed == 0.4
    assert timing_profile("paper") is not timing_profile("paper")  # a copy each time
    with pytest.raises(FlexhrcError, match="unknown timing 'fast'; choose one of default, paper"):
        timing_profile("fast")
    name, sim = choose_simulator("analytic", timing="paper")
    assert name == "analytic" and sim.timing == PAPER_TIMING


def test_paper_timing_sets_the_table_beside_table_i() -> None:
    """The default 4-leg table under the paper's timing simulates about the paper's robot and
    human totals; the default timing is today's (~5x quicker robot), and keeps its JSON."""
    default = _run(None)
    paper = _run("paper")
    assert "timing_profile" not in default["json"]
    assert paper["json"]["timing_profile"] == "paper"
    t, t0 = paper["json"]["timing"], default["json"]["timing"]
    assert t["robot_actions_s"] == pytest.approx(PAPER_TABLE_I["robot_actions_s"], rel=0.15)
    assert t["human_actions_s"] == pytest.approx(PAPER_TABLE_I["human_actions_s"], rel=0.15)
    assert t0["robot_actions_s"] < PAPER_TABLE_I["robot_actions_s"] / 3
    # the same decisions, only slower: the profile times actions, it does not choose them
    assert paper["json"]["robot_actions"] == default["json"]["robot_actions"]
    assert "Table I beside the paper (analytic simulator, paper timing)" in paper["text"]
    row = next(line for line in paper["text"].splitlines() if "Robot actions" in line)
    assert row.split()[-1] == "219.45"
    assert "Table I beside the paper" not in default["text"]


@pytest.mark.skipif(
    importlib.util.find_spec("pinocchio") is None, reason="needs the sim extra (pinocchio)"
)
def test_paper_timing_on_the_kinematic_simulator() -> None:
    """The default simulator: joints capped at the Baxter's 0.6 rad/s plus the calibrated
    per-action time land the robot's total near 219 s, the operator's near 26 s."""
    paper = _run("paper", simulator="kinematic")["json"]
    assert paper["simulator"] == "kinematic"
    t = paper["timing"]
    assert t["robot_actions_s"] == pytest.approx(PAPER_TABLE_I["robot_actions_s"], rel=0.1)
    assert t["human_actions_s"] == pytest.approx(PAPER_TABLE_I["human_actions_s"], rel=0.1)


@pytest.mark.skipif(
    importlib.util.find_spec("pinocchio") is None, reason="needs the sim extra (pinocchio)"
)
def test_joint_speed_limit_slows_the_kinematic_model() -> None:
    from flexhrc.action.simulator import KinematicSimulator

    target = (0.55, -0.25, 0.10)
    fast = KinematicSimulator(cache_size=0).simulate("right", "approach", target)
    slow = KinematicSimulator(cache_size=0, joint_speed_limit=0.6).simulate(
        "right", "approach", target
    )
    assert fast.success and slow.success
    assert slow.duration_s > fast.duration_s
    with pytest.raises(FlexhrcError, match="joint_speed_limit must be positive"):
        KinematicSimulator(joint_speed_limit=0.0)


def test_scenario_key_timing(tmp_path: Path) -> None:
    src = (REPO / "examples" / "scenarios" / "lid_task.yaml").read_text()
    assert "\nsimulator: analytic" in src
    good = tmp_path / "lid_paper.yaml"
    good.write_text(src.replace("\nsimulator: analytic", "\nsimulator: analytic\ntiming: paper"))
    sc = load_scenario(good)
    assert sc.timing == "paper"
    assert sc.make_simulator().timing == PAPER_TIMING
    assert load_scenario(REPO / "examples" / "scenarios" / "lid_task.yaml").timing == "default"
    bad = tmp_path / "lid_bad.yaml"
    text = src.replace("\nsimulator: analytic", "\nsimulator: analytic\ntiming: fast")
    bad.write_text(text)
    line = text.splitlines().index("timing: fast") + 1
    with pytest.raises(FormatError, match=rf"lid_bad.yaml:{line}: timing 'fast': choose one of"):
        load_scenario(bad)


def test_cli_translates_timing(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["demo", "table", "--simulator", "analytic", "--timing", "paper", "--json"])
    assert code == 0
    out = capsys.readouterr().out
    doc = json.loads(out)
    assert doc["timing_profile"] == "paper"
    assert doc["timing"]["robot_actions_s"] == pytest.approx(
        _run("paper")["json"]["timing"]["robot_actions_s"]
    )
    assert main(["demo", "table", "--timing", "fast"]) == 2
    assert "argument --timing: invalid choice: 'fast'" in capsys.readouterr().err
