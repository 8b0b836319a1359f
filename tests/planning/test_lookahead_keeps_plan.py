"""``lookahead`` keeps its plan while the cell follows it (a re-solve only on a deviation) and
plans the hands' travel where every agent has few branches (issue 23, quality and latency)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from flexhrc.scenario import load_scenario, prepare
from flexhrc.scenario.generate import generate

pytest.importorskip("ortools")
from flexhrc.planning import LookaheadPolicy

ROOT = Path(__file__).resolve().parents[2]
GEARBOX = str(ROOT / "examples" / "scenarios" / "gearbox.yaml")
LID = str(ROOT / "examples" / "scenarios" / "lid_task.yaml")


def _run(name: str, profile: str = "passive", seed: int = 0, **kw: Any) -> tuple[Any, Any]:
    run = prepare(load_scenario(name), simulator="analytic", policy="lookahead",
                  profile=profile, seed=seed)  # fmt: skip
    if kw:
        run.cell.tm.policy = LookaheadPolicy(**kw)
    result = run.run()
    assert result.summary["outcome"] == "solved"
    return result.summary, run.cell.tm.policy


@pytest.mark.parametrize("name", [LID, "generated"])
def test_a_passive_run_is_solved_once_and_follows_that_plan(name, tmp_path):
    if name == "generated":
        path = tmp_path / "generated.yaml"
        path.write_text(generate(actions=20, agents=6, width=4, seed=0))
        name = str(path)
    summary, advisor = _run(name)
    assert advisor.solves == 1 and advisor.fallbacks == 0
    assert advisor.reused >= 1  # later decisions keep the plan: no re-solve
    assert summary["advice_s"]["decisions"] == advisor.solves + advisor.reused


def test_a_person_deviating_from_the_plan_makes_it_solved_again():
    _, passive = _run(GEARBOX, "passive")
    _, takeover = _run(GEARBOX, "takeover")  # acts on their own: not what the plan said
    assert takeover.solves > passive.solves


def test_travel_is_planned_on_small_tasks_and_shortens_the_gearbox():
    with_travel, a = _run(GEARBOX)
    without, b = _run(GEARBOX, travel=False)
    assert a.task.setup and not b.task.setup
    # each agent's hyper-arcs ordered by where the last one left the hand (plan --travel)
    assert with_travel["timing"]["total_s"] < without["timing"]["total_s"]
    assert with_travel["timing"]["total_s"] == pytest.approx(23.716, abs=1e-3)


def test_a_task_with_many_branches_per_agent_is_planned_without_travel():
    _, advisor = _run("table_assembly")  # 50 branches per arm: beyond MAX_CIRCUIT
    assert not advisor.task.setup


@pytest.mark.parametrize("name", ["parallel_assembly", "generated"])
def test_no_passive_run_beats_the_travel_bound_beyond_max_circuit(name, tmp_path):
    # agents with more than MAX_CIRCUIT branches (parallel_assembly's operators: 12): each
    # branch as short as travel from the end of a branch of *another* hyper-arc makes it
    from flexhrc.planning import solve

    if name == "generated":
        path = tmp_path / "generated.yaml"
        path.write_text(generate(actions=20, agents=6, width=4, seed=1))
        name = str(path)
    bound = solve(load_scenario(name), time_limit_s=20, travel=True)
    assert bound.status == "optimal" and bound.makespan_s is not None
    slack = 0.0005 * len(bound.schedule)  # whole milliseconds in the model
    for policy in ("paper", "lookahead"):
        run = prepare(load_scenario(name), profile="passive", seed=0, policy=policy)
        total = run.run().summary["timing"]["total_s"]
        assert total >= bound.makespan_s - slack, (policy, total, bound.makespan_s)
