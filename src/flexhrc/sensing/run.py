"""A cooperation whose Task Manager knows the world only through its sensors.

:class:`PerceivedCooperationRun` is a :class:`~flexhrc.taskmanager.runner.CooperationRun` with
two worlds kept apart:

* the **truth** — a :class:`~flexhrc.sensing.world.SimulatedWorkspace` changed only by what the
  agents physically do (an arm grasps whatever lies where it closes its gripper; the operator
  takes, screws, puts down or nudges parts);
* the **belief** — the manager's knowledge base: symbols without positions at the start, then
  where perception anchored them, moved meanwhile by the *predicted* effects of the actions
  done and reported.

Perception (:class:`~flexhrc.sensing.perception.PerceptionComponent`) runs at the start and
after every action that changes the world, and after every reported human action (paper 000's
"update workspace"). Its findings reach the manager through one sans-IO input,
:meth:`~flexhrc.taskmanager.TaskManager.on_percept`:

* an object that moved while a robot element uses it stops that element, which is re-planned
  at the object's new place (validity checking, as paper 002 does for behaviours);
* an inconsistency (a belief the percept contradicts, e.g. after a false report of a human
  action) makes the manager wait; a later compatible percept clears it. With ``repair`` the
  cell repairs first, from normative knowledge — what should hold after the actions actually
  done (robot actions are acknowledged by the arms; a human report is only a recognition):
  it looks again (re-perceive), then asks the operator to confirm the report; a report the
  operator denies is undone (its effects on the base reverted, the belief back to the percept)
  and the manager drops the element it had started.

Human actions reach the manager as the wrist sensor recognises them (``human_sensing``): a miss
is a miss — the manager is not told, scene perception may still notice the change.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.representation import OnlineGraph
from flexhrc.sensing.perception import PerceptionComponent
from flexhrc.sensing.world import SimulatedWorkspace
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.manager import Command, HumanAction
from flexhrc.taskmanager.runner import CooperationRun, _Pending

#: Actions after which the world looks different (approach and rest only move an arm).
WORLD_CHANGING = ("grasp", "transport", "screw", "ungrasp", "pick_up", "put_down")
HOLD_HEIGHT_M = 0.10


@dataclass
class Nudge:
    """The operator moves the part the ``nth`` robot ``action`` goes for, by ``offset`` (m),
    ``at_fraction`` of the way through that action."""

    action: str = "approach"
    nth: int = 1
    offset: tuple[float, float] = (0.0, 0.08)
    at_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.nth < 1 or not 0.0 <= self.at_fraction <= 1.0:
            raise FlexhrcError("a nudge needs nth >= 1 and at_fraction in [0, 1]")
        if not all(math.isfinite(v) for v in self.offset):
            raise FlexhrcError(f"a nudge offset must be finite, got {self.offset}")


@dataclass
class FalseReport:
    """The wrist sensor reports ``action(human, leg)`` that the operator did not do, when the
    ``nth`` robot action ``after`` is acknowledged (``leg``: a leg on the table if None)."""

    after: str = "rest"
    nth: int = 1
    action: str = "pick_up"
    leg: str | None = None


@dataclass
class _Report:
    action: HumanAction
    real: bool
    added: set[tuple[str, ...]] = field(default_factory=set)
    removed: set[tuple[str, ...]] = field(default_factory=set)
    position: tuple[float, float, float] | None = None  # belief before the report


class PerceivedCooperationRun(CooperationRun):
    """A cooperation with perception in the loop (see the module docstring)."""

    def __init__(
        self,
        graph: OnlineGraph,
        domain: Domain,
        kb: KnowledgeBase,
        world: SimulatedWorkspace,
        perception: PerceptionComponent,
        *,
        repair: bool = False,
        nudges: Iterable[Nudge] = (),
        false_reports: Iterable[FalseReport] = (),
        confirm_s: float = 1.0,
        **kw: Any,
    ):
        false_reports = list(false_reports)
        for fr in false_reports:
            if fr.action not in domain.actions:
                raise FlexhrcError(
                    f"false report of {fr.action!r}: the domain has no such action "
                    f"(actions: {', '.join(sorted(domain.actions))})"
                )
        if not (math.isfinite(confirm_s) and confirm_s >= 0):
            raise FlexhrcError(f"confirm_s must be a finite number >= 0, got {confirm_s!r}")
        super().__init__(graph, domain, kb, **kw)
        self.world = world
        self.perception = perception
        self.repair = repair
        self.nudges = list(nudges)
        self.false_reports = list(false_reports)
        self.confirm_s = confirm_s
        self._counts: dict[str, int] = {}
        self._acks: dict[str, int] = {}
        self._reports: list[_Report] = []
        self._repairing: set[str] = set()
        self.human_stats = {
            "performed": 0, "recognised": 0, "missed": 0, "false_reports": 0, "uncovered": 0
        }  # fmt: skip
        tops = [p.name for p in world.parts.values() if p.shape == "box"]
        self._board = tops[0] if tops else None
        if getattr(self.execution, "execution", None) is not None:
            perception.robot_q = lambda: self.execution.execution.state.q  # type: ignore[attr-defined]

    # -- the loop -------------------------------------------------------------------------
    def _before_start(self) -> None:
        self._perceive("start")

    def _deadlock_reason(self) -> str:
        reason = super()._deadlock_reason()
        if self.kb.consistent:
            return reason
        reasons = "; ".join(i.reason for i in self.kb.inconsistencies)
        return f"{reason} (the knowledge base is inconsistent: {reasons})"

    def _perceive(self, why: str) -> None:
        upd = self.perception.update(self.now)
        rep = upd.report
        self._event("percept", why=why, **upd.to_dict())
        for reason in rep.inconsistencies:
            self._event("inconsistent", reason=reason)
        for sym in rep.cleared:
            self._event("consistent_again", object=sym, why="a compatible percept")
        if self.tm.outcome == "running" and (rep.moved or rep.cleared or rep.inconsistencies):
            self._dispatch(self.tm.on_percept(self.now, moved=rep.moved))
        if self.repair and not self.kb.consistent and self.tm.outcome == "running":
            self._repair()

    # -- repair from normative knowledge --------------------------------------------------
    def _repair(self) -> None:
        pending = [i for i in self.kb.inconsistencies if i.object_id not in self._repairing]
        if not pending:
            return
        for inc in pending:
            self._repairing.add(inc.object_id)
        self._event("repair", step="re-perceive", objects=[i.object_id for i in pending])
        repaired_before = {i.object_id for i in self.kb.inconsistencies}
        upd = self.perception.update(self.now)
        self._event("percept", why="repair: look again", **upd.to_dict())
        cleared = sorted(repaired_before - {i.object_id for i in self.kb.inconsistencies})
        for obj in cleared:
            self.perception.stats.repaired += 1
            self._repairing.discard(obj)
            self._event("repaired", object=obj, by="re-perceive")
        if cleared or upd.report.moved:
            self._dispatch(self.tm.on_percept(self.now, moved=upd.report.moved))
        asked: set[str] = set()
        for inc in list(self.kb.inconsistencies):
            if inc.object_id in asked:
                continue
            asked.add(inc.object_id)
            report = self._report_about(inc.object_id)
            if report is None:
                self._event(
                    "repair", step="none", object=inc.object_id,
                    reason="no unconfirmed report explains it; waiting for a compatible percept",
                )  # fmt: skip
                continue
            question = f"did you {report.action}?"
            self._event("repair", step="ask operator", object=inc.object_id, question=question)
            self._push(
                self.now + self.confirm_s,
                _Pending("operator_answer", {"object": inc.object_id, "report": report}),
            )

    def _report_about(self, obj: str) -> _Report | None:
        for r in reversed(self._reports):
            if obj in r.action.args:
                return r
        return None

    def _answer(self, data: dict[str, Any]) -> None:
        obj, report = data["object"], data["report"]
        self._repairing.discard(obj)
        if report not in self._reports or self.tm.done:
            return  # settled meanwhile
        if report.real:  # the operator did it: the percept was wrong; look again later
            self._event("operator_answers", question=f"did you {report.action}?", answer="yes")
            self.kb.resolve(obj, accept=False)  # the belief stands
            self.perception.anchoring.expected.discard(obj)
            self._dispatch(self.tm.on_percept(self.now))
            return
        self._event("operator_answers", question=f"did you {report.action}?", answer="no")
        # normative knowledge: what holds after the actions really done -> undo the report
        for fact in report.added:
            self.kb.retract_fact(*fact)
        for fact in report.removed:
            self.kb.assert_fact(*fact)
        seen = self.perception.anchoring.last_seen.get(obj)
        if seen is not None:
            self.kb.move(obj, seen[0])
        elif report.position is not None:
            self.kb.move(obj, report.position)
        self.kb.resolve(obj, accept=False)
        self._reports.remove(report)
        self.perception.stats.repaired += 1
        self._event("repaired", object=obj, by="operator denied " + str(report.action))
        self._dispatch(self.tm.on_percept(self.now, retracted=[report.action]))

    def _on_event(self, pending: _Pending) -> None:
        if pending.kind == "nudge":
            part = self.world.parts.get(pending.data["part"])
            if part is None or part.holder is not None or part.upright:
                return  # already taken: nothing to nudge
            dx, dy = pending.data["offset"]
            # dy points away from the middle of the table; where that spot is taken, the
            # operator puts the part in the first free spot as far away in another direction
            side = 1.0 if part.position[1] >= 0 else -1.0
            size = math.hypot(dx, dy)
            options = [(dx, side * dy), (size, 0.0), (-size, 0.0), (dx, -side * dy)]
            x, y, _ = part.position
            offset = next(
                (o for o in options if self.world.clear_at(part.name, (x + o[0], y + o[1]))),
                None,
            )
            if offset is None:
                self._event("operator_nudge_skipped", part=part.name, reason="no free spot")
                return
            self.world.displace(part.name, offset)
            self._event("operator_nudges", part=part.name, offset=list(offset))
            self._perceive("the operator moved a part")
        elif pending.kind == "operator_answer":
            self._answer(pending.data)
        else:
            super()._on_event(pending)

    # -- robots: the physical side ------------------------------------------------------------
    def _positions(self) -> dict[str, tuple[float, float, float]]:
        out = super()._positions()
        self._before = dict(out)
        return out

    def _start_robot(self, cmd: Command) -> None:
        super()._start_robot(cmd)
        kind = cmd.action.schema.kind
        n = self._counts[kind] = self._counts.get(kind, 0) + 1
        pending = self._by_command.get(cmd.id)
        if pending is None:
            return
        # the base runner writes every position of the snapshot back when the command ends:
        # keep only what the action itself changes (its predicted effect), so that what
        # perception learns meanwhile is not overwritten by a stale snapshot
        before = self._before
        pending.data["positions"] = {
            k: v for k, v in pending.data["positions"].items() if before.get(k) != v
        }
        if kind == "grasp" and pending.data["status"] == "done":
            obj = cmd.action.args[1]
            at = self.kb.position(obj)
            if self.world.nearest(at, within=self.world.grasp_tolerance_m) is None:
                pending.data["status"] = "failed"
                pending.data["reason"] = (
                    f"nothing to grasp at ({at[0]:.3f}, {at[1]:.3f}): {obj} is not there"
                )
        for nudge in self.nudges:
            if nudge.action == kind and nudge.nth == n and len(cmd.action.args) > 1:
                target = self.world.nearest(self.kb.position(cmd.action.args[1]), within=0.05)
                if target is None:
                    continue
                duration = self._queue_time(pending) - self.now
                self._push(
                    self.now + nudge.at_fraction * duration,
                    _Pending("nudge", {"part": target.name, "offset": nudge.offset}),
                )

    def _stop(self, stop: Any) -> None:
        super()._stop(stop)
        # a stopped arm lays what it holds back where it took it (the manager believes it is
        # released where the arm is: perception sees otherwise and re-anchors it)
        self.world.put_back(stop.agent)

    def _queue_time(self, pending: _Pending) -> float:
        return next((at for at, _, p in self._queue if p is pending), self.now)

    def _robot_done(self, data: dict[str, Any]) -> None:
        cmd: Command = data["cmd"]
        kind = cmd.action.schema.kind
        if data["status"] == "done":
            self._truth(cmd.action, cmd.agents[0])
        super()._robot_done(data)
        if data["status"] != "done" or self.tm.done:
            return
        n = self._acks[kind] = self._acks.get(kind, 0) + 1
        if self._changes_world(cmd.action):
            self._perceive(f"after {cmd.action}")
        for fr in self.false_reports:
            if fr.after == kind and fr.nth == n and not self.tm.done:
                self._false_report(fr)

    def _truth(self, action: GroundAction, agent: str) -> None:
        """What the action does to the truth (see :func:`physical_effect`)."""
        physical_effect(self.world, action, agent, self.kb.position, self._board)

    def _changes_world(self, action: GroundAction) -> bool:
        schema = action.schema
        return schema.kind in WORLD_CHANGING or bool(
            getattr(schema, "carries", None) or getattr(schema, "fixes", None)
        )

    # -- the human ------------------------------------------------------------------------
    def _physical(self, action: GroundAction, positions: dict[str, Any]) -> None:
        """The base runner's physical side moves the *belief* (where the action leaves what
        it carries). A robot's acknowledged action does so at once; an operator's action
        changes the truth here, and the belief only as far as it is reported (:meth:`_sensed`)."""
        if not any(self.domain.agent(a).is_human for a in action.agents):
            super()._physical(action, positions)
            return
        self._truth(action, action.agents[0])
        self._human_changed = True

    def _sensed(self, step: GroundAction) -> HumanAction | None:
        sensed = super()._sensed(step)
        uncovered = bool(self.events) and self.events[-1]["type"] == "human_sensing_uncovered"
        if sensed is not None and uncovered:
            self.human_stats["uncovered"] += 1  # confirmed otherwise: no recognition figure
            self._believe(sensed, True, step)
            return sensed
        self.human_stats["performed"] += 1
        if sensed is None:
            self.human_stats["missed"] += 1
            return None
        action = self._fit(sensed, step)
        if action is None:
            self.human_stats["false_reports"] += 1
            self._event("human_report_unusable", recognised=sensed.name, action=str(step))
            return None
        real = action.name == step.name and action.args == step.args
        self.human_stats["recognised" if real else "false_reports"] += 1
        self._believe(action, real, step if real else None)
        return action

    def _fit(self, sensed: HumanAction, step: GroundAction) -> HumanAction | None:
        """The recognised action with the arguments its schema takes (from the step done)."""
        schema = self.domain.actions.get(sensed.name)
        if schema is None:
            return None
        n = len(schema.parameters)
        if n <= len(step.args):
            return HumanAction(sensed.name, tuple(step.args[:n]))
        # more arguments than the action done has (a pick-up taken for a screw): the sensor
        # names the motion, the rest comes from what the operator is about to do
        op = self.operators.get(step.agents[0]) if step.agents else None
        plan = op.plan.steps if op is not None and op.plan is not None else []
        for other in plan:
            if other.name == sensed.name and other.args[: len(step.args)] == step.args:
                return HumanAction(sensed.name, other.args)
        return None

    def _believe(self, action: HumanAction, real: bool, step: GroundAction | None) -> None:
        """The belief a report implies — its effects on the facts are the manager's; where the
        objects now are, the base runner's physical side — remembered so that it can be
        undone; the next percept checks it (:meth:`Anchoring.expect`)."""
        before = set(self.kb.facts)
        obj = action.args[1] if len(action.args) > 1 else None
        report = _Report(action, real)
        fixed = False
        if obj is not None and obj in self.kb.objects:
            report.position = self.kb.position(obj)
            fixed = self.kb.object(obj).fixed
            self.perception.anchoring.expect(obj)
        ground = step
        if ground is None:
            schema = self.domain.actions[action.name]
            who = action.args[0] if action.args and action.args[0] in self.domain.agents else None
            ground = GroundAction(schema, action.args, (who,) if who else ())
        self._believe_effects(ground)
        self._reports.append(report)
        self._pending_report = (report, before, fixed)

    def _believe_effects(self, action: GroundAction) -> None:
        """Where a reported operator action leaves what it carries, as the domain declares it
        (``carries``, ``moves_to``, ``fixes``): at ``moves_to``, else at the place it names
        (a screw at its bolt), else in the operator's hand."""
        schema, binding = action.schema, action.binding
        carried = binding.get(getattr(schema, "carries", None) or "")
        fixed = binding.get(getattr(schema, "fixes", None) or "")
        if carried is None and schema.kind == "pick_up" and len(action.args) > 1:
            carried = action.args[1]  # a domain without the declarations
        if carried is None and schema.kind == "screw" and len(action.args) > 2:
            carried = fixed = action.args[1]
        if carried in self.kb.objects and not self.kb.object(carried).fixed:
            to = binding.get(getattr(schema, "moves_to", None) or "")
            if to is None:
                to = next(
                    (
                        a
                        for a in action.args
                        if a in self.kb.objects and a != carried and a not in self.domain.agents
                    ),
                    None,
                )
            self.kb.move(carried, self.kb.position(to) if to else self.world.hand)
        if fixed in self.kb.objects and not self.kb.object(fixed).fixed:
            self.kb.set_fixed(fixed)
            self._event("fixed", object=fixed, agents=list(action.agents), action=str(action))
            for a in action.agents:
                self.legs_by_agent[a] = self.legs_by_agent.get(a, 0) + 1

    def _human_done(self, data: dict[str, Any]) -> None:
        self._pending_report = None
        self._human_changed = False
        super()._human_done(data)
        self._settle_report()
        if self._human_changed and not self.tm.done:
            self._perceive(f"after the operator's {data['step']}")

    _pending_report: tuple[_Report, set[tuple[str, ...]], bool] | None = None
    _human_changed = False
    _before: dict[str, tuple[float, float, float]] = {}  # noqa: RUF012 - replaced, not mutated

    def _settle_report(self) -> None:
        """Record what the manager's handling of the report changed in the base (to undo)."""
        if self._pending_report is None:
            return
        report, before, fixed = self._pending_report
        after = set(self.kb.facts)
        report.added, report.removed = after - before, before - after
        self._pending_report = None
        if not report.added and not report.removed and len(report.action.args) > 1:
            # the manager matched the report to nothing (its effects were not applied): the
            # belief of where the object is does not follow it either
            obj = report.action.args[1]
            if report.position is not None and obj in self.kb.objects:
                self.kb.move(obj, report.position)
                self.kb.set_fixed(obj, fixed)
            self.perception.anchoring.expected.discard(obj)
            self._reports.remove(report)
            self._event("human_report_ignored", action=str(report.action))

    def _false_report(self, fr: FalseReport) -> None:
        leg = fr.leg
        if leg is None:
            busy = set().union(*(ex.objects for ex in self.tm.executions.values()))
            legs = [
                o.id
                for o in self.kb.objects_of_type("leg")
                if self.kb.holds("on_table", o.id) and o.id not in busy
            ]
            if not legs:
                return
            leg = sorted(legs)[-1]
        who = next((a.name for a in self.domain.agents.values() if a.is_human), "human")
        action = HumanAction(fr.action, (who, leg))
        self.human_stats["false_reports"] += 1
        self._event("false_report", action=str(action))
        self._pending_report = None
        self._believe(action, False, None)
        self._dispatch(self.tm.on_human_action(self.now, action))
        self._settle_report()
        self._perceive(f"after the report {action}")

    # -- results --------------------------------------------------------------------------
    def summary(self, wall_s: float) -> dict[str, Any]:
        out = super().summary(wall_s)
        out["perception"] = self.perception.stats.to_dict()
        out["human_sensing"] = dict(self.human_stats)
        return out


