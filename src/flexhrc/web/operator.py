"""The inputs an operator at a panel has, on any :class:`~flexhrc.taskmanager.TaskManager`.

A recognised human action (paper 000, section V) tells the manager what the person *did*. A
person at a panel can also say what they *will* do — "I'll do this" on a feasible hyper-arc —
and stop an arm. The cell takes the first as its input ``human_take``
(:meth:`~flexhrc.cell.Cell.human_take`, then :meth:`TaskManager.operator_takes`): the robot
leaves that part as it does when the manager recognises an unsuggested human action, and the
hyper-arc's actions, grounded for the operator by a decision tree (eq. 21), are suggested to the
operator. :func:`takeable` lists the hyper-arcs an operator may take now;
:meth:`TaskManager.advances` tries a reported action on a copy of the manager, so a panel refuses
what the manager would not match without changing anything.
"""

from __future__ import annotations

from flexhrc.taskmanager.manager import TakeRefused, TaskManager
from flexhrc.taskmanager.words import plain_words


def humans(tm: TaskManager) -> list[str]:
    return [a.name for a in tm.domain.agents.values() if a.is_human]


def takeable(tm: TaskManager) -> list[str]:
    """Feasible hyper-arcs an operator may take now (those not already an operator's)."""
    return [offer["element"] for offer in offers(tm)]


def offers(tm: TaskManager) -> list[dict[str, str]]:
    """The hyper-arcs an operator may take now, each with its steps in plain words (the first
    grounding of the operator's decision tree; taking it grounds it anew, eq. 21):
    ``{"element", "text"}``, cheapest first."""
    if tm.done:
        return []
    names = tuple(tm.domain.agents)
    out = []
    for name, _cost in sorted(tm.feasible_hyperarcs().items(), key=lambda kv: (kv[1], kv[0])):
        ex = tm.executions.get(name)
        if ex is not None and ex.owner == "human":
            continue
        if not tm.actions_of(name):
            continue
        branches = tm.operator_branches(name).branches
        if branches:
            words = [plain_words(step, names) for step in branches[0].steps]
            out.append({"element": name, "text": " · ".join(words)})
    return out


_STATUS = {"unknown": 404, "invalid": 400, "conflict": 409}


def refusal_status(refused: TakeRefused) -> int:
    """The HTTP status of a refused take: 404 unknown, 400 not a hyper-arc, 409 not now."""
    return _STATUS.get(refused.kind, 409)


__all__ = ["humans", "offers", "refusal_status", "takeable"]
