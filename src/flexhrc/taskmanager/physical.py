"""What an action does to the world besides its facts: the one place that says it.

An action's add/delete effects change the knowledge base's facts (eq. 20); its *physical* side —
where things are afterwards — comes from the domain, not from code: ``moves_to: ?p`` is where
the hand goes, ``carries: ?o`` makes ``?o`` travel with the hand (or to the ``moves_to`` place),
``fixes: ?o`` fixes ``?o`` in place. The engine applies it once per finished action, whoever did
it, so every front end sees the same world.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Domain, GroundAction


def apply_physical(
    kb: KnowledgeBase,
    domain: Domain,
    action: GroundAction,
    positions: Mapping[str, Any],
) -> str | None:
    """Apply the physical side of a finished ``action`` to ``kb``; ``positions`` are where the
    agent's report says things are now (a hand, a moved part). Returns the object the action
    fixed in place, if any."""
    schema, binding = action.schema, action.binding
    where = None
    if schema.moves_to and binding.get(schema.moves_to) in kb.objects:
        where = kb.position(binding[schema.moves_to])
    for agent in action.agents:
        if agent in positions and agent in kb.objects and domain.agent(agent).is_human:
            kb.move(agent, positions[agent])
    carried = binding.get(schema.carries) if schema.carries else None
    if carried in kb.objects and not kb.object(carried).fixed:
        hand = positions.get(action.agents[0]) if action.agents else None
        if hand is None and action.agents and action.agents[0] in kb.objects:
            hand = kb.position(action.agents[0])
        target = where or hand
        if target is not None:
            kb.move(carried, target)
    fixed = binding.get(schema.fixes) if schema.fixes else None
    if fixed in kb.objects:
        kb.set_fixed(fixed)
        return str(fixed)
    return None
