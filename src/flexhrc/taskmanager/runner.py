"""A whole cooperation on a simulated clock: Task Manager + simulated arms + simulated human.

:class:`CooperationRun` is a discrete-event loop. The Task Manager's :class:`Command` goes to a
simulated robot arm (or both, for a joint command), which finishes it after the time the
execution model gives (or fails, when a failure is injected, or times out); its
:class:`Suggest` goes to the simulated operator it names; a :class:`Stop` cancels a command.
The operators are generic :class:`~flexhrc.taskmanager.operator.SimulatedOperator` s: they
follow suggestions and, per profile, act on their own on the hyper-arcs the domain lets a human
do:

* ``passive`` — only when asked;
* ``takeover`` — takes every cooperation step it can (paper Fig. 10);
* ``cooperative`` — takes a step now and then (seeded; Fig. 11);
* ``random`` — acts at random moments with random objects (seeded).

``human_takes`` scripts the (first) operator instead: it takes exactly the K-th cooperation
steps listed (1-based; for the table: bolt K). ``humans`` names several operators, each with
its own profile.

The physical side of an action comes from the domain, not from code: ``carries: ?obj`` moves
the object to where the hand ends (its ``moves_to`` target), ``fixes: ?obj`` fixes it in place
(a ``fixed`` event; ``legs_by_agent`` counts the objects each agent fixed — the name is the
table demo's), ``undo: ACTION`` is what an operator does when its action turned out to advance
nothing (put the part back).

Nothing sleeps (unless ``realtime``), so a whole assembly takes milliseconds of wall time. Every
decision, command, acknowledgement and human action is recorded in :attr:`RunResult.events`
(JSON-serialisable dicts, written as JSON lines by :meth:`RunResult.save_log`) and handed, as it
happens, to the ``sink`` — e.g. :meth:`flexhrc.files.EventLogWriter.write`, so a run killed
half way leaves its log up to the last event. :meth:`CooperationRun.request_stop` (from a signal
handler) ends the run at the next event with the outcome ``interrupted``.
"""

from __future__ import annotations

import heapq
import itertools
import json
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
from flexhrc.taskmanager.operator import Intention, SimulatedOperator
from flexhrc.taskmanager.simulator import (
    AnalyticSimulator,
    ExecutionModel,
    Simulator,
    default_simulator,
    simulator_name,
)

PROFILES = ("passive", "takeover", "cooperative", "random")
#: Every outcome a cooperation run can end with (the ``outcome`` event and the summary).
OUTCOMES = ("solved", "failed", "interrupted")


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
        """Write the whole log at once, atomically (the CLI streams it instead, event by event,
        with :class:`flexhrc.files.EventLogWriter` as the run's ``sink``)."""
        from flexhrc.files import atomic_write_text

        atomic_write_text(path, "".join(json.dumps(ev) + "\n" for ev in self.events))


