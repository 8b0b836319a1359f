"""The CP-SAT model of a task (issue 23): see docs/planning.md."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from flexhrc.taskmanager.policy import Advice

if TYPE_CHECKING:
    from flexhrc.taskmanager.manager import TaskManager


def advise_from(policy: Any, tm: TaskManager, now: float) -> Advice | None:
    """(The solver lands in the next commit: no advice, the paper's decision.)"""
    return None
