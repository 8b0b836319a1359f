"""A utility a user can shape: the paper's eq. (21) with weighted terms (scenario key ``utility:``).

The paper scores a branch b of a decision tree by ``J(b) = success(b) / sum(t_i)`` (paper 000,
eq. 21). :class:`Utility` keeps that as its default and lets a scenario weigh four terms, each a
factor of a product so that a weight of 0 drops the term and the default weights give eq. (21)
exactly:

``J(b) = success^w_s * (1 / T)^w_t * exp(w_p * P) * exp(-w_w * W)``

* **success** ``success(b)`` (1 or 0, the simulator's verdict). Any positive weight excludes a
  branch the simulator says fails (eq. 21); weight 0 ignores the verdict (a pessimistic
  simulator).
* **time** ``T``, the sum of the branch's action times (eq. 21's denominator).
* **preference** ``P``, the mean over the branch's actions of the ``prefer:`` values that match
  its agent: a key naming an agent, an agent type or ``human``/``robot`` holds a number (for
  every action); a key naming an action holds a mapping of such agent keys to numbers (that
  action only), e.g. ``screw: {robot: 1}``, "prefer the robot for screwing".
* **workload** ``W``, the person's share of the busy time if the branch is chosen: for each
  person, (their effort-weighted time so far + in b) / (time elapsed + T), the largest of them;
  ``effort:`` weighs an action's time (default 1). ``max_workload`` also excludes a branch that
  gives a person work beyond that share ("keep the person's workload under 40 %").

Every branch's terms go to the decision log (``terms`` of each branch).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from flexhrc.taskmanager.domain import Domain, GroundAction

#: the weights a ``utility:`` block may set, and their defaults (eq. 21)
WEIGHTS: dict[str, float] = {"success": 1.0, "time": 1.0, "preference": 0.0, "workload": 0.0}
#: every key of a ``utility:`` block
UTILITY_KEYS: tuple[str, ...] = (*WEIGHTS, "prefer", "effort", "max_workload")
#: agent keys every domain has: any person, any arm
AGENT_KINDS: tuple[str, ...] = ("human", "robot")


@dataclass(frozen=True)
class Utility:
    """The weights and tables of a shaped utility (see the module docstring)."""

    success: float = 1.0
    time: float = 1.0
    preference: float = 0.0
    workload: float = 0.0
    #: agent key -> value, or action name -> {agent key -> value}
    prefer: Mapping[str, float | Mapping[str, float]] = field(default_factory=dict)
    #: action name -> effort weight of its time in the workload (default 1)
    effort: Mapping[str, float] = field(default_factory=dict)
    max_workload: float | None = None

    @property
    def is_default(self) -> bool:
        """The paper's eq. (21) unchanged (the manager then keeps its own arithmetic)."""
        return self == Utility()

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {k: getattr(self, k) for k in WEIGHTS}
        if self.prefer:
            out["prefer"] = {
                k: v if isinstance(v, float | int) else dict(v) for k, v in self.prefer.items()
            }
        if self.effort:
            out["effort"] = dict(self.effort)
        if self.max_workload is not None:
            out["max_workload"] = self.max_workload
        return out

    # -- the terms --------------------------------------------------------------------------
    def _matches(self, key: str, agent: str, domain: Domain) -> bool:
        a = domain.agents.get(agent)
        if a is None:
            return key == agent
        return key in (a.name, a.kind) or key in a.types

    def preference_of(self, step: GroundAction, domain: Domain) -> float:
        """The ``prefer:`` values that match one action and its agents (summed)."""
        total = 0.0
        for key, value in self.prefer.items():
            if isinstance(value, Mapping):
                if key != step.schema.name:
                    continue
                pairs = list(value.items())
            else:
                pairs = [(key, value)]
            for agent_key, v in pairs:
                if any(self._matches(agent_key, a, domain) for a in step.agents):
                    total += float(v)
        return total

    def terms(
        self,
        steps: Sequence[GroundAction],
        success: bool,
        durations: Sequence[float],
        domain: Domain,
        *,
        now: float = 0.0,
        person_time: Mapping[str, float] | None = None,
    ) -> dict[str, float]:
        """The branch's terms and its utility ``J`` (key ``utility``).

        ``now`` is the time elapsed in the run, ``person_time`` each person's effort-weighted
        busy time so far."""
        total = float(sum(durations))
        pref = (
            sum(self.preference_of(s, domain) for s in steps) / len(steps)
            if steps and self.prefer
            else 0.0
        )
        busy = dict(person_time or {})
        gives_work = False
        for s, d in zip(steps, durations, strict=False):
            for a in s.agents:
                agent = domain.agents.get(a)
                if agent is not None and agent.is_human:
                    busy[a] = busy.get(a, 0.0) + d * float(self.effort.get(s.schema.name, 1.0))
                    gives_work = True
        span = now + total
        work = max((t / span for t in busy.values()), default=0.0) if span > 0 else 0.0
        j = 0.0
        if (success or self.success == 0) and (total > 0 or self.time == 0):
            j = (1.0 / total) ** self.time if self.time else 1.0
            j *= math.exp(self.preference * pref - self.workload * work)
            if gives_work and self.max_workload is not None and work > self.max_workload:
                j = 0.0
        return {
            "success": 1.0 if success else 0.0,
            "time": round(total, 6),
            "preference": round(pref, 6),
            "workload": round(work, 6),
            "utility": j,
        }

    def effort_time(self, step: GroundAction, duration: float) -> float:
        """A person's effort-weighted time for one action."""
        return duration * float(self.effort.get(step.schema.name, 1.0))


