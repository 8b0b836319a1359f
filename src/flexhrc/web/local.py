"""An in-process cooperation driven by the panel: the operator acts only through the page.

:class:`LocalCooperation` is a :class:`~flexhrc.web.backend.PanelBackend` over the sans-IO
:class:`~flexhrc.taskmanager.TaskManager` with simulated robot arms on a wall clock (``speed``
simulated seconds per second) and **no simulated operator**: every human action is a button the
person presses (``done`` on a suggested action, ``I'll do this`` on a hyper-arc) or a
``POST /api/human``. It is the panel's embedded default (``flexhrc panel``) and the reference a
live cell's backend is tested against.

A human input is first tried on a copy of the manager, so an input the manager would not match
(an action that advances no feasible element) is refused with nothing changed — neither the
event log nor the knowledge base.

:class:`PanelTaskManager` adds to the Task Manager the two operator inputs a person at a panel
has and a recognised action has not: *take* — "I will do this hyper-arc" (the robot leaves that
part, as when the paper's manager recognises an unsuggested human action, section V) — and
*stop* of one arm (the arm is out of use until it is resumed).
"""

from __future__ import annotations

import heapq
import itertools
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

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
from flexhrc.taskmanager.simulator import AnalyticSimulator, ExecutionModel, Simulator
from flexhrc.web import operator
from flexhrc.web.backend import PanelInputError, json_safe, parse_action
from flexhrc.web.snapshot import feasible_costs, graph_snapshot, suggestions

TIMELINE_LIMIT = 300  # entries of the timeline kept in a snapshot (the store keeps them all)


