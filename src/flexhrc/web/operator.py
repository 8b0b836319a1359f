"""The inputs an operator at a panel has, on any :class:`~flexhrc.taskmanager.TaskManager`.

A recognised human action (paper 000, section V) tells the manager what the person *did*. A
person at a panel can also say what they *will* do — "I'll do this" on a feasible hyper-arc —
and stop an arm. :func:`take` is the first: the robot leaves that part as it does when the
manager recognises an unsuggested human action (every robot execution sharing a child node or an
object with it is aborted, its arm sent to rest), and the hyper-arc's actions, grounded for the
operator by a decision tree (eq. 21), are suggested to the operator. :func:`takeable` lists the
hyper-arcs an operator may take now. :func:`dry_run` tries an input on a copy of the manager, so
a panel refuses what the manager would not match without changing anything.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

from flexhrc.taskmanager.decision import DecisionTree
from flexhrc.taskmanager.manager import Directive, TakeRefused, TaskManager
from flexhrc.web.backend import PanelInputError


def humans(tm: TaskManager) -> list[str]:
    return [a.name for a in tm.domain.agents.values() if a.is_human]


def human_branches(tm: TaskManager, element: str) -> DecisionTree:
    """The operators' ways of doing a feasible hyper-arc now
    (:meth:`TaskManager.operator_branches`)."""
    return tm.operator_branches(element)


def takeable(tm: TaskManager) -> list[str]:
    """Feasible hyper-arcs an operator may take now (those not already an operator's)."""
    if tm.done:
        return []
    out = []
    for name, _cost in sorted(tm.feasible_hyperarcs().items(), key=lambda kv: (kv[1], kv[0])):
        ex = tm.executions.get(name)
        if ex is not None and ex.owner == "human":
            continue
        if tm.actions_of(name) and human_branches(tm, name).branches:
            out.append(name)
    return out


_STATUS = {"unknown": 404, "invalid": 400, "conflict": 409}


def refusal_status(refused: TakeRefused) -> int:
    """The HTTP status of a refused take: 404 unknown, 400 not a hyper-arc, 409 not now."""
    return _STATUS.get(refused.kind, 409)


def take(tm: TaskManager, now: float, element: str) -> list[Directive]:
    """The operator will do ``element`` (:meth:`TaskManager.operator_takes`). Raises
    :class:`PanelInputError` (nothing changed) when it is not a feasible hyper-arc an operator
    can do now."""
    try:
        return tm.operator_takes(now, element)
    except TakeRefused as exc:
        raise PanelInputError(str(exc), refusal_status(exc)) from None


def dry_run(
    tm: TaskManager, apply: Callable[[TaskManager], object], *, share: tuple[Any, ...] = ()
) -> list[dict[str, Any]]:
    """Apply an input to a deep copy of ``tm``; returns the events the copy logged. The log
    callback is replaced (the copy never writes to the real log); the simulator, the domain and
    the objects in ``share`` are shared, not copied."""
    events: list[dict[str, Any]] = []
    memo: dict[int, Any] = {id(tm.simulator): tm.simulator, id(tm.domain): tm.domain}
    memo[id(vars(tm)["_log"])] = events.append
    for obj in share:
        memo[id(obj)] = obj
    clone = copy.deepcopy(tm, memo)
    apply(clone)
    return events


__all__ = ["dry_run", "human_branches", "humans", "refusal_status", "take", "takeable"]
