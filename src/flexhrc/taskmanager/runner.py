"""A whole cooperation on a simulated clock: Task Manager + simulated arms + simulated human.

:class:`CooperationRun` is a discrete-event loop. The Task Manager's :class:`Command` goes to a
simulated robot arm, which finishes it after the time the execution model gives (or fails, when
a failure is injected, or times out); its :class:`Suggest` goes to the simulated human; a
:class:`Stop` cancels an arm's command. The simulated human follows suggestions and, depending on
its profile, also acts on its own:

* ``passive`` — only when asked;
* ``takeover`` — takes every leg it can (paper Fig. 10);
* ``cooperative`` — takes the next leg now and then (seeded; Fig. 11);
* ``random`` — acts at random moments on random legs (seeded).

``human_takes`` scripts the operator instead: it takes exactly the listed bolts (tests, demos).

Nothing sleeps (unless ``realtime``), so a 4-leg assembly takes milliseconds of wall time. Every
decision, command, acknowledgement and human action is recorded in :attr:`RunResult.events`
(JSON-serialisable dicts, written as JSON lines by :meth:`RunResult.save_log`).
"""

from __future__ import annotations

import heapq
import itertools
import json
import math
import random
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.representation import OnlineGraph
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.manager import (
    Ack,
    Command,
    Directive,
    HumanAction,
    Stop,
    Suggest,
    TaskManager,
)
from flexhrc.taskmanager.simulator import (
    AnalyticSimulator,
    ExecutionModel,
    Simulator,
    default_simulator,
)

PROFILES = ("passive", "takeover", "cooperative", "random")


@dataclass
class InjectedFailure:
    """Make the ``nth`` execution of ``action`` (by ``agent``, any if None) fail half way."""

    action: str
    nth: int = 1
    agent: str | None = None
    reason: str = "injected failure"
    status: str = "failed"  # or timed_out


@dataclass
class RunResult:
    outcome: str
    reason: str | None
    events: list[dict[str, Any]]
    summary: dict[str, Any]

    def save_log(self, path: str | Path) -> None:
        with open(path, "w", encoding="utf-8") as fh:
            for ev in self.events:
                fh.write(json.dumps(ev) + "\n")


@dataclass
class _Pending:
    kind: str  # robot_done | human_done | human_think
    data: dict[str, Any]
    cancelled: bool = False


@dataclass
class _HumanPlan:
    steps: list[GroundAction]
    index: int = 0
    suggested: bool = False
    element: str | None = None


