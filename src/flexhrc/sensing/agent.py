"""The cell's perception as an agent: ``flexhrc agent perception SCENARIO --connect ...``.

:class:`PerceptionAgent` joins a live cell (:mod:`flexhrc.cell`, protocol v1) like the robot
and operator agents do, and closes the loop there: it keeps the simulated workspace (the parts
as they physically are, from the scenario), follows what the agents physically do — every
command the manager sends and its acknowledgement, every reported human action — and after each
action that changes the world renders the head camera, runs the scene pipeline, anchors the
percepts to the scenario's symbols and publishes one ``percept`` message per loose part it sees
(``{"type": "percept", "object": "leg2", "object_type": "leg", "pose": [...]}``). The manager
stores each percept as an input and hands it to its knowledge base (``update_object``): a part
seen elsewhere than believed is updated, a contradiction makes the base inconsistent and the
manager waits.

Parts fixed to the assembly are not reported (they stand upright where the knowledge base keeps
the bolt's position on the board: the agent checks them itself). The arms are drawn in their
rest posture: their joint states stay inside the robot agents.

With a ``truth`` (:class:`~flexhrc.sensing.truth.WorkspaceTruth`, in the process of the cell:
:mod:`flexhrc.sensing.loop`) the agent follows no message to change the world — the agents
change the truth themselves — and it is a *watcher* of the cell's ordered loop: it answers every
``state`` with ``looked``, after looking whenever the world or the manager's belief changed
(and at the times the truth names: a part nudged), against the belief the state carries. Its
percepts say whether a part ``moved`` and which reported belief they contradict.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from flexhrc.cell import protocol as P
from flexhrc.cell.components import ground
from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.sensing.camera import HeadCamera
from flexhrc.sensing.perception import PerceptionComponent
from flexhrc.sensing.truth import WORLD_CHANGING, WorkspaceTruth, physical_effect
from flexhrc.sensing.world import SimulatedWorkspace
from flexhrc.taskmanager.domain import GroundAction
from flexhrc.transport import Transport

log = logging.getLogger(__name__)


class PerceptionAgent:
    """Perception of a cell over a :class:`~flexhrc.transport.Transport` (see the module)."""

    def __init__(
        self,
        scenario: Any,
        transport: Transport,
        *,
        name: str = "perception",
        camera: HeadCamera | None = None,
        trace: Callable[[str], None] | None = None,
        truth: WorkspaceTruth | None = None,
        belief: KnowledgeBase | None = None,
        repair: bool = False,
    ) -> None:
        self.name = name
        self.domain = scenario.domain
        # the symbols, anchored by this agent's own percepts
        self.kb = belief if belief is not None else scenario.world()
        self.truth = truth
        self.repair = repair  # a look that contradicts a belief is followed by a second one
        if truth is not None:
            self.world = truth.world
        else:
            self.world, _ = SimulatedWorkspace.from_knowledge(self.kb)
        if not self.world.parts:
            raise FlexhrcError("the scenario has no part with a body for the camera to see")
        self.perception = PerceptionComponent(self.world, self.kb, camera=camera)
        boards = [p.name for p in self.world.parts.values() if p.shape == "box"]
        self._board = boards[0] if boards else None
        self.transport = transport
        self.trace = trace or (lambda line: None)
        self.commands: dict[int, tuple[GroundAction, dict[str, Any]]] = {}
        self.ended: str | None = None
        self.received = 0
        self.dropped = 0
        self.sent = 0
        self._seen_acks: set[int] = set()
        # an arm's ack can overtake the manager's command on its way here (two publishers,
        # no order between them): it waits for its command
        self._early_acks: dict[int, dict[str, Any]] = {}
        self._seen_humans: set[str] = set()
        robots = [a.name for a in self.domain.agents.values() if not a.is_human]
        # as a watcher: reports to check at their time, and what the last look saw
        self._expect: dict[str, tuple[float, str, str]] = {}
        self._looked_version: int | None = None
        self._checks: list[tuple[str, str]] = []  # (object, why) of reports to check
        if truth is not None:
            self._subs = [transport.subscribe(P.cmd_topic(r), self._stop_of(r)) for r in robots]
            self._subs += [
                transport.subscribe(P.HUMAN_TOPIC, self._on_report),
                transport.subscribe(P.STATE_TOPIC, self._on_state),
            ]
            return
        self._subs = [transport.subscribe(P.cmd_topic(r), self._on_command) for r in robots]
        self._subs += [
            transport.subscribe(P.ACK_TOPIC, self._on_ack),
            transport.subscribe(P.HUMAN_TOPIC, self._on_human),
            transport.subscribe(P.STATE_TOPIC, self._on_state),
        ]

    # -- what the agents do ---------------------------------------------------------------
    def _bad(self, exc: Exception) -> None:
        self.dropped += 1
        log.warning("%s: dropped a malformed message: %s", self.name, exc)
        self.trace(f"dropped: {exc}")

    def _on_state(self, data: Any) -> None:
        if isinstance(data, dict) and data.get("type") == "end":
            try:  # only the manager's own end (a spoofed "v": 99 one is dropped)
                self.ended = str(P.parse_end(data, run=getattr(self, "run", None))["outcome"])
            except P.ProtocolError as exc:
                self._bad(exc)
        elif self.truth is not None and isinstance(data, dict) and data.get("type") == "state":
            self._watch(data)

    # -- as the cell's watcher ------------------------------------------------------------
    def _stop_of(self, robot: str) -> Callable[[Any], None]:
        def on_stop(data: Any) -> None:
            if isinstance(data, dict) and data.get("type") == "stop" and self.truth is not None:
                self.truth.stop(int(data["id"]), robot, float(data.get("t", 0.0)))

        return on_stop

    def _human_action(self, data: Any) -> tuple[dict[str, Any], GroundAction] | None:
        """A person's report on the ``human`` topic and the action it names (None: an answer to
        the manager, or malformed — dropped and counted)."""
        if isinstance(data, dict) and data.get("type") == "answer":
            return None  # the operator answers the manager, not the camera
        try:
            msg = P.parse(data, expect="human_action")
            return msg, ground(self.domain, msg["action"], (str(msg["agent"]),))
        except FlexhrcError as exc:
            self._bad(exc)
            return None

    def _on_report(self, data: Any) -> None:
        """A reported human action: once the manager has it, the next look checks the belief
        it implies (a recognition may be false); a missed one implies nothing."""
        got = self._human_action(data)
        if got is None:
            return
        msg, action = got
        if msg.get("recognised") is False or len(action.args) < 2:
            return
        obj = action.args[1]
        if obj in self.kb.objects and self.perception.anchoring.perceivable(self.kb.object(obj)):
            self._expect[str(msg["id"])] = (float(msg["t"]), obj, str(action))

    def _watch(self, state: dict[str, Any]) -> None:
        """Look at the state the cell left when the world changed or a report is to be checked
        (against the belief the state carries), then say so. The states that only carry this
        agent's own percepts back need no look."""
        assert self.truth is not None
        t = float(state.get("t", 0.0))
        self.truth.advance(t)
        for rid, (at, obj, action) in sorted(self._expect.items()):
            if at <= t:
                del self._expect[rid]
                self._checks.append((obj, f"after the report {action}"))
        first = self._looked_version is None
        changed = first or self.world.version != self._looked_version or self._checks
        if state.get("outcome") == "running" and changed:
            self._sync(state.get("knowledge") or {})
            for obj, _ in self._checks:
                self.perception.anchoring.expect(obj)
            if first:
                why = "start"
            elif self._checks:
                why = self._checks[-1][1]
            else:
                why = self.truth.whys[-1] if self.truth.whys else "the world changed"
            self.truth.whys.clear()
            self._checks.clear()
            self._looked_version = self.world.version
            known = len(self.kb.inconsistencies)
            self.look(t, why)
            if self.repair and len(self.kb.inconsistencies) > known:
                self.look(t, "repair: look again")
        wake = self.truth.next_wake()
        fields = {"at": wake} if wake is not None and wake > t else {}
        self.transport.publish(
            P.PERCEPT_TOPIC,
            P.message("looked", agent=self.name, upto=int(state.get("seq", 0)), t=t, **fields),
        )

    def _sync(self, knowledge: dict[str, Any]) -> None:
        """The manager's belief, as the state carries it: where the objects are, which fixed
        (and consistent again: the manager decided the contradictions)."""
        if knowledge.get("consistent") and self.kb.inconsistencies:
            self.kb.resolve(accept=False)
            self.perception.anchoring.expected.clear()
        for o in knowledge.get("objects") or []:
            rec = self.kb.objects.get(o.get("id"))
            if rec is None:
                continue
            pos = tuple(float(v) for v in o["position"])
            if rec.position != pos:
                self.kb.move(rec.id, pos)
            if bool(o.get("fixed")) != rec.fixed:
                self.kb.set_fixed(rec.id, bool(o.get("fixed")))

    def _on_command(self, data: Any) -> None:
        self.received += 1
        try:
            msg = P.parse(data, expect=("command", "stop"))
            if msg["type"] == "command":
                action = ground(
                    self.domain, msg["action"], tuple(msg["agents"]),
                    process=bool(msg.get("process")),
                )  # fmt: skip
                cid = int(msg["id"])
                self.commands[cid] = (action, dict(msg.get("world") or {}))
                early = self._early_acks.pop(cid, None)
                if early is not None:
                    self._done(cid, early)
        except FlexhrcError as exc:
            self._bad(exc)

    def _believed(self, world: dict[str, Any]) -> Callable[[str], tuple[float, float, float]]:
        positions = world.get("positions") or {}

        def where(name: str) -> tuple[float, float, float]:
            p = positions.get(name)
            if isinstance(p, list) and len(p) == 3:
                return (float(p[0]), float(p[1]), float(p[2]))
            return self.kb.position(name)

        return where

    def _on_ack(self, data: Any) -> None:
        self.received += 1
        try:
            msg = P.parse(data, expect="ack")
        except FlexhrcError as exc:
            self._bad(exc)
            return
        cid = int(msg["id"])
        if cid in self._seen_acks or msg["status"] != "done":
            return
        if cid not in self.commands:
            log.debug("%s: ack %d came before its command", self.name, cid)
            self._early_acks.setdefault(cid, msg)
            return
        self._done(cid, msg)

    def _done(self, cid: int, msg: dict[str, Any]) -> None:
        """The arm reports command ``cid`` done: its physical effect, then a look."""
        self._seen_acks.add(cid)
        action, world = self.commands[cid]
        # the arm acted where the manager believed things were, when it sent the command
        physical_effect(self.world, action, action.agents[0], self._believed(world), self._board)
        for obj, p in (msg.get("positions") or {}).items():  # what the manager now believes
            if obj in self.kb.objects:
                self.kb.move(obj, p)
        fixed = action.binding.get(getattr(action.schema, "fixes", None) or "")
        if fixed is not None and fixed in self.kb.objects:
            self.kb.set_fixed(fixed)
        if action.schema.kind in WORLD_CHANGING or getattr(action.schema, "carries", None):
            self.look(float(msg["t"]), f"after {action}")

    def _on_human(self, data: Any) -> None:
        self.received += 1
        got = self._human_action(data)
        if got is None:
            return
        msg, action = got
        if msg["id"] in self._seen_humans:
            return
        self._seen_humans.add(msg["id"])
        physical_effect(self.world, action, action.agents[0], self.kb.position, self._board)
        fixed = action.binding.get(getattr(action.schema, "fixes", None) or "")
        if fixed is not None and fixed in self.kb.objects:
            self.kb.set_fixed(fixed)
        self.look(float(msg["t"]), f"after {action}")

    # -- perceiving -----------------------------------------------------------------------
    def look(self, t: float, why: str = "") -> int:
        """One perception update at cell time ``t``; publishes the loose parts it anchored.
        Returns how many percepts it sent."""
        before = {i.object_id for i in self.kb.inconsistencies}
        upd = self.perception.update(t)
        sent = 0
        detections = {d.id: d for d in upd.detections}
        moved = set(upd.report.moved)
        for sym, pid in sorted(upd.report.anchored.items()):
            rec = self.kb.object(sym)
            det = detections.get(pid)
            if det is None or rec.fixed:
                continue
            self.sent += 1
            sent += 1
            extra: dict[str, Any] = {"why": why} if why else {}
            if sym in moved:
                extra["moved"] = True
            self.transport.publish(
                P.PERCEPT_TOPIC,
                P.message(
                    "percept",
                    id=f"{self.name}:{upd.report.frame}:{sym}",
                    object=sym,
                    object_type=rec.type,
                    pose=[round(float(v), 5) for v in rec.position],
                    t=t,
                    **extra,
                ),
            )
        for inc in self.kb.inconsistencies:  # a belief this frame contradicts
            if inc.object_id in before:
                continue
            self.sent += 1
            sent += 1
            pos = inc.percept["position"]
            self.transport.publish(
                P.PERCEPT_TOPIC,
                P.message(
                    "percept",
                    id=f"{self.name}:{upd.report.frame}:{inc.object_id}:contradicts",
                    object=inc.object_id,
                    object_type=str(inc.percept["type"]),
                    pose=[round(float(v), 5) for v in pos],
                    t=t,
                    why=why,
                    contradicts=inc.reason,
                ),
            )
        inc = len(upd.report.inconsistencies)
        self.trace(
            f"frame {upd.report.frame} ({why}): {len(upd.detections)} detections, {sent} "
            f"percepts sent{f', {inc} inconsistencies' if inc else ''}, "
            f"{1000 * upd.total_s:.0f} ms"
        )
        return sent

    # -- the agent loop (flexhrc.cell.components.run_agent) ---------------------------------
    def poll(self) -> None:
        """Nothing is paced: every frame is taken when its action is reported."""

    def next_due(self) -> float | None:
        return None

    def close(self) -> None:
        for sub in self._subs:
            sub.cancel()
        self.perception.close()

    def summary(self) -> dict[str, Any]:
        return {
            "agent": self.name,
            "kind": "perception",
            "outcome": self.ended or "stopped",
            "received": self.received,
            "dropped": self.dropped,
            "percepts_sent": self.sent,
            "perception": self.perception.stats.to_dict(),
        }


__all__ = ["PerceptionAgent"]