def forget_positions(kb: KnowledgeBase, types: Iterable[str]) -> KnowledgeBase:
    """A copy of ``kb`` in which the objects of ``types`` are symbols with no known position
    (what the manager starts from when perception is on)."""
    out = kb.copy()
    wanted = set(types)
    for rec in out.objects.values():
        if set(out.type_chain(rec.type)) & wanted:
            rec.position = (0.0, 0.0, 0.0)
            rec.anchored = False
    out.version += 1
    return out


def lying_layout(
    legs: int, seed: int = 0, *, tabletop_depth: float = 0.40, length: float = 0.40
) -> list[tuple[float, float, float]]:
    """Seeded places for ``legs`` legs lying along x beside the tabletop, clear of each
    other (a leg is a body here, not a point: two legs side by side need 7 cm)."""
    import random

    rng = random.Random(seed)
    out: list[tuple[float, float, float]] = []
    for _ in range(10_000):
        if len(out) == legs:
            return out
        x = rng.uniform(0.32, 0.55)
        y = rng.choice((-1, 1)) * rng.uniform(tabletop_depth / 2 + 0.08, 0.46)
        if all(abs(y - q[1]) >= 0.07 or abs(x - q[0]) >= length + 0.04 for q in out):
            out.append((round(x, 3), round(y, 3), 0.0))
    raise FlexhrcError(f"no room for {legs} legs beside the tabletop; use fewer legs")