class CooperationRun:
    """Run one cooperation to its end."""

    def __init__(
        self,
        graph: OnlineGraph,
        domain: Domain,
        kb: KnowledgeBase,
        *,
        simulator: Simulator | None = None,
        execution: ExecutionModel | None = None,
        human_profile: str = "passive",
        seed: int = 0,
        failures: list[InjectedFailure] | None = None,
        timeout_factor: float = 3.0,
        trace: Callable[[dict[str, Any]], None] | None = None,
        realtime: float = 0.0,
        max_time_s: float = 3600.0,
        human_takes: Iterable[int] | None = None,
        human_sensing: Any = None,
    ):
        if human_profile not in PROFILES:
            raise FlexhrcError(
                f"unknown human profile {human_profile!r}; choose one of {', '.join(PROFILES)}"
            )
        self.graph = graph
        self.domain = domain
        self.kb = kb
        self.simulator = simulator if simulator is not None else default_simulator()
        if execution is None:  # the simulator plays the real world too, when it can
            sim: Any = self.simulator
            execution = sim if hasattr(sim, "execute") else AnalyticSimulator()
        self.execution: ExecutionModel = execution
        self.profile = human_profile
        # a scripted operator: takes exactly these bolts (1-based), whatever the profile says
        self.human_takes = set(human_takes) if human_takes is not None else None
        # None: the Task Manager is told what the operator did; else an object with
        # sense(action) -> result with .recognised (task action or None) and .to_dict()
        self.human_sensing = human_sensing
        self.rng = random.Random(seed)
        self.failures = list(failures or [])
        self._failure_counts: dict[int, int] = {}
        self.timeout_factor = timeout_factor
        self.trace = trace
        self.realtime = realtime
        self.max_time_s = max_time_s
        self.events: list[dict[str, Any]] = []
        self.tm = TaskManager(graph, domain, kb, self.simulator, log=self._record)
        self.now = 0.0
        self._queue: list[tuple[float, int, _Pending]] = []
        self._seq = itertools.count()
        self._by_command: dict[int, _Pending] = {}
        self._starts: dict[int, float] = {}
        self.human_plan: _HumanPlan | None = None
        self._human_decided: set[str] = set()
        self._has_human = any(a.is_human for a in domain.agents.values())
        self.robot_time = 0.0
        self.human_time = 0.0
        self.robot_actions = 0
        self.human_actions = 0
        self.legs_by_agent: dict[str, int] = {a: 0 for a in domain.agents}

    # -- logging --------------------------------------------------------------------------
    def _record(self, ev: dict[str, Any]) -> None:
        self.events.append(ev)
        if self.trace:
            self.trace(ev)

    def _event(self, type: str, **data: Any) -> None:
        self._record({"t": round(self.now, 6), "type": type, **data})

    # -- the loop -------------------------------------------------------------------------
    def _push(self, at: float, pending: _Pending) -> None:
        heapq.heappush(self._queue, (at, next(self._seq), pending))

    def run(self) -> RunResult:
        wall0 = time.perf_counter()
        self._event("start", profile=self.profile, agents=list(self.domain.agents))
        self._dispatch(self.tm.start(0.0))
        self._human_consider()
        while not self.tm.done:
            if not self._queue:
                self.tm.outcome = "failed"
                self.tm.reason = "deadlock: no agent has anything to do and the task is not solved"
                self._event("outcome", outcome="failed", reason=self.tm.reason)
                break
            at, _, pending = heapq.heappop(self._queue)
            if pending.cancelled:
                continue
            if at > self.max_time_s:
                self.tm.outcome, self.tm.reason = (
                    "failed",
                    f"time budget {self.max_time_s} s exceeded",
                )
                self._event("outcome", outcome="failed", reason=self.tm.reason)
                break
            if self.realtime > 0:
                lag = (at - self.now) / self.realtime - 0.0
                if lag > 0:
                    time.sleep(min(lag, 5.0))
            self.now = at
            if pending.kind == "robot_done":
                self._robot_done(pending.data)
            elif pending.kind == "human_done":
                self._human_done(pending.data)
            elif pending.kind == "human_think":
                self._human_start_own(pending.data)
            else:
                self._on_event(pending)
            self._human_consider()
        summary = self.summary(time.perf_counter() - wall0)
        self._record({"t": round(self.now, 6), "type": "summary", **summary})
        return RunResult(self.tm.outcome, self.tm.reason, self.events, summary)

    def _dispatch(self, directives: list[Directive]) -> None:
        for d in directives:
            if isinstance(d, Command):
                self._start_robot(d)
            elif isinstance(d, Stop):
                self._stop(d)
            elif isinstance(d, Suggest):
                self._suggest(d)

    # -- robots ---------------------------------------------------------------------------
    def _positions(self) -> dict[str, tuple[float, float, float]]:
        return {k: o.position for k, o in self.kb.objects.items()}

    def _start_robot(self, cmd: Command) -> None:
        positions = self._positions()
        report = self.execution.execute(cmd.action, positions, self.kb, self.domain)
        status, duration = report.status, report.duration_s
        reason = None if status == "done" else report.reason
        for f in self.failures:
            if f.action == cmd.action.name and (f.agent is None or f.agent in cmd.agents):
                n = self._failure_counts.get(id(f), 0) + 1
                self._failure_counts[id(f)] = n
                if n == f.nth:
                    status, reason, duration = f.status, f.reason, duration / 2
        limit = max(cmd.expected_s * self.timeout_factor, 1.0)
        if status == "done" and duration > limit:
            status, reason, duration = "timed_out", f"no result after {limit:.1f} s", limit
        pending = _Pending(
            "robot_done",
            {"cmd": cmd, "status": status, "reason": reason, "positions": positions},
        )
        self._by_command[cmd.id] = pending
        self._starts[cmd.id] = self.now
        self._push(self.now + duration, pending)
        self._event(
            "action_start",
            agents=list(cmd.agents),
            action=str(cmd.action),
            command=cmd.id,
            element=cmd.element,
            planned_s=round(duration, 6),
        )

    def _stop(self, stop: Stop) -> None:
        pending = self._by_command.pop(stop.command_id, None)
        if pending is not None and not pending.cancelled:
            pending.cancelled = True
            cmd: Command = pending.data["cmd"]
            t0 = self._starts.pop(cmd.id, self.now)
            self.robot_time += self.now - t0
            self._event(
                "action_end",
                agents=list(cmd.agents),
                action=str(cmd.action),
                command=cmd.id,
                status="stopped",
                start=round(t0, 6),
                reason=stop.reason,
            )

    def _robot_done(self, data: dict[str, Any]) -> None:
        cmd: Command = data["cmd"]
        self._by_command.pop(cmd.id, None)
        t0 = self._starts.pop(cmd.id, self.now)
        self.robot_time += self.now - t0
        status = data["status"]
        if status == "done":
            self.robot_actions += 1
            # the physical side of the action: where things are now
            for k, p in data["positions"].items():
                if k in self.kb.objects and self.kb.position(k) != p:
                    self.kb.move(k, p)
            if cmd.action.schema.kind == "screw":
                leg = cmd.action.args[1]
                self.kb.set_fixed(leg)
                for a in cmd.agents:
                    self.legs_by_agent[a] = self.legs_by_agent.get(a, 0) + 1
        self._event(
            "action_end",
            agents=list(cmd.agents),
            action=str(cmd.action),
            command=cmd.id,
            status=status,
            start=round(t0, 6),
            reason=data["reason"],
            element=cmd.element,
        )
        self._dispatch(self.tm.on_ack(self.now, Ack(cmd.id, status, data["reason"])))

    # -- the human ------------------------------------------------------------------------
    def _suggest(self, s: Suggest) -> None:
        self._event("human_told", element=s.element, actions=[str(a) for a in s.actions])
        if self.human_plan is not None:  # busy with its own idea: it switches to the request
            for _, _, p in self._queue:
                if p.kind in ("human_done", "human_think"):
                    p.cancelled = True
        self.human_plan = _HumanPlan(list(s.actions), 0, True, s.element)
        self._human_next()

    def _human_next(self) -> None:
        plan = self.human_plan
        if plan is None or plan.index >= len(plan.steps):
            self.human_plan = None
            return
        step = plan.steps[plan.index]
        positions = self._positions()
        duration = self.execution.execute(step, positions, self.kb, self.domain).duration_s
        self._push(
            self.now + duration,
            _Pending("human_done", {"step": step, "start": self.now, "positions": positions}),
        )
        self._event(
            "action_start", agents=["human"], action=str(step), planned_s=round(duration, 6)
        )

    def _on_event(self, pending: _Pending) -> None:
        """Other kinds of scheduled events (subclasses schedule their own)."""
        raise FlexhrcError(f"unknown event kind {pending.kind!r}")

    def _sensed(self, step: GroundAction) -> HumanAction | None:
        """What the Task Manager learns of a human action: the performed one, or what the
        wearable sensor recognised — nothing when it missed it (a miss is a miss). The object
        (which leg) comes from scene perception."""
        if self.human_sensing is None:
            return HumanAction(step.name, step.args)
        sensed = self.human_sensing.sense(step.name)
        self._event("human_sensed", action=str(step), **sensed.to_dict())
        if sensed.recognised is None:
            self._event("human_sensing_missed", action=str(step))
            return None
        return HumanAction(str(sensed.recognised), step.args)

    def _human_effects(self, step: GroundAction) -> None:
        """The physical side of a completed human action, in the knowledge base."""
        if step.schema.kind == "pick_up":
            obj = step.args[1]
            self.kb.move(
                obj, self.kb.position("human") if "human" in self.kb.objects else (1.2, 0, 0.1)
            )
        if step.schema.kind == "screw":
            leg, bolt = step.args[1], step.args[2]
            self.kb.move(leg, self.kb.position(bolt))
            self.kb.set_fixed(leg)
        if step.schema.kind == "put_down":
            self.kb.retract_fact("held_by_human", step.args[1])
            self.kb.assert_fact("on_table", step.args[1])

    def _taken_by_robot(self, obj: str) -> str | None:
        for fact in self.kb.facts:
            if fact[0] == "holding" and fact[2] == obj:
                return fact[1]
        return None

    def _human_done(self, data: dict[str, Any]) -> None:
        step: GroundAction = data["step"]
        t0 = data["start"]
        if step.schema.kind == "pick_up" and (arm := self._taken_by_robot(step.args[1])):
            # the robot grasped it first: the operator does not pull it out of the gripper
            self.human_time += self.now - t0
            self._event(
                "action_end",
                agents=["human"],
                action=str(step),
                status="failed",
                start=round(t0, 6),
                reason=f"{step.args[1]} already in the {arm} gripper",
            )
            self._event("human_gives_up", leg=step.args[1], holder=arm)
            self.human_plan = None
            return
        self.human_time += self.now - t0
        self.human_actions += 1
        self._event(
            "action_end", agents=["human"], action=str(step), status="done", start=round(t0, 6)
        )
        self._human_effects(step)
        if step.schema.kind == "screw":
            self.legs_by_agent["human"] = self.legs_by_agent.get("human", 0) + 1
        if step.schema.kind == "put_down":
            self.human_plan = None
            return
        sensed = self._sensed(step)
        if sensed is not None:
            self._dispatch(self.tm.on_human_action(self.now, sensed))
        plan = self.human_plan
        if plan is None:
            return
        plan.index += 1
        ex = self._human_execution(step)
        if ex is None and step.schema.kind == "pick_up":
            # nothing this action advances any more: put the leg back down
            put = self.domain.actions.get("put_down")
            if put is not None:
                plan.steps = [GroundAction(put, ("human", step.args[1]), ("human",))]
                plan.index = 0
                self._human_next()
            else:
                self.human_plan = None
            return
        if ex is not None and not plan.suggested:
            plan.steps = list(ex.branch.steps)
            plan.index = ex.next_index
        self._human_next()

    def _human_execution(self, step: GroundAction) -> Any:
        for ex in self.tm.executions.values():
            if ex.owner == "human" and step.args[1] in ex.branch.grounding.values():
                return ex
        return None

    def _next_bolt(self) -> str | None:
        """The bolt the operator can work on now: the first empty one whose predecessor is
        connected in the cooperation state (the bolts are filled in a fixed order)."""
        k = 1
        while f"bolt_{k}" in self.kb.objects:
            if not self.kb.holds("filled", f"bolt_{k}"):
                before = f"connected_{k - 1}" if k > 1 else None
                if before is None or self._met(before):
                    return f"bolt_{k}"
                return None
            k += 1
        return None

    def _met(self, node: str) -> bool:
        try:
            return self.graph.is_met(node)
        except KeyError:
            return False

    def _human_consider(self) -> None:
        """Profiles that act on their own decide here whether to take the next leg."""
        if not self._has_human or self.tm.done:
            return
        if self.profile == "passive" and self.human_takes is None:
            return
        if self.human_plan is not None:
            return
        if any(ex.owner == "human" for ex in self.tm.executions.values()):
            return
        bolt = self._next_bolt()
        if bolt is None or bolt in self._human_decided:
            return
        self._human_decided.add(bolt)
        if self.human_takes is not None:
            act, delay = int(bolt.rsplit("_", 1)[1]) in self.human_takes, 0.0
        elif self.profile == "takeover":
            act, delay = True, 0.0
        elif self.profile == "cooperative":
            act, delay = self.rng.random() < 0.5, self.rng.uniform(0.5, 2.0)
        else:  # random
            act, delay = self.rng.random() < 0.4, self.rng.uniform(0.0, 6.0)
        if act:
            self.human_plan = _HumanPlan([], 0, False, None)
            self._push(self.now + delay, _Pending("human_think", {"bolt": bolt}))

    def _human_start_own(self, data: dict[str, Any]) -> None:
        if self.human_plan is None or self.human_plan.suggested:
            return
        if self._next_bolt() != data["bolt"]:  # meanwhile the robot got there first
            self.human_plan = None
            self._event("human_gives_up", bolt=data["bolt"], holder="robot")
            return
        busy_objects = set().union(*(ex.objects for ex in self.tm.executions.values()))
        hand = self.kb.position("human") if "human" in self.kb.objects else (1.2, 0.0, 0.1)
        on_table = [
            o.id
            for o in self.kb.objects_of_type("leg")
            if self.kb.holds("on_table", o.id) or self.kb.holds("at", o.id, "middle")
        ]
        # a leg the robot only plans to use is still free to take; prefer the others
        legs = [leg for leg in on_table if leg not in busy_objects] or on_table
        if not legs:
            self.human_plan = None
            return
        if self.profile == "random":
            leg = self.rng.choice(sorted(legs))
        else:
            leg = min(legs, key=lambda lid: (math.dist(hand, self.kb.position(lid)), lid))
        pick = self.domain.actions["pick_up"]
        self.human_plan = _HumanPlan([GroundAction(pick, ("human", leg), ("human",))], 0, False)
        self._event("human_decides", leg=leg, bolt=data["bolt"])
        self._human_next()

    # -- results --------------------------------------------------------------------------
    def summary(self, wall_s: float) -> dict[str, Any]:
        tm = self.tm.summary()
        return {
            "outcome": tm["outcome"],
            "reason": tm["reason"],
            "robot_actions": self.robot_actions,
            "human_actions": self.human_actions,
            "decisions": tm["decisions"],
            "branches_simulated": tm["branches_simulated"],
            "timing": {
                **tm["timing"],
                "robot_actions_s": round(self.robot_time, 6),
                "human_actions_s": round(self.human_time, 6),
                "total_s": round(self.now, 6),
            },
            "legs_by_agent": {a: n for a, n in self.legs_by_agent.items()},
            "wall_s": wall_s,
        }


def table_i(summary: dict[str, Any]) -> str:
    """The paper's Table I from a run summary."""
    t = summary["timing"]
    rows = [
        ("Task Manager", t["task_manager_s"]),
        ("Task Representation", t["task_representation_s"]),
        ("Simulator", t["simulator_s"]),
        ("Robot actions", t["robot_actions_s"]),
        ("Human actions", t["human_actions_s"]),
    ]
    total = sum(v for _, v in rows)
    lines = [f"{'Computation':<22}{'time [s]':>12}{'time [%]':>10}"]
    for name, v in rows:
        lines.append(f"{name:<22}{v:>12.4f}{100 * v / total if total else 0:>10.2f}")
    lines.append(f"{'Total':<22}{total:>12.4f}{100.0:>10.2f}")
    lines.append(f"(assembly makespan on the simulated clock: {t['total_s']:.2f} s)")
    return "\n".join(lines)
