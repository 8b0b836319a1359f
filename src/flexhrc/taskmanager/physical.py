"""What an action does to the world besides its facts: the one place that says it.

An action's add/delete effects change the knowledge base's facts (eq. 20); its *physical* side —
where things are afterwards — comes from the action's kind (:mod:`flexhrc.taskmanager.kinds`),
whose default is the domain's declarative rule, not code: ``moves_to: ?p`` is where the hand
goes, ``carries: ?o`` makes ``?o`` travel with the hand (or to the ``moves_to`` place),
``fixes: ?o`` fixes ``?o`` in place. The engine applies it once per finished action, whoever did
it, so every front end sees the same world.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.kinds import declared_effect, kind_of


def apply_physical(
    kb: KnowledgeBase,
    domain: Domain,
    action: GroundAction,
    positions: Mapping[str, Any],
) -> str | None:
    """Apply the physical side of a finished ``action`` to ``kb``; ``positions`` are where the
    agent's report says things are now (a hand, a moved part). Returns the object the action
    fixed in place, if any."""
    effect = kind_of(action.schema).effect or declared_effect
    return effect(kb, domain, action, positions)