def physical_effect(
    world: SimulatedWorkspace,
    action: GroundAction,
    agent: str,
    believed: Callable[[str], tuple[float, float, float]],
    board: str | None,
) -> None:
    """What ``action`` by ``agent`` does to the truth. Robot and operator act where they
    *believe* things are (``believed(name)``: a position): a grasp closes on whatever lies at
    the believed place, a leg carried above a bolt of ``board`` is held upright, a screwed one
    stands upright on it; a part the domain ``carries`` to a ``moves_to`` place without a hand
    (both arms placing the tabletop) is put there."""
    schema = action.schema
    kind, args, binding = schema.kind, action.args, action.binding
    carries = binding.get(getattr(schema, "carries", None) or "")
    moves_to = binding.get(getattr(schema, "moves_to", None) or "")
    if kind == "grasp":
        world.grasp(agent, believed(args[1]))
    elif kind == "transport":
        x, y, _ = believed(moves_to or args[2])
        over = world.over_board((x, y))
        held = world.held_by(agent)
        if over is not None and held is not None and held.shape == "cylinder":
            # above a bolt the leg is held upright, its foot just above the board
            top = over.position[2] + over.dims[2] / 2
            world.carry(agent, (x, y, top + 0.01 + held.dims[0] / 2), upright=True)
        else:
            world.carry(agent, (x, y, HOLD_HEIGHT_M))
    elif kind == "screw":
        world.attach(agent, believed(args[2]), on=board)
    elif kind in ("ungrasp", "put_down"):
        world.release(agent)
    elif kind == "pick_up":
        world.pick_up(agent, believed(args[1]))
    elif carries and moves_to:
        part = world.nearest(believed(carries), within=0.05)
        if part is not None:
            world.relocate(part.name, believed(moves_to))


__all__ = [
    "FalseReport",
    "Nudge",
    "PerceivedCooperationRun",
    "forget_positions",
    "lying_layout",
    "physical_effect",
]