def parse_utility(
    block: Any, domain: Domain | None
) -> tuple[Utility | None, list[tuple[str, str | None]]]:
    """A ``utility:`` block read: the :class:`Utility` and the problems (message, key where it
    is), the key None for the block itself. Names in ``prefer``/``effort`` are checked against
    the domain when there is one."""
    problems: list[tuple[str, str | None]] = []

    def fault(message: str, key: str) -> None:
        problems.append((message, key))

    if block is None:
        return None, problems
    if not isinstance(block, Mapping):
        return None, [
            ("utility must be a mapping of weights (success, time, preference, workload)", None)
        ]
    for key in block:
        if key not in UTILITY_KEYS:
            fault(f"utility: unknown key {key!r}; choose among {', '.join(UTILITY_KEYS)}", str(key))
    kw: dict[str, Any] = {}
    for key in WEIGHTS:
        if key in block:
            v = block[key]
            if not _number(v) or v < 0:
                fault(f"utility: {key} must be a number >= 0, got {v!r}", key)
            else:
                kw[key] = float(v)
    agents = set(AGENT_KINDS)
    actions: set[str] = set()
    if domain is not None:
        for a in domain.agents.values():
            agents |= {a.name, *a.types}
        actions = set(domain.actions)
    prefer: dict[str, float | dict[str, float]] = {}
    raw = block.get("prefer", {}) or {}
    if not isinstance(raw, Mapping):
        fault(
            "utility: prefer must be a mapping (agent: value or action: {agent: value})", "prefer"
        )
        raw = {}
    for key, value in raw.items():
        key = str(key)
        if isinstance(value, Mapping):
            if domain is not None and key not in actions:
                fault(f"utility: prefer: {key!r} is not an action of the domain", "prefer")
                continue
            inner: dict[str, float] = {}
            for ak, av in value.items():
                if domain is not None and str(ak) not in agents:
                    fault(f"utility: prefer: {key}: {ak!r} names no agent or agent type", "prefer")
                elif not _number(av):
                    fault(f"utility: prefer: {key}: {ak} must be a number, got {av!r}", "prefer")
                else:
                    inner[str(ak)] = float(av)
            prefer[key] = inner
        elif _number(value):
            if domain is not None and key not in agents:
                fault(
                    f"utility: prefer: {key!r} names no agent or agent type"
                    " (an action takes a mapping agent: value)",
                    "prefer",
                )
                continue
            prefer[key] = float(value)
        else:
            fault(f"utility: prefer: {key} must be a number or a mapping, got {value!r}", "prefer")
    effort: dict[str, float] = {}
    raw = block.get("effort", {}) or {}
    if not isinstance(raw, Mapping):
        fault("utility: effort must be a mapping action: weight", "effort")
        raw = {}
    for key, value in raw.items():
        if domain is not None and str(key) not in actions:
            fault(f"utility: effort: {key!r} is not an action of the domain", "effort")
        elif not _number(value) or value < 0:
            fault(f"utility: effort: {key} must be a number >= 0, got {value!r}", "effort")
        else:
            effort[str(key)] = float(value)
    cap = block.get("max_workload")
    if cap is not None and (not _number(cap) or not 0 <= cap <= 1):
        fault(f"utility: max_workload must be a share between 0 and 1, got {cap!r}", "max_workload")
        cap = None
    if problems:
        return None, problems
    return Utility(
        **kw, prefer=prefer, effort=effort, max_workload=None if cap is None else float(cap)
    ), problems


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


__all__ = ["UTILITY_KEYS", "WEIGHTS", "Utility", "parse_utility"]
