"""The decision policies of :mod:`flexhrc.planning`, registered by name.

``lookahead`` (:class:`LookaheadPolicy`) is an advisor of the Task Manager
(:mod:`flexhrc.taskmanager.policy`): at each decision, and so after every deviation of a person
(a report the manager did not ask for is a new decision), it solves the remaining task with
CP-SAT (:func:`flexhrc.planning.solve_remaining`: a time limit in deterministic solver time, one
worker, a fixed seed, a warm start from the last schedule) and advises the hyper-arcs the
schedule starts now, with their agents, and holds back the ones it starts later or never. When
the solver has no answer in time, or the plan has nothing to start while nothing runs, it gives
no advice and the manager decides as the paper does. The person stays free to deviate.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from flexhrc.events import DECISION_POLICIES
from flexhrc.taskmanager.policy import Advice, register_policy

if TYPE_CHECKING:
    from flexhrc.taskmanager.manager import TaskManager

#: how long (deterministic solver seconds, about wall seconds on one core) one decision's
#: solve may take before the paper's decision is taken instead
DECISION_TIME_LIMIT_S = 0.05
#: the first decision of a task with more than ``MAX_CIRCUIT`` branches for some agent: how
#: long its plan with every hand's travel (:func:`flexhrc.planning.model.solve_exact_travel`)
#: may take (deterministic seconds; 0: plan that task without travel, as every later
#: decision that re-plans does)
FIRST_PLAN_TIME_LIMIT_S = 1.0


class LookaheadPolicy:
    """Follow a CP-SAT schedule of the remaining task (see the module docstring)."""

    name = "lookahead"

    def __init__(
        self,
        *,
        time_limit_s: float = DECISION_TIME_LIMIT_S,
        seed: int = 0,
        travel: bool = True,
        first_time_limit_s: float = FIRST_PLAN_TIME_LIMIT_S,
    ) -> None:
        self.time_limit_s = time_limit_s
        self.first_time_limit_s = first_time_limit_s
        self.seed = seed
        #: plan with the hands' travel from one hyper-arc to the next (``plan --travel``)
        self.travel = travel
        self.last: Any = None  # the last plan (warm start)
        self.first: Any = None  # the first plan, with every hand's travel (kept if followed)
        self.task: Any = None  # the task as the solver sees it, made at the first decision
        self.seen: dict[int, float] = {}  # command id -> when it was first seen (its start)
        self.key: Any = None  # what the last advice was given for
        self.base: Any = None  # what the last plan was solved for
        self.advice: Advice | None = None
        self.solves = 0
        self.fallbacks = 0
        self.reused = 0  # decisions that kept the last plan (the cell followed it)

    def advise(self, tm: TaskManager, now: float) -> Advice | None:
        from flexhrc.planning.model import advise_from

        return advise_from(self, tm, now)


#: the policies this package adds: name -> factory (what :func:`register_policy` is given)
POLICIES: Mapping[str, Any] = {"lookahead": LookaheadPolicy}

for _name, _factory in POLICIES.items():
    assert _name in DECISION_POLICIES
    register_policy(_name, _factory)
