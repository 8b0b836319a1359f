"""Operators that decide for themselves on any task (issue 22, item 3): ``takeover`` takes
every step it may do before being asked, ``passive`` only what it is asked, ``reluctant``
declines and cannot — defined against the graph and the domain alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from flexhrc import scenario
from flexhrc.scenario.run import run
from flexhrc.taskmanager.domain import GroundAction
from flexhrc.taskmanager.operator import SimulatedOperator

ROOT = Path(__file__).resolve().parents[2]
TASKS = [*scenario.SHIPPED, *sorted(str(p) for p in (ROOT / "examples/scenarios").glob("*.yaml"))]
SEEDS = range(10)


def _persons_hyperarcs(name: str, profile: str) -> tuple[int, set[str]]:
    """Hyper-arcs solved by a person over the seeds, and the outcomes."""
    sc = scenario.load(name)
    humans = {h.name for h in sc.humans}
    total, outcomes = 0, set()
    for seed in SEEDS:
        summary = run(sc, profile=profile, seed=seed).summary
        outcomes.add(summary["outcome"])
        total += sum(1 for s in summary["solved_hyperarcs"] if set(s["agent"].split("+")) & humans)
    return total, outcomes


@pytest.mark.parametrize("name", TASKS, ids=lambda n: Path(n).stem)
def test_takeover_gives_the_person_more_hyperarcs_than_passive(name):
    passive, p_out = _persons_hyperarcs(name, "passive")
    takeover, t_out = _persons_hyperarcs(name, "takeover")
    assert p_out == t_out == {"solved"}
    assert takeover > passive, (takeover, passive)


@pytest.mark.parametrize("name", TASKS, ids=lambda n: Path(n).stem)
def test_reluctant_declines_are_handled_with_the_cooperation_solved(name):
    sc = scenario.load(name)
    replies: set[str] = set()
    asked = 0
    for seed in SEEDS:
        result = run(sc, profile="reluctant", seed=seed)
        assert result.summary["outcome"] == "solved", (seed, result.summary["reason"])
        replies |= {e["reply"] for e in result.events if e["type"] == "human_declined"}
        asked += sum(e["type"] == "suggestion" for e in result.events)
    # a task that asks the person anything over 10 seeds gets some of it declined
    # (table_two_arms and the example ball_in_box never need the person)
    assert bool(replies & {"decline", "cannot"}) == (asked > 0), (asked, replies)


def _lid() -> scenario.Scenario:
    return scenario.load(str(ROOT / "examples/scenarios/lid_task.yaml"))


def test_reluctant_cannot_only_what_an_arm_may_do_too():
    domain = _lid().domain
    # carry: a person or an arm; drive: a person only (never 'cannot': the task stays solvable)
    for seed in range(20):
        op = SimulatedOperator("human", "reluctant", seed)
        assert op.cannot_do(domain) == {"carry"}
    assert SimulatedOperator("human", "takeover").cannot_do(domain) == frozenset()
    carry = GroundAction(domain.actions["carry"], ("human", "lid", "box"), ("human",))
    drive = GroundAction(domain.actions["drive"], ("human", "screw_a"), ("human",))
    op = SimulatedOperator("human", "reluctant", 0)
    assert op.answer([carry], domain) == ("cannot", "human cannot carry")
    # drive is declined about decline_share of the time, the same way for one seed
    answers = [op.answer([drive], domain)[0] for _ in range(200)]
    assert set(answers) == {"follow", "decline"}
    assert 0.2 < answers.count("decline") / 200 < 0.4
    again = SimulatedOperator("human", "reluctant", 0)
    again.answer([carry], domain)  # a 'cannot' draws nothing
    assert [again.answer([drive], domain)[0] for _ in range(200)] == answers
    for profile in ("passive", "takeover", "cooperative", "random"):
        assert SimulatedOperator("human", profile).answer([drive], domain) == ("follow", None)


def test_reluctant_never_acts_on_its_own_and_random_is_seeded():
    arcs = [(1.0, "h1"), (2.0, "h2")]
    assert SimulatedOperator("human", "reluctant", 3).decide("n1", arcs) is None
    assert SimulatedOperator("human", "passive", 3).decide("n1", arcs) is None
    taken = SimulatedOperator("human", "takeover", 3).decide("n1", arcs)
    assert taken is not None and (taken.hyperarc, taken.delay_s) == ("h1", 0.0)

    def draws(seed: int) -> list[object]:
        op = SimulatedOperator("human", "random", seed)
        return [op.decide(f"n{k}", arcs) for k in range(20)]

    assert draws(5) == draws(5)
    assert draws(5) != draws(6)