@dataclass
class _Pending:
    kind: str  # robot_done | human_done | human_think
    data: dict[str, Any]
    cancelled: bool = False


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
        human_takes: Iterable[int | str] | None = None,
        human_sensing: Any = None,
        sink: Callable[[dict[str, Any]], None] | None = None,
        humans: Iterable[tuple[str, str]] | None = None,
        reaction: str = "conflicts",
    ):
        if human_profile not in PROFILES:
            raise FlexhrcError(
                f"unknown human profile {human_profile!r}; choose one of {', '.join(PROFILES)}"
            )
        self.graph = graph
        self.domain = domain
        self.kb = kb
        self.simulator = simulator if simulator is not None else default_simulator()
        self.simulator_name = simulator_name(self.simulator)
        if execution is None:  # the simulator plays the real world too, when it can
            sim: Any = self.simulator
            execution = sim if hasattr(sim, "execute") else AnalyticSimulator()
        self.execution: ExecutionModel = execution
        self.profile = human_profile
        # a scripted operator: takes exactly these steps (1-based), whatever the profile says
        self.human_takes = set(human_takes) if human_takes is not None else None
        # the operators: (agent name, profile) each; by default every human agent, one profile
        pairs = (
            list(humans)
            if humans is not None
            else [(a.name, human_profile) for a in domain.agents.values() if a.is_human]
        )
        self.operators: dict[str, SimulatedOperator] = {}
        for i, (name, prof) in enumerate(pairs):
            if prof not in PROFILES:
                raise FlexhrcError(
                    f"unknown human profile {prof!r}; choose one of {', '.join(PROFILES)}"
                )
            if not domain.agent(name).is_human:
                raise FlexhrcError(f"operator {name!r} is not a human agent of the domain")
            self.operators[name] = SimulatedOperator(
                name, prof, seed * 1009 + i, self.human_takes if i == 0 else None
            )
        # None: the Task Manager is told what the operator did; else an object with
        # sense(action) -> result with .recognised (task action or None) and .to_dict()
        self.human_sensing = human_sensing
        self.failures = list(failures or [])
        self._failure_counts: dict[int, int] = {}
        self.timeout_factor = timeout_factor
        self.trace = trace
        # every event, as it happens (a streamed log); the in-memory list is kept as well
        self.sink = sink
        self._stop_reason: str | None = None
        self.realtime = realtime
        self.max_time_s = max_time_s
        self.events: list[dict[str, Any]] = []
        self.tm = TaskManager(
            graph, domain, kb, self.simulator, log=self._record, reaction=reaction
        )
        self.now = 0.0
        self._queue: list[tuple[float, int, _Pending]] = []
        self._seq = itertools.count()
        self._by_command: dict[int, _Pending] = {}
        self._starts: dict[int, float] = {}
        self._has_human = bool(self.operators)
        self.robot_time = 0.0
        self.human_time = 0.0
        self.robot_actions = 0
        self.human_actions = 0
        self.legs_by_agent: dict[str, int] = {a: 0 for a in domain.agents}
        self.solved_hyperarcs: list[dict[str, Any]] = []

    # -- logging --------------------------------------------------------------------------
    def _record(self, ev: dict[str, Any]) -> None:
        if ev.get("type") == "solved":
            self.solved_hyperarcs.append(
                {"hyperarc": ev["element"], "agent": "+".join(ev["agents"]), "t": ev["t"]}
            )
        self.events.append(ev)
        if self.sink is not None:  # first to the log: what was shown was also stored
            self.sink(ev)
        if self.trace:
            self.trace(ev)

    def _event(self, type: str, **data: Any) -> None:
        self._record({"t": round(self.now, 6), "type": type, **data})

    # -- the loop -------------------------------------------------------------------------
    def _push(self, at: float, pending: _Pending) -> None:
        heapq.heappush(self._queue, (at, next(self._seq), pending))

    def request_stop(self, reason: str = "interrupted") -> None:
        """Ask the run to end at the next event with the outcome ``interrupted`` (safe to call
        from a signal handler: it only sets a flag, the loop writes the final events)."""
        self._stop_reason = reason

    def _interrupted(self) -> bool:
        if self._stop_reason is None or self.tm.done:
            return False
        self.tm.outcome, self.tm.reason = "interrupted", self._stop_reason
        self._event("outcome", outcome="interrupted", reason=self._stop_reason)
        return True

    def _pace(self, at: float) -> None:
        """Realtime mode: sleep until the simulated clock reaches ``at`` (in short naps, so a
        stop request is honoured at once)."""
        deadline = time.monotonic() + min((at - self.now) / self.realtime, 5.0)
        while self._stop_reason is None:
            left = deadline - time.monotonic()
            if left <= 0:
                return
            time.sleep(min(left, 0.05))

    def run(self) -> RunResult:
        wall0 = time.perf_counter()
        self._event(
            "start",
            profile=self.profile,
            agents=list(self.domain.agents),
            humans=list(self.operators),
            simulator=self.simulator_name,
        )
        if not self._interrupted():
            self._before_start()
            self._dispatch(self.tm.start(0.0))
            self._human_consider()
        while not self.tm.done:
            if self._interrupted():
                break
            if not self._queue:
                self.tm.outcome = "failed"
                self.tm.reason = self._deadlock_reason()
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
            if self.realtime > 0 and at > self.now:
                self._pace(at)
                if self._interrupted():
                    break
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
        before = dict(positions)
        report = self.execution.execute(cmd.action, positions, self.kb, self.domain)
        status, duration = report.status, report.duration_s
        # what this action moves; the rest may be moved by others while it runs
        moved = {k: p for k, p in positions.items() if before.get(k) != p}
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
            {"cmd": cmd, "status": status, "reason": reason, "positions": moved},
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
            self._physical(cmd.action, data["positions"])
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

    # -- physical effects ---------------------------------------------------------------
    def _physical(self, action: GroundAction, positions: dict[str, Any]) -> None:
        """What an action does to the world besides its facts, as the domain declares it."""
        schema = action.schema
        binding = action.binding
        where = None
        if schema.moves_to and binding.get(schema.moves_to) in self.kb.objects:
            where = self.kb.position(binding[schema.moves_to])
        for agent in action.agents:
            if (
                agent in positions
                and agent in self.kb.objects
                and self.domain.agent(agent).is_human
            ):
                self.kb.move(agent, positions[agent])
        carried = binding.get(schema.carries) if schema.carries else None
        if carried in self.kb.objects and not self.kb.object(carried).fixed:
            hand = positions.get(action.agents[0]) if action.agents else None
            target = where or hand
            if target is not None:
                self.kb.move(carried, target)
        fixed = binding.get(schema.fixes) if schema.fixes else None
        if fixed in self.kb.objects:
            self.kb.set_fixed(fixed)
            self._event("fixed", object=fixed, agents=list(action.agents), action=str(action))
            for a in action.agents:
                self.legs_by_agent[a] = self.legs_by_agent.get(a, 0) + 1

    # -- the operators --------------------------------------------------------------------
    def _operator_of(self, agents: Iterable[str]) -> SimulatedOperator | None:
        for a in agents:
            if a in self.operators:
                return self.operators[a]
        return None

    def _cancel_pending(self, op: SimulatedOperator) -> None:
        for _, _, p in self._queue:
            if p.kind in ("human_done", "human_think") and p.data.get("who") == op.name:
                p.cancelled = True

    def _suggest(self, s: Suggest) -> None:
        self._event(
            "human_told",
            element=s.element,
            agents=list(s.agents),
            actions=[str(a) for a in s.actions],
        )
        op = self._operator_of(s.agents)
        if op is None:
            return
        if op.plan is not None:  # busy with its own idea: it switches to the request
            self._cancel_pending(op)
        op.follow(s.element, list(s.actions))
        self._human_next(op)

    def _human_next(self, op: SimulatedOperator) -> None:
        plan = op.plan
        if plan is None or plan.index >= len(plan.steps):
            op.plan = None
            return
        step = plan.steps[plan.index]
        positions = self._positions()
        duration = self.execution.execute(step, positions, self.kb, self.domain).duration_s
        self._push(
            self.now + duration,
            _Pending(
                "human_done",
                {"who": op.name, "step": step, "start": self.now, "positions": positions},
            ),
        )
        self._event(
            "action_start", agents=[op.name], action=str(step), planned_s=round(duration, 6)
        )

    def _before_start(self) -> None:
        """Called once, after the ``start`` event and before the manager's first decision."""

    def _deadlock_reason(self) -> str:
        from flexhrc.taskmanager.diagnose import stall_reason

        return stall_reason(self.tm)

    def _on_event(self, pending: _Pending) -> None:
        """Other kinds of scheduled events (subclasses schedule their own)."""
        raise FlexhrcError(f"unknown event kind {pending.kind!r}")

    def _sensed(self, step: GroundAction) -> HumanAction | None:
        """What the Task Manager learns of a human action: the performed one, or what the
        wearable sensor recognised — nothing when it missed it (a miss is a miss: scene
        perception may still see the part move). The objects come from scene perception."""
        if self.human_sensing is None:
            return HumanAction(step.name, step.args)
        sensed = self.human_sensing.sense(step.name)
        self._event("human_sensed", action=str(step), **sensed.to_dict())
        if sensed.recognised is None:
            if not sensed.samples:
                # no motion of the sensor plays this action (e.g. a visual check): the operator
                # confirms it some other way (the panel's "done")
                self._event("human_sensing_uncovered", action=str(step))
                return HumanAction(step.name, step.args)
            self._event("human_sensing_missed", action=str(step))
            return None
        return HumanAction(str(sensed.recognised), step.args)

    def _human_done(self, data: dict[str, Any]) -> None:
        op = self.operators[data["who"]]
        step: GroundAction = data["step"]
        t0 = data["start"]
        self.human_time += self.now - t0
        holder = op.holder_of(self.kb, self.domain, step)
        if holder is not None:
            # another agent took the part first: the operator does not pull it out of its hand
            obj = next((a for a in step.args if a in self.kb.objects and a != op.name), None)
            self._event(
                "action_end",
                agents=[op.name],
                action=str(step),
                status="failed",
                start=round(t0, 6),
                reason=f"{obj} already held by {holder}",
            )
            self._event("human_gives_up", object=obj, holder=holder, agent=op.name)
            op.plan = None
            return
        self.human_actions += 1
        self._event(
            "action_end", agents=[op.name], action=str(step), status="done", start=round(t0, 6)
        )
        self._physical(step, data["positions"])
        plan = op.plan
        if plan is not None and plan.element == "undo":
            # putting a part back is no task action: only its facts change
            self.kb.apply_effects(step.schema.add, step.schema.delete, step.binding)
            op.plan = None
            return
        sensed = self._sensed(step)
        if sensed is not None:
            self._dispatch(self.tm.on_human_action(self.now, sensed))
        if op.plan is not plan or plan is None:
            return  # a new suggestion came with this action's consequences: it is under way
        plan.index += 1
        ex = self._execution_of(op, step)
        if ex is None:
            if plan.index < len(plan.steps):
                # nothing this action advances any more: undo it (put the part back), or stop
                undo = self.domain.actions.get(step.schema.undo) if step.schema.undo else None
                if undo is not None:
                    args = tuple(step.args[: len(undo.parameters)])
                    op.plan = type(plan)([GroundAction(undo, args, (op.name,))], 0, False, "undo")
                    self._human_next(op)
                    return
            op.plan = None
            return
        if not plan.suggested:
            plan.steps = list(ex.branch.steps)
            plan.index = ex.next_index
        self._human_next(op)

    def _execution_of(self, op: SimulatedOperator, step: GroundAction) -> Any:
        """The operator's running execution that ``step`` just advanced."""
        for ex in self.tm.executions.values():
            if ex.owner != "human" or op.name not in ex.agents:
                continue
            done = ex.branch.steps[: ex.next_index]
            if done and str(done[-1]) == str(step):
                return ex
        return None

    def _human_consider(self) -> None:
        """Operators that act on their own decide here whether to take the next step."""
        if not self._has_human or self.tm.done:
            return
        for op in self.operators.values():
            intention = op.consider(self.tm)
            if intention is not None:
                self._push(
                    self.now + intention.delay_s,
                    _Pending("human_think", {"who": op.name, "intention": intention}),
                )

    def _human_start_own(self, data: dict[str, Any]) -> None:
        op = self.operators[data["who"]]
        intention: Intention = data["intention"]
        if op.plan is None or op.plan.suggested:
            return
        steps = op.start_own(self.tm, self.kb, intention)
        if steps is None:
            self._event("human_gives_up", step=intention.step, holder="robot", agent=op.name)
            return
        self._event(
            "human_decides",
            agent=op.name,
            element=intention.hyperarc,
            step=intention.step,
            actions=[str(a) for a in steps],
        )
        self._human_next(op)

    # -- results --------------------------------------------------------------------------
    def operator_profiles(self) -> list[tuple[str, str]]:
        """(operator, profile) of this run."""
        return [(op.name, op.profile) for op in self.operators.values()]

    def unfired_failures(self) -> list[InjectedFailure]:
        """Injected failures whose N-th execution never came (e.g. ``transport:99``)."""
        return [f for f in self.failures if self._failure_counts.get(id(f), 0) < f.nth]

    def executions_of(self, action: str) -> int:
        """How many times robot commands of ``action`` were started in this run."""
        return sum(
            1
            for ev in self.events
            if ev["type"] == "action_start"
            and ev["agents"] != ["human"]
            and ev["action"].split("(", 1)[0] == action
        )

    def summary(self, wall_s: float) -> dict[str, Any]:
        tm = self.tm.summary()
        return {
            "outcome": tm["outcome"],
            "reason": tm["reason"],
            "simulator": self.simulator_name,
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
            "solved_hyperarcs": list(self.solved_hyperarcs),
            "by_agent": self._by_agent(),
            "wall_s": wall_s,
        }

    def _by_agent(self) -> dict[str, int]:
        counts = {a: 0 for a in self.domain.agents}
        for item in self.solved_hyperarcs:
            for a in item["agent"].split("+"):
                counts[a] = counts.get(a, 0) + 1
        return counts