class PanelTaskManager(TaskManager):
    """The Task Manager with the panel's operator inputs (see :mod:`flexhrc.web.operator`):
    take a hyper-arc, stop and resume an arm."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.halted: set[str] = set()

    def takeable(self) -> list[str]:
        return operator.takeable(self)

    def take(self, now: float, element: str) -> list[Directive]:
        return operator.take(self, now, element)

    def halt(self, now: float, agent: str) -> list[Directive]:
        """Stop ``agent``'s command (acknowledged as failed: stopped by the operator); the arm
        is unavailable to the manager until :meth:`resume`."""
        self.halted.add(agent)
        out = self.set_available(now, agent, False)
        cmd = self.busy.get(agent)
        if cmd is not None:
            out += self.on_ack(now, Ack(cmd.id, "failed", "stopped by the operator"))
        return out

    def resume(self, now: float, agent: str) -> list[Directive]:
        self.halted.discard(agent)
        return self.set_available(now, agent, True)


@dataclass
class _Pending:
    command: Command
    status: str
    reason: str | None
    positions: dict[str, tuple[float, float, float]]
    start: float  # simulated time
    cancelled: bool = False


class LocalCooperation:
    """A :class:`~flexhrc.web.backend.PanelBackend` running one cooperation in this process.

    ``speed`` is simulated seconds per wall second (robot actions of a few seconds finish in
    milliseconds at ``speed=1000``); ``clock`` is injectable for tests. Call :meth:`start` to
    begin, :meth:`close` to end the worker thread.
    """

    def __init__(
        self,
        graph: OnlineGraph,
        domain: Domain,
        kb: KnowledgeBase,
        *,
        simulator: Simulator | None = None,
        execution: ExecutionModel | None = None,
        speed: float = 1.0,
        timeout_factor: float = 3.0,
        clock: Callable[[], float] = time.monotonic,
        name: str = "cell",
    ):
        if not (speed > 0 and speed < float("inf")):
            raise PanelInputError(f"speed must be a positive number, got {speed}")
        self.name = name
        self.domain = domain
        self.kb = kb
        self.simulator = simulator if simulator is not None else AnalyticSimulator()
        self.execution: ExecutionModel = execution or AnalyticSimulator()
        self.speed = float(speed)
        self.timeout_factor = timeout_factor
        self._clock = clock
        self._t0 = clock()
        self.events: list[dict[str, Any]] = []
        self.timeline: list[dict[str, Any]] = []
        self.tm = PanelTaskManager(graph, domain, kb, self.simulator, log=self._record)
        self._lock = threading.RLock()
        self._wake = threading.Condition(self._lock)
        self._queue: list[tuple[float, int, _Pending]] = []
        self._seq = itertools.count()
        self._by_command: dict[int, _Pending] = {}
        self._listeners: dict[int, Callable[[], None]] = {}
        self._listener_ids = itertools.count()
        self._version = 0
        self._cached: tuple[int, dict[str, Any]] | None = None
        self._thread: threading.Thread | None = None
        self._closed = False
        self.started = False

    # -- time -----------------------------------------------------------------------------
    def now(self) -> float:
        """Simulated seconds since the start."""
        return (self._clock() - self._t0) * self.speed

    def set_speed(self, speed: float) -> None:
        """Change the arms' speed from now on (simulated time stays continuous)."""
        if not (speed > 0 and speed < float("inf")):
            raise PanelInputError(f"speed must be a positive number, got {speed}")
        with self._lock:
            now = self.now()
            self.speed = float(speed)
            self._t0 = self._clock() - now / self.speed
            self._wake.notify_all()

    # -- life cycle -----------------------------------------------------------------------
    def start(self, *, background: bool = True) -> None:
        """Start the cooperation; ``background=False`` leaves robot completions to
        :meth:`run_due` (tests drive the clock themselves)."""
        with self._lock:
            if self.started:
                return
            self.started = True
            self._t0 = self._clock()
            self._record({"t": 0.0, "type": "start", "agents": list(self.domain.agents)})
            self._dispatch(self.tm.start(0.0), 0.0)
            self._changed()
        if background:
            self._thread = threading.Thread(
                target=self._loop, name="flexhrc-panel-cell", daemon=True
            )
            self._thread.start()
        self._notify()

    def close(self) -> None:
        with self._lock:
            self._closed = True
            self._wake.notify_all()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def __enter__(self) -> LocalCooperation:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_done(self, timeout: float) -> bool:
        """Block until the cooperation ends (or ``timeout`` wall seconds); True if it ended."""
        deadline = time.monotonic() + timeout
        with self._lock:
            while not self.tm.done:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._wake.wait(min(left, 0.05))
            return True

    # -- the loop: robot completions on the wall clock -------------------------------------
    def next_due(self) -> float | None:
        """Simulated time of the next robot completion (None: no robot is working)."""
        with self._lock:
            live = [at for at, _, p in self._queue if not p.cancelled]
            return min(live) if live else None

    def run_due(self) -> int:
        """Process every robot completion due by now; how many."""
        done = 0
        with self._lock:
            while self._queue and not self._closed:
                at, _, pending = self._queue[0]
                if at > self.now() + 1e-9:
                    break
                heapq.heappop(self._queue)
                if not pending.cancelled:
                    self._robot_done(pending, at)
                    done += 1
        if done:
            self._notify()
        return done

    def _loop(self) -> None:
        while True:
            with self._lock:
                if self._closed:
                    return
                if not self._queue:
                    self._wake.wait(0.5)
                    continue
                at = self._queue[0][0]
                wait_s = (at / self.speed) - (self._clock() - self._t0)
                if wait_s > 0:
                    self._wake.wait(min(wait_s, 0.5))
                    continue
            self.run_due()

    def _record(self, event: dict[str, Any]) -> None:
        self.events.append(event)

    def _changed(self) -> None:
        self._version += 1
        self._wake.notify_all()

    def _notify(self) -> None:
        for cb in list(self._listeners.values()):
            cb()

    def _dispatch(self, directives: list[Directive], now: float) -> None:
        """Carry out the manager's directives at simulated time ``now`` (the time of the input
        they answer, so the timeline has no gaps of processing latency)."""
        for d in directives:
            if isinstance(d, Command):
                self._start_robot(d, now)
            elif isinstance(d, Stop):
                self._stop(d, now)
            elif isinstance(d, Suggest):
                self._record(
                    {
                        "t": round(now, 6),
                        "type": "human_told",
                        "element": d.element,
                        "actions": [str(a) for a in d.actions],
                    }
                )

    def _start_robot(self, cmd: Command, now: float) -> None:
        positions = {k: o.position for k, o in self.kb.objects.items()}
        reason: str | None
        if any(a in self.tm.halted for a in cmd.agents):
            status, reason, duration = "failed", "robot stopped by the operator", 0.0
        else:
            report = self.execution.execute(cmd.action, positions, self.kb, self.domain)
            status, duration = report.status, report.duration_s
            reason = None if status == "done" else report.reason
            limit = max(cmd.expected_s * self.timeout_factor, 1.0)
            if status == "done" and duration > limit:
                status, reason, duration = "timed_out", f"no result after {limit:.1f} s", limit
        pending = _Pending(cmd, status, reason, positions, now)
        self._by_command[cmd.id] = pending
        heapq.heappush(self._queue, (now + duration, next(self._seq), pending))
        self._record(
            {
                "t": round(now, 6),
                "type": "action_start",
                "agents": list(cmd.agents),
                "action": str(cmd.action),
                "command": cmd.id,
                "element": cmd.element,
                "planned_s": round(duration, 6),
            }
        )
        self._changed()

    def _stop(self, stop: Stop, now: float) -> None:
        pending = self._by_command.pop(stop.command_id, None)
        if pending is not None and not pending.cancelled:
            pending.cancelled = True
            self._timeline(
                pending.command.agents,
                str(pending.command.action),
                pending.start,
                now,
                "stopped",
                stop.reason,
            )

    def _robot_done(self, pending: _Pending, at: float) -> None:
        cmd = pending.command
        self._by_command.pop(cmd.id, None)
        if pending.status == "done":
            for k, p in pending.positions.items():
                if k in self.kb.objects and self.kb.position(k) != p:
                    self.kb.move(k, p)
            if cmd.action.schema.kind == "screw" and len(cmd.action.args) > 1:
                obj = cmd.action.args[1]
                if obj in self.kb.objects:
                    self.kb.set_fixed(obj)
        self._timeline(
            cmd.agents, str(cmd.action), pending.start, at, pending.status, pending.reason
        )
        self._dispatch(self.tm.on_ack(at, Ack(cmd.id, pending.status, pending.reason)), at)
        self._changed()

    def _timeline(
        self,
        agents: tuple[str, ...] | list[str],
        action: str,
        start: float,
        end: float,
        status: str,
        reason: str | None = None,
    ) -> None:
        entry = {
            "start": round(start, 3),
            "end": round(end, 3),
            "agents": list(agents),
            "action": action,
            "status": status,
        }
        if reason:
            entry["reason"] = reason
        self.timeline.append(entry)
        self._record({"t": round(end, 6), "type": "action_end", **entry})

    # -- the backend contract --------------------------------------------------------------
    def subscribe(self, callback: Callable[[], None]) -> Callable[[], None]:
        key = next(self._listener_ids)
        self._listeners[key] = callback

        def cancel() -> None:
            self._listeners.pop(key, None)

        return cancel

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            if self._cached is not None and self._cached[0] == self._version:
                return self._cached[1]
            snap = self._build_snapshot()
            self._cached = (self._version, snap)
            return snap

    def submit(self, body: Mapping[str, str]) -> dict[str, Any]:
        with self._lock:
            if not self.started:
                raise PanelInputError("the cooperation has not started", 409)
            if self.tm.done:
                raise PanelInputError(f"the cooperation has ended ({self.tm.outcome})", 409)
            if "action" in body:
                result = self._human_action(body["action"])
            elif "take" in body:
                result = self._take(body["take"])
            else:
                raise PanelInputError('send {"action": ...} or {"take": ...}')
            self._changed()
        self._notify()
        return result

    def stop_robot(self, name: str) -> dict[str, Any]:
        with self._lock:
            self._robot(name)
            if name in self.tm.halted:
                raise PanelInputError(f"robot {name!r} is already stopped", 409)
            now = self.now()
            self._record({"t": round(now, 6), "type": "operator_stop", "agent": name})
            cmd = self.tm.busy.get(name)
            if cmd is not None:
                pending = self._by_command.pop(cmd.id, None)
                if pending is not None:
                    pending.cancelled = True
                    self._timeline(
                        cmd.agents,
                        str(cmd.action),
                        pending.start,
                        now,
                        "stopped",
                        "stopped by the operator",
                    )
            self._dispatch(self.tm.halt(now, name), now)
            self._changed()
        self._notify()
        return {"ok": True, "stopped": name}

    def resume_robot(self, name: str) -> dict[str, Any]:
        with self._lock:
            self._robot(name)
            if name not in self.tm.halted:
                raise PanelInputError(f"robot {name!r} is not stopped", 409)
            now = self.now()
            self._record({"t": round(now, 6), "type": "operator_resume", "agent": name})
            self._dispatch(self.tm.resume(now, name), now)
            self._changed()
        self._notify()
        return {"ok": True, "resumed": name}

    # -- inputs -----------------------------------------------------------------------------
    def _robot(self, name: str) -> None:
        agent = self.domain.agents.get(name)
        if agent is None:
            robots = ", ".join(a.name for a in self.domain.agents.values() if not a.is_human)
            raise PanelInputError(f"unknown robot {name!r}; robots: {robots}", 404)
        if agent.is_human:
            raise PanelInputError(f"{name!r} is an operator, not a robot", 400)

    def _ground(self, text: str) -> GroundAction:
        name, args = parse_action(text)
        schema = self.domain.actions.get(name)
        if schema is None:
            known = ", ".join(sorted(self.domain.actions))
            raise PanelInputError(f"unknown action {name!r}; actions: {known}", 404)
        if len(args) != len(schema.parameters):
            raise PanelInputError(
                f"{name} takes {len(schema.parameters)} argument(s), got {len(args)}", 400
            )
        for a in args:
            if a not in self.domain.agents and a not in self.kb.objects:
                raise PanelInputError(f"unknown agent or object {a!r} in {text!r}", 404)
        spec = schema.agents
        if spec.mode == "choice":
            agents: tuple[str, ...] = (args[schema.variables.index(str(spec.variable))],)
        else:
            agents = spec.names
        for a in agents:
            agent = self.domain.agents.get(a)
            if agent is None or not agent.is_human:
                raise PanelInputError(f"{text} is not an operator's action ({a} does it)", 409)
        return GroundAction(schema, args, agents)

    def _dry_run(self, apply: Callable[[Any], object]) -> list[dict[str, Any]]:
        return operator.dry_run(self.tm, apply)

    def _human_action(self, text: str) -> dict[str, Any]:
        step = self._ground(text)
        action = HumanAction(step.name, step.args)
        now = self.now()
        trial = self._dry_run(lambda tm: tm.on_human_action(now, action))
        if any(ev["type"] == "human_action_unmatched" for ev in trial):
            raise PanelInputError(
                f"{action} advances no feasible part of the task now; "
                "press 'done' on a suggested action or 'I'll do this' on a hyper-arc",
                409,
            )
        self._physical(step)
        self._timeline(
            ["human"] if "human" in step.agents else step.agents, str(action), now, now, "done"
        )
        self._dispatch(self.tm.on_human_action(now, action), now)
        return {"ok": True, "action": str(action), "outcome": self.tm.outcome}

    def _physical(self, step: GroundAction) -> None:
        """Where things are after the operator's action (a camera would tell; here we know)."""
        kind, args = step.schema.kind, step.args
        who = step.agents[0] if step.agents else None
        if kind == "pick_up" and len(args) > 1 and args[1] in self.kb.objects:
            if who in self.kb.objects:
                self.kb.move(args[1], self.kb.position(str(who)))
        elif kind == "screw" and len(args) > 2 and args[1] in self.kb.objects:
            if args[2] in self.kb.objects:
                self.kb.move(args[1], self.kb.position(args[2]))
            self.kb.set_fixed(args[1])

    def _take(self, element: str) -> dict[str, Any]:
        try:
            self.tm.graph.element_id(element)
        except KeyError:
            raise PanelInputError(f"unknown hyper-arc {element!r}", 404) from None
        now = self.now()
        self._dry_run(lambda tm: tm.take(now, element))  # raises PanelInputError, nothing changed
        self._record({"t": round(now, 6), "type": "operator_takes", "element": element})
        self._dispatch(self.tm.take(now, element), now)
        ex = self.tm.executions.get(element)
        return {
            "ok": True,
            "take": element,
            "actions": [str(a) for a in ex.branch.steps] if ex else [],
        }

    # -- the state ------------------------------------------------------------------------
    def _agents(self) -> list[dict[str, Any]]:
        out = []
        human_next = {
            a: str(ex.branch.steps[ex.next_index])
            for ex in self.tm.executions.values()
            if ex.owner == "human" and ex.next_index < len(ex.branch.steps)
            for a in ex.branch.steps[ex.next_index].agents
        }
        for agent in self.domain.agents.values():
            item: dict[str, Any] = {"name": agent.name, "kind": agent.kind, "alive": True}
            if agent.is_human:
                nxt = human_next.get(agent.name)
                item["status"] = "asked" if nxt else "free"
                item["action"] = nxt
            else:
                cmd = self.tm.busy.get(agent.name)
                if agent.name in self.tm.halted:
                    item["status"] = "stopped"
                else:
                    item["status"] = "busy" if cmd else "idle"
                item["action"] = str(cmd.action) if cmd else None
                item["command"] = cmd.id if cmd else None
            out.append(item)
        return out

    def _waiting(self) -> str | None:
        tm = self.tm
        if tm.done:
            return None
        if not self.kb.consistent:
            reasons = "; ".join(i.reason for i in self.kb.inconsistencies)
            return f"knowledge base inconsistent: {reasons}"
        asked = [
            str(ex.branch.steps[ex.next_index])
            for ex in tm.executions.values()
            if ex.owner == "human" and ex.next_index < len(ex.branch.steps)
        ]
        parts = []
        if asked and not tm.busy:
            parts.append(f"waiting for the operator: {', '.join(asked)}")
        if tm.halted:
            parts.append(f"stopped by the operator: {', '.join(sorted(tm.halted))}")
        if not parts and not tm.busy:
            parts.append("waiting: no agent has anything to do")
        return "; ".join(parts) or None

    def _build_snapshot(self) -> dict[str, Any]:
        tm = self.tm
        costs = feasible_costs(tm.graph)
        running = {e: ex.owner for e, ex in tm.executions.items()}
        kb = self.kb.to_dict()
        return json_safe(
            {
                "v": 1,
                "cell": self.name,
                "outcome": tm.outcome,
                "reason": tm.reason,
                "waiting": self._waiting(),
                "time": round(self.now(), 3),
                "version": self._version,
                "suggestions": suggestions(tm),
                "takeable": tm.takeable() if not tm.done else [],
                "agents": self._agents(),
                "graph": graph_snapshot(tm.graph, costs, running),
                "timeline": self.timeline[-TIMELINE_LIMIT:],
                "objects": kb["objects"],
                "facts": kb["facts"],
                "consistent": kb["consistent"],
                "events": len(self.events),
            }
        )


def table_assembly(
    legs: int = 4,
    *,
    seed: int = 0,
    unreachable_bolts: tuple[int, ...] = (),
    human: bool = True,
    segments: str | None = "legs",
    **kwargs: Any,
) -> LocalCooperation:
    """The table assembly of paper 000 (VI-D) with the operator at the panel. Bolts in
    ``unreachable_bolts`` no arm reaches: the robot asks the operator (paper Fig. 12).
    ``segments`` as :func:`flexhrc.scenario.builtin.table_assembly` (default here: the legs
    fix, the part this loop can play)."""
    from flexhrc.scenario.builtin.table import table_assembly as build

    scenario = build(
        legs,
        seed=seed,
        unreachable_bolts=tuple(unreachable_bolts),
        human=human,
        segments=segments,
    )
    return LocalCooperation(
        scenario.online_graph(),
        scenario.domain,
        scenario.world(),
        name="table_assembly",
        **kwargs,
    )


__all__ = ["TIMELINE_LIMIT", "LocalCooperation", "PanelTaskManager", "table_assembly"]
