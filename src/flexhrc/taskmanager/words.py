"""Plain words for the person at the workbench: what an action asks them (or an arm) to do.

The panel's operator view and the station speak to a person, not to an engineer: instead of
``screw(human, leg3, bolt_1)`` it says "Screw leg 3 to bolt 1". A scenario gives the words of an
action with ``text:`` (``"Screw {?leg} to {?bolt}"``: each ``{?var}`` is replaced by the readable
name of the object bound to that parameter); without it the words are made from the action's
name and its objects ("Screw leg 3, bolt 1"), leaving out the agents themselves — the person
knows who they are.
"""

from __future__ import annotations

import re
from collections.abc import Collection

from flexhrc.taskmanager.domain import TEXT_PLACEHOLDER, GroundAction, placeholders

_DIGITS = re.compile(r"(?<=[A-Za-z])(?=\d)")


def readable(name: str) -> str:
    """A constant as a person reads it: ``bolt_1`` -> ``bolt 1``, ``leg3`` -> ``leg 3``."""
    spaced = _DIGITS.sub(" ", name.replace("_", " ").replace("-", " "))
    return " ".join(spaced.split())


def plain_words(action: GroundAction, agents: Collection[str] = ()) -> str:
    """The words of one ground action for a person: its ``text:`` with the objects filled in,
    or its name and objects. ``agents`` are the cell's agent names, left out of the fallback
    (the acting agents of ``action`` always are)."""
    binding = action.binding
    text = action.schema.text
    if text:
        return TEXT_PLACEHOLDER.sub(lambda m: readable(binding.get(m.group(1), m.group(1))), text)
    skip = set(agents) | set(action.agents)
    objects = [readable(a) for a in action.args if a not in skip]
    verb = readable(action.schema.name)
    verb = verb[:1].upper() + verb[1:]
    return f"{verb} {', '.join(objects)}" if objects else verb


__all__ = ["placeholders", "plain_words", "readable"]
