"""``--policy lookahead``: runs finish, beat or match paper, replay and resume identically;
``paper`` (the default) is the run it always was."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.scenario import load_scenario, prepare

pytest.importorskip("ortools")
import flexhrc.planning  # noqa: F401  (registers the lookahead policy)

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted(str(p) for p in (ROOT / "examples" / "scenarios").glob("*.yaml"))
TWO_JOBS = ROOT / "tests" / "data" / "planning" / "two_jobs.yaml"


def _log(name: Any, **kw: Any) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    result = prepare(load_scenario(name), simulator="analytic", **kw).run()
    events = [e for e in result.events if e["type"] != "summary"]
    return events, result.summary


@pytest.mark.parametrize("name", [*SHIPPED, "table_assembly"])
@pytest.mark.parametrize("profile", ["passive", "takeover"])
def test_lookahead_runs_finish_and_replay_identically(name, profile):
    a, summary = _log(name, policy="lookahead", profile=profile, seed=3)
    b, _ = _log(name, policy="lookahead", profile=profile, seed=3)
    assert summary["outcome"] == "solved"
    assert a == b  # deterministic: solver time counted deterministically, one worker, a seed
    assert a[0]["policy"] == "lookahead" and summary["policy"] == "lookahead"
    assert summary["advice_s"]["decisions"] >= 1


def test_lookahead_finds_the_hand_optimum_that_paper_misses():
    _, paper = _log(TWO_JOBS)
    _, ahead = _log(TWO_JOBS, policy="lookahead")
    assert paper["timing"]["total_s"] == pytest.approx(6.0)
    assert ahead["timing"]["total_s"] == pytest.approx(5.0)  # the optimum (test_plan.py)


def test_paper_is_the_default_and_unchanged():
    default, summary = _log("examples/scenarios/gearbox.yaml", profile="takeover", seed=2)
    paper, _ = _log("examples/scenarios/gearbox.yaml", profile="takeover", seed=2, policy="paper")
    assert default == paper
    assert "policy" not in default[0] and "policy" not in summary and "advice_s" not in summary


def test_the_scenario_key_policy_is_the_default_a_run_overrides():
    from dataclasses import replace

    sc = replace(load_scenario(TWO_JOBS), policy="lookahead")
    result = prepare(sc, simulator="analytic").run()
    assert result.summary["policy"] == "lookahead"
    result = prepare(sc, simulator="analytic", policy="paper").run()
    assert "policy" not in result.summary


@pytest.mark.parametrize("crash_after", [5, 12])
def test_a_resumed_lookahead_cell_ends_like_the_uninterrupted_run(tmp_path, crash_after):
    """The stored start keeps the policy: a cell resumed without --policy goes on deciding by
    lookahead and ends where the uninterrupted run ends."""
    from flexhrc.cell import Cell, EventStore
    from flexhrc.cell.components import execution_model
    from flexhrc.transport import InProcessBus

    from ..cell.helpers import Crash, pump_of, simulated_agents

    scenario = load_scenario("examples/scenarios/gearbox.yaml")

    def cell(bus: Any, **kw: Any) -> Any:
        return Cell(scenario, bus, liveliness=False, simulator=execution_model("analytic"), **kw)

    bus = InProcessBus()
    ref_cell = cell(bus, policy="lookahead")
    ref = ref_cell.run(pump=pump_of(ref_cell, bus, simulated_agents(scenario, bus)))
    path = tmp_path / "s.db"
    store = EventStore(path)
    bus = InProcessBus()
    first = cell(bus, store=store, policy="lookahead")
    with pytest.raises(Crash):
        first.run(pump=pump_of(first, bus, simulated_agents(scenario, bus), crash_after))
    store.close()
    store = EventStore(path, resume=True)
    bus = InProcessBus()
    again = cell(bus, store=store, resume=True)  # no policy given: the stored one
    data = again.run(pump=pump_of(again, bus, simulated_agents(scenario, bus)))
    store.close()
    assert again.policy == "lookahead" and data["policy"] == "lookahead"
    assert data["outcome"] == "solved" and data["cell"]["resumed"]
    assert data["timing"]["total_s"] == ref["timing"]["total_s"]
    assert data["knowledge"] == ref["knowledge"]
    assert data["solved_hyperarcs"] == ref["solved_hyperarcs"]


@pytest.mark.parametrize("seed", [0, 1])
def test_lookahead_plans_a_hierarchy_through_its_lower_instances(seed):
    """kitchen_drawer (three graph layers): lookahead follows the plan of the expanded
    hierarchy — its own decisions, to the goal, no slower than paper's, replayed identically."""
    _, paper = _log("kitchen_drawer", seed=seed)
    ahead, summary = _log("kitchen_drawer", seed=seed, policy="lookahead")
    again, _ = _log("kitchen_drawer", seed=seed, policy="lookahead")
    assert summary["outcome"] == "solved" and summary["advice_s"]["decisions"] >= 1
    assert ahead == again
    assert summary["by_agent"] != paper["by_agent"]  # its own allocation, not paper's
    assert summary["timing"]["total_s"] <= paper["timing"]["total_s"]


@pytest.mark.parametrize("seed", [0, 1])
def test_a_hold_stopped_as_its_arm_finishes_ends_once_in_the_stored_log(tmp_path, seed):
    """On the gearbox, lookahead's timing stops the left arm's ``hold`` (a process) at the very
    instant its arm acknowledges it: the manager ignores that ack, and the store read as a log
    used to end the command twice, so ``flexhrc replay STORE`` (and ``--fork-at``) refused it."""
    from flexhrc.cell.replay import replay
    from flexhrc.cell.serve import CellConfig, serve_cell
    from flexhrc.cell.store import store_log

    path = tmp_path / "gearbox.db"
    config = CellConfig(store=path, policy="lookahead", seed=seed)
    scenario = load_scenario(str(ROOT / "examples" / "scenarios" / "gearbox.yaml"))
    assert serve_cell(scenario, config)["outcome"] == "solved"
    log = store_log(path)
    assert any(ev["type"] == "ack_ignored" for ev in log)  # the case happened
    ends = [ev["command"] for ev in log if ev["type"] == "action_end" and "command" in ev]
    commands = [ev["id"] for ev in log if ev["type"] == "command"]
    assert sorted(ends) == sorted(commands)  # every command ended exactly once
    assert replay(path).json["outcome"] == "solved"
