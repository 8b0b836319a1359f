"""The decision tree's kept groundings (ActionSchema.grounded) answer as grounding every
literal again would: same pruned branches, same reasons, same progressed facts (eq. 20)."""

from __future__ import annotations

import itertools

import pytest

from flexhrc import scenario
from flexhrc.logic import apply_substitution
from flexhrc.taskmanager import AnalyticSimulator, TaskManager
from flexhrc.taskmanager.decision import DecisionTree, holds, unmet_precondition
from flexhrc.taskmanager.domain import GroundAction


def reference(steps: list[GroundAction], facts: frozenset, from_index: int = 0) -> str | None:
    """unmet_precondition as it was written before the groundings were kept."""
    state = set(facts)
    for i, step in enumerate(steps):
        pre = [apply_substitution(lit, step.binding) for lit in step.schema.pre]
        if i >= from_index and pre and not holds(pre, state):
            bad = [x for x in pre if x.is_ground and (x.key() in state) == x.negated]
            bad = bad or [x for x in pre if not x.is_ground] or pre
            return f"pre({step}) does not hold: {' & '.join(str(x) for x in bad)}"
        for lit in step.schema.delete:
            state.discard(apply_substitution(lit, step.binding).key())
        for lit in step.schema.add:
            state.add(apply_substitution(lit, step.binding).key())
    return None


@pytest.mark.parametrize("name", scenario.SHIPPED)
def test_kept_groundings_answer_as_grounding_again(name):
    sc = scenario.load(name)
    kb = sc.world()
    tm = TaskManager(sc.online_graph(), sc.domain, kb, AnalyticSimulator())
    facts = kb.facts
    checked = 0
    for element in tm.graph.elements():
        if tm.graph.kind(element) != "hyperarc" or not tm.actions_of(element):
            continue
        tree = DecisionTree.build(
            element,
            tm.actions_of(element),
            [],  # every grounding of the objects' types: most of them fail a precondition
            sc.domain,
            kb,
            check_pre=False,
        )
        for b in tree.branches[:20]:
            for start in range(len(b.steps)):
                got = unmet_precondition(b.steps, facts, start)
                assert got == reference(b.steps, facts, start)
                checked += 1
            for pair in itertools.permutations(b.steps[:3], 2):  # effects of one, then the other
                assert unmet_precondition(list(pair), facts) == reference(list(pair), facts)
    assert checked > 10
