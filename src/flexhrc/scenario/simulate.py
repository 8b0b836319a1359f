"""The analytic simulator of scenario files: times come from the domain, not from code.

An action (or process) that declares ``duration`` and/or ``moves_to`` is simulated without any
scenario-specific code: the agent's hand travels from where it is to the object or place bound
to the ``moves_to`` parameter at the agent's speed (a robot arm's ``speed``, default 0.4 m/s —
the paper's robot; an operator's ``speed`` from ``humans:``, default 1 m/s), then works for
``duration`` seconds. A robot target farther than the arm's ``reach`` from its ``base`` (or an
object whose ``reachable_by`` leaves the arm out) fails, "out of reach", so the decision tree
scores that branch 0 (eq. 21). A joint action takes as long as its slowest agent. Actions that
declare neither fall back to :class:`~flexhrc.taskmanager.AnalyticSimulator`'s models of the
table's motions (approach, grasp, transport, screw, ...).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Agent, Domain, GroundAction
from flexhrc.taskmanager.simulator import AnalyticSimulator, Vec3


class ScenarioSimulator(AnalyticSimulator):
    """:class:`AnalyticSimulator` that honours the domain's ``duration`` and ``moves_to``."""

    def step(
        self,
        action: GroundAction,
        positions: dict[str, Vec3],
        kb: KnowledgeBase,
        domain: Domain,
    ) -> tuple[bool, float, str | None]:
        schema = action.schema
        if schema.duration is None and schema.moves_to is None:
            return super().step(action, positions, kb, domain)
        target_name = action.binding.get(schema.moves_to) if schema.moves_to else None
        target: Vec3 | None = None
        if target_name is not None and target_name in kb.objects:
            target = positions.get(target_name) or kb.position(target_name)
        longest = 0.0
        for name in action.agents:
            agent = domain.agent(name)
            ok, travel, why = self._travel(agent, target, target_name, positions, kb)
            if not ok:
                return False, 0.0, why
            longest = max(longest, travel)
        total = longest + (schema.duration or 0.0)
        robots = [a for a in action.agents if not domain.agent(a).is_human]
        if robots and self.failure_rate and self._rng.random() < self.failure_rate:
            return False, total, f"{action} failed (simulated fault)"
        return True, total, None

    def _travel(
        self,
        agent: Agent,
        target: Vec3 | None,
        target_name: str | None,
        positions: dict[str, Vec3],
        kb: KnowledgeBase,
    ) -> tuple[bool, float, str | None]:
        params: Mapping[str, object] = agent.params
        if agent.is_human:
            speed = float(params.get("speed", self.timing.human_speed))  # type: ignore[arg-type]
        else:
            speed = float(params.get("speed", self.timing.robot_speed))  # type: ignore[arg-type]
        here = positions.get(agent.name) or (
            kb.position(agent.name) if agent.name in kb.objects else None
        )
        if target is None or here is None:
            return True, 0.0, None
        if not agent.is_human:
            rec = kb.objects.get(target_name or "")
            allowed = rec.attrs.get("reachable_by") if rec is not None else None
            if allowed is not None and agent.name not in allowed:
                return False, 0.0, f"{target_name} cannot be reached by {agent.name} (blocked)"
            if "base" in params:
                base = tuple(float(v) for v in params["base"])  # type: ignore[attr-defined]
                reach = float(params.get("reach", 0.85))  # type: ignore[arg-type]
                d = math.dist(base, target)
                if d > reach:
                    return (
                        False,
                        0.0,
                        f"{target_name} is out of reach of {agent.name} "
                        f"({d:.2f} m > {reach:.2f} m)",
                    )
        positions[agent.name] = target
        return True, math.dist(here, target) / max(speed, 1e-6), None