def table_i(summary: dict[str, Any]) -> str:
    """The paper's Table I from a run summary, in two parts that are never added up.

    Compute (wall clock of this process: Task Manager, task representation, simulator) and
    simulated time (how long the agents' actions take on the simulated clock) are different
    quantities; the paper's Table I puts them in one column, which here would add milliseconds
    of computation to minutes of make-believe motion.
    """
    t = summary["timing"]
    compute = [
        ("Task Manager", t["task_manager_s"]),
        ("Task Representation", t["task_representation_s"]),
        ("Simulator", t["simulator_s"]),
    ]
    simulated = [
        ("Robot actions", t["robot_actions_s"]),
        ("Human actions", t["human_actions_s"]),
    ]
    sim = summary.get("simulator")
    head = f"Computation ({sim} simulator)" if sim else "Computation (wall clock)"
    total = sum(v for _, v in compute)
    lines = [f"{head:<34}{'time [s]':>12}{'time [%]':>10}"]
    if summary.get("compute_recorded", True):
        for name, v in compute:
            lines.append(f"{name:<34}{v:>12.4f}{100 * v / total if total else 0:>10.2f}")
        lines.append(f"{'Compute total (wall clock)':<34}{total:>12.4f}{100.0:>10.2f}")
    else:  # a log cut short before its closing summary: the compute was never written down
        for name, _ in compute:
            lines.append(f"{name:<34}{'n/a':>12}{'':>10}")
        lines.append("(not recorded: the log ends before the run's closing summary)")
    lines.append("")
    lines.append(f"{'Simulated time (simulated clock)':<34}{'time [s]':>12}")
    for name, v in simulated:
        lines.append(f"{name:<34}{v:>12.2f}")
    lines.append(f"{'Assembly makespan':<34}{t['total_s']:>12.2f}")
    lines.append("(robot and human action times overlap; they add up to more than the makespan)")
    return "\n".join(lines)
