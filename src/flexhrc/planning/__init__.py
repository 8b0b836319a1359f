"""Planning ahead: the optimal cooperation path, allocation and schedule of a task (issue 23).

:func:`solve` models one scenario with OR-tools CP-SAT (the ``plan`` extra, imported when a
solve runs) and answers a :class:`Plan` — the alternatives of the AND/OR graph taken, the agent
of every action and its start time, the objective, the solver's proven bound and status.
:func:`solve_remaining` solves what is left of a task at a decision of a running Task Manager
(the ``lookahead`` policy, :mod:`flexhrc.planning.policies`, registered when this package is
imported); :func:`hindsight` solves the task constrained to what a finished run did (its
cooperation path and its persons' hyper-arcs): the reference a run with a deviating operator is
compared against. See ``docs/planning.md``.
"""

from __future__ import annotations

from flexhrc.planning.model import (
    OBJECTIVES,
    Plan,
    PlanEntry,
    hindsight,
    solve,
    solve_remaining,
)
from flexhrc.planning.policies import POLICIES, LookaheadPolicy

__all__ = [
    "OBJECTIVES",
    "POLICIES",
    "LookaheadPolicy",
    "Plan",
    "PlanEntry",
    "hindsight",
    "solve",
    "solve_remaining",
]
