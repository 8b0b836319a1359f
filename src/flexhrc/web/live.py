"""The panel over a cell (:class:`flexhrc.cell.Cell`): ``flexhrc panel`` and ``flexhrc cell --web``.

The cell is single-threaded: one loop receives, stores, feeds and sends. The panel's server runs
on its own thread, so :class:`CellPanel` never touches the cell from there. It is one more
component the cell's loop polls (like the simulated agents): in :meth:`CellPanel.poll`, on the
cell's thread, it

* carries out the inputs the page queued — a human action through :meth:`Cell.human_input`
  (stored as an input like any operator's report), a *take*, a stop or resume of an arm — each
  first checked against a copy of the Task Manager so a refused input changes nothing, and
  answers the waiting HTTP request;
* takes a new snapshot when the cell moved on and tells the page.

Over Zenoh with ``--agents external`` the panel *is* the operator: it holds the liveliness token
of each human agent, so the cell waits for the person at the page (and says so on it) instead of
for an operator process. In ``flexhrc panel`` (:mod:`flexhrc.web.local`) it is the operator of a
cell in this process, on the wall clock.

Every input goes through the cell's public entries (:meth:`Cell.human_input`,
:meth:`Cell.human_take`, :meth:`Cell.halt_agent`, :meth:`Cell.release_agent`): stored inputs
(``human_action``, ``human_take``, ``agent_down``/``agent_up`` with ``"by": "operator"``), so a
resumed cell replays them.
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from typing import Any, TypeVar

from flexhrc.cell import protocol as P
from flexhrc.cell.components import ground, unknown_name
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager.domain import GroundAction
from flexhrc.taskmanager.manager import Command, HumanAction, TakeRefused, TaskManager
from flexhrc.taskmanager.words import plain_words
from flexhrc.web import operator
from flexhrc.web.backend import PanelInputError, json_safe, parse_action
from flexhrc.web.snapshot import (
    TIMELINE_LIMIT,
    feasible_costs,
    graph_snapshot,
    progress,
    suggestions,
)

ANSWER_TIMEOUT_S = 10.0  # an HTTP request waits this long for the cell's loop to take its input


class CellPanel:
    """A :class:`~flexhrc.web.backend.PanelBackend` for a :class:`~flexhrc.cell.Cell`.

    ``operator=True`` (external agents): the panel stands in for the scenario's human agents
    (declares their liveliness tokens). Call :meth:`poll` from the cell's loop and
    :meth:`close` at the end.
    """

    def __init__(
        self, cell: Any, *, operator: bool = False, on_input: Callable[[], None] | None = None
    ):
        self.cell = cell
        self._on_input = on_input
        self.halted: set[str] = set()
        self._inbox: queue.SimpleQueue[tuple[str, Any, Future[dict[str, Any]]]] = (
            queue.SimpleQueue()
        )
        self._listeners: dict[int, Callable[[], None]] = {}
        self._next_listener = 0
        self._lock = threading.Lock()
        self._seen: tuple[Any, ...] | None = None
        self._version = 0
        self._timeline: list[dict[str, Any]] = []
        self._timeline_from = 0
        self._commands: dict[int, dict[str, Any]] = {}
        self._joints: dict[str, list[float]] = {}  # each arm's latest joint state (acks)
        self._tokens: list[Any] = []
        for ev in cell.events:  # a resumed cell: the operator's stops are in its store
            if ev.body.get("by") == "operator" and ev.kind in ("agent_down", "agent_up"):
                name = str(ev.body.get("agent"))
                (self.halted.add if ev.kind == "agent_down" else self.halted.discard)(name)
        self._snapshot = self._build()
        declare = getattr(cell.transport, "declare_token", None)
        if operator and declare is not None:  # the person at the page is the operator
            for name, st in cell.agents.items():
                if st.kind == "human":
                    cell.played_here(name)
                    self._tokens.append(declare(P.alive_key(name)))

    # -- the backend contract (any thread) --------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        return self._snapshot

    def subscribe(self, callback: Callable[[], None]) -> Callable[[], None]:
        with self._lock:
            key = self._next_listener
            self._next_listener += 1
            self._listeners[key] = callback

        def cancel() -> None:
            with self._lock:
                self._listeners.pop(key, None)

        return cancel

    def submit(self, body: Mapping[str, str]) -> dict[str, Any]:
        if "action" in body:
            return self._ask("action", body["action"])
        if "take" in body:
            return self._ask("take", body["take"])
        if "reply" in body:
            return self._ask("reply", (body["reply"], body.get("reason")))
        raise PanelInputError('send {"action": ...}, {"take": ...} or {"reply": ...}')

    def what_if(self, body: Mapping[str, str]) -> dict[str, Any]:
        """What the robots would do if the person did ``{"action": ...}`` or took
        ``{"take": ...}`` now; changes nothing (see :meth:`_what_if`)."""
        return self._ask("whatif", dict(body))

    def stop_robot(self, name: str) -> dict[str, Any]:
        return self._ask("stop", name)

    def resume_robot(self, name: str) -> dict[str, Any]:
        return self._ask("resume", name)

    def _ask(self, kind: str, arg: Any) -> dict[str, Any]:
        answer: Future[dict[str, Any]] = Future()
        self._inbox.put((kind, arg, answer))
        if self._on_input is not None:
            self._on_input()
        try:
            return answer.result(timeout=ANSWER_TIMEOUT_S)
        except FutureTimeout:
            raise PanelInputError(
                f"the cell did not take the input within {ANSWER_TIMEOUT_S:g} s (busy or ended)",
                503,
            ) from None

    # -- on the cell's thread ---------------------------------------------------------------
    def poll(self) -> None:
        """Carry out queued inputs; refresh the snapshot if the cell moved on (cell thread)."""
        for kind, arg, answer in drained(self._inbox):
            try:
                answer.set_result(self._apply(kind, arg))
            except PanelInputError as exc:
                answer.set_exception(exc)
            except FlexhrcError as exc:
                answer.set_exception(PanelInputError(str(exc), 409))
        self.refresh()

    def next_due(self) -> float | None:
        return None

    def refresh(self, *, force: bool = False) -> None:
        c = self.cell
        seen = (len(c.events), len(c.pending), c.now, c.tm.outcome, c.started, self._alive())
        if seen == self._seen and not force:
            return
        self._seen = seen
        snap = self._build()
        if not force and {**snap, "version": None} == {**self._snapshot, "version": None}:
            return  # nothing the page shows changed (e.g. an answer queued, not yet handled)
        self._version += 1
        snap["version"] = self._version
        self._snapshot = snap
        with self._lock:
            listeners = list(self._listeners.values())
        for cb in listeners:
            cb()

    def close(self) -> None:
        """Answer what is still queued (the cell has ended), drop the operator's tokens."""
        self.refresh(force=True)
        for _, _, answer in drained(self._inbox):
            answer.set_exception(
                PanelInputError(f"the cooperation has ended ({self.cell.tm.outcome})", 409)
            )
        with self._lock:
            for token in self._tokens:
                with contextlib.suppress(Exception):  # the session may already be closed
                    token.undeclare()
            self._tokens.clear()

    # -- inputs -------------------------------------------------------------------------------
    def _apply(self, kind: str, arg: Any) -> dict[str, Any]:
        c = self.cell
        if not c.started:
            raise PanelInputError("the cell has not started yet (waiting for its agents)", 409)
        if c.tm.done:
            raise PanelInputError(f"the cooperation has ended ({c.tm.outcome})", 409)
        if kind == "action":
            return self._human_action(str(arg))
        if kind == "take":
            return self._take(str(arg))
        if kind == "whatif":
            return self._what_if(arg)
        if kind in ("stop", "resume"):
            return self._robot(str(arg), stop=kind == "stop")
        if kind == "reply":
            return self._reply(*arg)
        raise PanelInputError(f"unknown input {kind!r}")

    def _reply(self, reply: str, reason: str | None) -> dict[str, Any]:
        """The person answers their open request (``docs/protocol.md``, "Operator answers"):
        "not now", "I can't do this", "I'm starting", "I give it back"."""
        c = self.cell
        human = next((n for n, s in c.agents.items() if s.kind == "human"), None)
        if human is None:
            raise PanelInputError("this scenario has no operator", 409)
        if reply != "start" and human not in c.active_suggestion:
            raise PanelInputError(f"nothing is asked of {human} now: nothing to {reply}", 409)
        before = len(c.dropped)
        c.human_reply(reply, human, reason=reason)  # stored and fed by the cell's own loop
        if len(c.dropped) > before:
            raise PanelInputError(c.dropped[-1], 409)
        self._handle_now()
        return {"ok": True, "reply": reply, "outcome": c.tm.outcome}

    def _human_action(self, text: str) -> dict[str, Any]:
        c = self.cell
        step, people = self._human_step(text)
        action = HumanAction(step.name, step.args)
        if self._already_done(str(action), people[0]):
            # a double click, a second tab, a retried request: the same report once (W27-W29)
            return {
                "ok": True,
                "action": str(action),
                "already_done": True,
                "outcome": c.tm.outcome,
            }
        now = c.now
        if not c.tm.advances(now, action):
            raise PanelInputError(
                f"{action} advances no feasible part of the task now; "
                "press 'done' on a suggested action or 'I'll do this' on a hyper-arc",
                409,
            )
        c.human_input(str(action), people[0])  # stored and fed by the cell's own loop
        self._handle_now()
        return {"ok": True, "action": str(action), "outcome": c.tm.outcome}

    def _handle_now(self) -> None:
        """On the wall clock the loop handles inputs as they arrive: now, so the answer and the
        page already show the input's effect (the ordered loop waits for its time)."""
        c = self.cell
        if not c.ordered:
            while c.pending and c.step():
                pass
        self.refresh(force=True)

    def _already_done(self, action: str, agent: str) -> bool:
        """Is ``action`` the operator's report of a step already recorded — the latest
        ``human_action`` of ``agent``, still queued for the loop (the ordered loop takes inputs
        at their time) or taken and not asked of the operator again since?

        The manager would take a repeat as the operator starting the hyper-arc over ("human
        changed plan"), and the store would hold a phantom action, so "done" pressed twice on
        one step is recorded once."""
        c = self.cell
        for *_, kind, body in reversed(c.pending):
            if kind == "human_action" and body.get("agent") == agent:
                return str(body.get("action")) == action
        last = next(
            (
                str(ev.body.get("action"))
                for ev in reversed(c.events)
                if ev.kind == "human_action" and ev.body.get("agent") == agent
            ),
            None,
        )
        if last != action:
            return False
        # asked again (re-planned): doing it again is new work
        return action not in {str(step) for step in self._asked()}

    def _human_step(self, text: str) -> tuple[GroundAction, list[str]]:
        """A person's report ``text`` checked as the manager would check it: the ground
        action and the people doing it, or one :class:`PanelInputError` saying why not."""
        c = self.cell
        name, args = parse_action(text)
        schema = c.domain.actions.get(name)
        if schema is None:
            raise PanelInputError(
                f"unknown action {name!r}; actions: {', '.join(sorted(c.domain.actions))}", 404
            )
        if len(args) != len(schema.parameters):
            raise PanelInputError(
                f"{name} takes {len(schema.parameters)} argument(s), got {len(args)}", 400
            )
        for a in args:
            if a not in c.domain.agents and a not in c.kb.objects:
                raise PanelInputError(f"unknown agent or object {a!r} in {text!r}", 404)
        step = ground(c.domain, f"{name}({', '.join(args)})")
        wrong = unknown_name(c.domain, c.kb, step)  # the manager's own check of a report
        if wrong is not None:
            raise PanelInputError(wrong, 400)
        people = [a for a in step.agents if c.agents.get(a) and c.agents[a].kind == "human"]
        if not people or len(people) != len(step.agents):
            raise PanelInputError(f"{step} is not an operator's action", 409)
        return step, people

    def _what_if(self, body: Mapping[str, Any]) -> dict[str, Any]:
        """What the robots would do if the person did the step ``body`` names (``action``) or
        took a part (``take``): the Task Manager tried on a copy (:meth:`TaskManager.what_if`),
        so nothing changes. Each arm: the command it would get, or the one it goes on with,
        in plain words, with its planned hand path."""
        c = self.cell
        if "take" in body:
            try:
                commands, twin = c.tm.what_if(c.now, take=str(body["take"]))
            except TakeRefused as exc:
                raise PanelInputError(str(exc), operator.refusal_status(exc)) from None
        elif "action" in body:
            step, _ = self._human_step(str(body["action"]))
            action = HumanAction(step.name, step.args)
            if not c.tm.advances(c.now, action):
                raise PanelInputError(f"{action} would not advance the task now", 409)
            commands, twin = c.tm.what_if(c.now, action=action)
        else:
            raise PanelInputError('send {"action": ...} or {"take": ...}')
        names = tuple(c.agents)
        robots, words = [], []
        for name, st in c.agents.items():
            if st.kind != "robot":
                continue
            issued = [cmd for cmd in commands if name in cmd.agents]
            cmd = issued[0] if issued else twin.busy.get(name)
            text = plain_words(cmd.action, names) if cmd else None
            robots.append(
                {
                    "agent": name,
                    "action": str(cmd.action) if cmd else None,
                    "text": text,
                    "new": bool(issued),
                    "path": _step_path(twin, cmd, name) if cmd else None,
                }
            )
            said = text[:1].lower() + text[1:] if text else ""
            words.append(
                f"{name} would {said}"
                if issued
                else f"{name} goes on: {said}"
                if cmd
                else f"{name} would wait"
            )
        return {"ok": True, **dict(body), "robots": robots, "text": "; ".join(words) + "."}

    def _take(self, element: str) -> dict[str, Any]:
        c = self.cell
        try:  # checked by the manager first: a refused take stores and changes nothing
            actions = c.human_take(element)
        except TakeRefused as exc:
            raise PanelInputError(str(exc), operator.refusal_status(exc)) from None
        self.refresh(force=True)
        return {"ok": True, "take": element, "actions": actions}

    def _robot(self, name: str, *, stop: bool) -> dict[str, Any]:
        c = self.cell
        st = c.agents.get(name)
        if st is None:
            robots = ", ".join(n for n, s in c.agents.items() if s.kind == "robot")
            raise PanelInputError(f"unknown robot {name!r}; robots: {robots}", 404)
        if st.kind != "robot":
            raise PanelInputError(f"{name!r} is an operator, not a robot", 400)
        if stop:
            if name in self.halted or not st.available:
                raise PanelInputError(f"robot {name!r} is already stopped or lost", 409)
            self.halted.add(name)
            # stored as an input: the manager plans without the arm, its command fails
            c.halt_agent(name, by="operator")
        else:
            if name not in self.halted:
                raise PanelInputError(f"robot {name!r} is not stopped", 409)
            self.halted.discard(name)
            c.release_agent(name, by="operator")
        self.refresh(force=True)
        return {"ok": True, ("stopped" if stop else "resumed"): name}

    # -- the state ----------------------------------------------------------------------------
    def _asked(self) -> list[GroundAction]:
        """The steps the operators are asked to do now (the next one of each of their parts)."""
        return [
            ex.branch.steps[ex.next_index]
            for ex in self.cell.tm.executions.values()
            if ex.owner == "human" and ex.next_index < len(ex.branch.steps)
        ]

    def _alive(self) -> tuple[tuple[str, bool, bool], ...]:
        return tuple((n, st.alive, st.available) for n, st in self.cell.agents.items())

    def _update_timeline(self) -> None:
        events = self.cell.events
        for ev in events[self._timeline_from :]:
            body = ev.body
            if ev.kind == "ack" and isinstance(body.get("joints"), Mapping):
                self._joints.update(body["joints"])  # where the arms are (the 3D view)
            if ev.kind == "command":
                self._commands[int(body["id"])] = {"start": ev.t, **body}
            elif ev.kind in ("ack", "stop"):  # a command's end: answered, or stopped
                cmd = self._commands.pop(int(body["id"]), None)
                if cmd is not None:
                    entry = {
                        "start": round(float(cmd["start"]), 3),
                        "end": round(ev.t, 3),
                        "agents": list(cmd.get("agents", [])),
                        "action": str(cmd.get("action")),
                        "status": str(body.get("status")) if ev.kind == "ack" else "stopped",
                    }
                    if ev.kind == "stop" or body.get("reason"):
                        entry["reason"] = str(body.get("reason"))
                    self._timeline.append(entry)
            elif ev.kind == "human_action":
                t = round(ev.t, 3)
                start = body.get("start")
                self._timeline.append(
                    {
                        "start": round(float(start), 3) if isinstance(start, int | float) else t,
                        "end": t,
                        "agents": [str(body.get("agent"))],
                        "action": str(body.get("action")),
                        "status": "done",
                    }
                )
        self._timeline_from = len(events)
        del self._timeline[:-TIMELINE_LIMIT]

    def _agents(self) -> list[dict[str, Any]]:
        c = self.cell
        names = tuple(c.agents)
        asked = {a: step for step in self._asked() for a in step.agents}
        out = []
        for name, st in c.agents.items():
            item: dict[str, Any] = {"name": name, "kind": st.kind, "alive": bool(st.alive)}
            if st.kind == "human":
                step = asked.get(name)
                item["action"] = str(step) if step else None
                item["text"] = plain_words(step, names) if step else None
                item["status"] = (
                    "lost" if not st.available else "asked" if name in asked else "free"
                )
            else:
                cmd = c.tm.busy.get(name)
                item["action"] = str(cmd.action) if cmd else None
                item["text"] = plain_words(cmd.action, names) if cmd else None
                following = self._following(name)
                item["next"] = str(following) if following else None
                item["next_text"] = plain_words(following, names) if following else None
                item["command"] = cmd.id if cmd else None
                if name in self.halted:
                    item["status"] = "stopped"
                elif not st.available:
                    item["status"] = "lost"
                else:
                    item["status"] = "busy" if cmd else "idle"
            out.append(item)
        return out

    def _scene(self) -> dict[str, Any]:
        """What the 3D view draws (issue 24, item 2): each arm's base, hand and — when its
        joint state is known (the kinematic model's acknowledgements) — its joint chain by
        forward kinematics of the project's robot model; each person's hand; the objects with
        their sizes (the knowledge base, agents left out)."""
        c = self.cell
        robots, people = [], []
        for name, agent in c.tm.domain.agents.items():
            hand = c.kb.objects[name].position if name in c.kb.objects else None
            if agent.is_human:
                people.append({"name": name, "hand": _xyz(hand)})
                continue
            robots.append(
                {
                    "name": name,
                    "base": _xyz(agent.params.get("base")),
                    "hand": _xyz(hand),
                    "reach": agent.params.get("reach"),
                    "chain": self._chain(name),
                    "planned": self._planned(name),
                }
            )
        agents = set(c.tm.domain.agents)
        objects = [
            {
                "id": o.id,
                "type": o.type,
                "position": _xyz(o.position),
                "size": dict(o.size),
                "fixed": bool(o.fixed),
            }
            for o in c.kb.objects.values()
            if o.id not in agents
        ]
        return {"robots": robots, "people": people, "objects": objects}

    def _planned(self, robot: str) -> dict[str, Any] | None:
        """The running command's planned hand path for ``robot`` (issue 24, item 3): from the
        branch simulation the Task Manager ran when it chose the branch — ``{"command",
        "action", "text", "path"}`` — or None when the arm runs nothing (the path goes when the
        command ends or is stopped)."""
        cmd = self.cell.tm.busy.get(robot)
        path = _step_path(self.cell.tm, cmd, robot) if cmd is not None else None
        if cmd is None or not path:
            return None
        started = self._commands.get(cmd.id, {}).get("start")
        return {
            "command": cmd.id,
            "action": str(cmd.action),
            "text": plain_words(cmd.action, tuple(self.cell.agents)),
            "path": path,
            "start": round(float(started), 3) if started is not None else None,
            "expected_s": round(cmd.expected_s, 3),
        }

    def _chain(self, arm: str) -> list[list[float]] | None:
        q = self._joints.get(arm)
        if q is None:
            return None
        try:  # the kinematic model sent joint states: pinocchio is installed
            from flexhrc.action.robots import load_robot

            model = load_robot().arms.get(arm)
            if model is None or len(q) != model.dof:
                return None
            return [_xyz(p) or [] for p in model.joint_positions(q)]
        except (ImportError, FlexhrcError):
            return None

    def _following(self, robot: str) -> GroundAction | None:
        """The step an arm will do after its current one (the rest of the part it carries
        out), or the first of a part given to it and not started."""
        for ex in self.cell.tm.executions.values():
            if robot not in ex.branch.agents:
                continue
            at = ex.next_index + (1 if ex.command is not None else 0)
            for step in ex.branch.steps[at:]:
                if robot in step.agents:
                    return step
        return None

    def _waiting(self) -> str | None:
        c = self.cell
        if c.tm.done:
            return None
        missing = [n for n, st in c.agents.items() if not st.alive and st.kind == "robot"]
        if not c.started:
            if missing:
                return f"waiting for the agents' processes: {', '.join(missing)}"
            return "starting"
        if not c.kb.consistent:
            reasons = "; ".join(i.reason for i in c.kb.inconsistencies)
            return f"knowledge base inconsistent: {reasons}"
        lost = [n for n, st in c.agents.items() if not st.available and n not in self.halted]
        # in the person's words: the banner is read at the workbench too
        asked = [plain_words(step, tuple(c.agents)) for step in self._asked()]
        if c.ordered:  # the loop holds the arms' answers while the operator is asked
            robots_working = bool(c.pending)
        else:  # on the wall clock the arms go on: wait for the operator once they are done
            answered = {b["id"] for *_, kind, b in c.pending if kind == "ack"}
            robots_working = any(cmd.id not in answered for cmd in c.tm.busy.values())
        parts = []
        if asked and not robots_working:
            parts.append(f"waiting for the operator: {', '.join(asked)}")
        if lost:
            parts.append(f"agent(s) lost: {', '.join(lost)}")
        if self.halted:
            parts.append(f"stopped by the operator: {', '.join(sorted(self.halted))}")
        if not parts and not c.tm.busy and not c.pending:
            parts.append("waiting: no agent has anything to do")
        return "; ".join(parts) or None

    def _build(self) -> dict[str, Any]:
        c = self.cell
        self._update_timeline()
        tm = c.tm
        running = {e: ex.owner for e, ex in tm.executions.items()}
        graph = graph_snapshot(tm.graph, feasible_costs(tm.graph), running)
        offers = operator.offers(tm)
        kb = c.kb.to_dict()
        return json_safe(
            {
                "v": 1,
                "cell": c.name,
                "scenario": getattr(c.scenario, "name", None),
                "outcome": tm.outcome,
                "reason": tm.reason,
                "waiting": self._waiting(),
                "time": round(c.now, 3),
                "version": self._version,
                "suggestions": suggestions(tm),
                "takeable": [offer["element"] for offer in offers],
                "offers": offers,
                "clock_rate": c.realtime,
                "agents": self._agents(),
                "graph": graph,
                "progress": progress(graph),
                "scene": self._scene(),
                "timeline": list(self._timeline),
                "objects": kb["objects"],
                "facts": kb["facts"],
                "consistent": kb["consistent"],
                "events": len(c.events),
                "dropped": len(c.dropped),
            }
        )


_Item = TypeVar("_Item")


def drained(inbox: queue.SimpleQueue[_Item]) -> Iterator[_Item]:
    """What ``inbox`` holds so far, taken off one by one (never blocks)."""
    while True:
        try:
            yield inbox.get_nowait()
        except queue.Empty:
            return


def _step_path(tm: TaskManager, cmd: Command, robot: str) -> list[list[float] | None] | None:
    """The hand path of ``robot`` for command ``cmd`` from the branch simulation the
    manager ran when it chose the branch (the step's ``paths``), or None."""
    ex = tm.executions.get(cmd.element) if cmd.element is not None else None
    result = ex.branch.result if ex is not None else None
    if result is None or not 0 <= cmd.index < len(result.details):
        return None
    paths = result.details[cmd.index].get("paths")
    path = paths.get(robot) if isinstance(paths, Mapping) else None
    return [_xyz(p) for p in path] if path else None


def _xyz(p: Any) -> list[float] | None:
    """A position as three rounded floats (millimetres are enough for a picture), or None."""
    if p is None:
        return None
    try:
        return [round(float(v), 4) for v in list(p)[:3]]
    except (TypeError, ValueError):
        return None


__all__ = ["CellPanel"]
