"""Planning ahead: the optimal cooperation path, allocation and schedule of a task (issue 23).

See ``docs/planning.md``.
"""

from __future__ import annotations

from flexhrc.planning.policies import POLICIES, LookaheadPolicy

__all__ = ["POLICIES", "LookaheadPolicy"]
