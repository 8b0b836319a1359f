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
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from flexhrc.cell import protocol as P
from flexhrc.cell.components import ground
from flexhrc.errors import FlexhrcError
from flexhrc.sensing.camera import HeadCamera
from flexhrc.sensing.perception import PerceptionComponent
from flexhrc.sensing.run import WORLD_CHANGING, physical_effect
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
    ) -> None:
        self.name = name
        self.domain = scenario.domain
        self.kb = scenario.world()  # the symbols, anchored by this agent's own percepts
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
            self.ended = str(data.get("outcome"))

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
        if fixed in self.kb.objects:
            self.kb.set_fixed(fixed)
        if action.schema.kind in WORLD_CHANGING or getattr(action.schema, "carries", None):
            self.look(float(msg["t"]), f"after {action}")

    def _on_human(self, data: Any) -> None:
        self.received += 1
        try:
            msg = P.parse(data, expect="human_action")
            action = ground(self.domain, msg["action"], (str(msg["agent"]),))
        except FlexhrcError as exc:
            self._bad(exc)
            return
        if msg["id"] in self._seen_humans:
            return
        self._seen_humans.add(msg["id"])
        physical_effect(self.world, action, action.agents[0], self.kb.position, self._board)
        fixed = action.binding.get(getattr(action.schema, "fixes", None) or "")
        if fixed in self.kb.objects:
            self.kb.set_fixed(fixed)
        self.look(float(msg["t"]), f"after {action}")

    # -- perceiving -----------------------------------------------------------------------
    def look(self, t: float, why: str = "") -> int:
        """One perception update at cell time ``t``; publishes the loose parts it anchored.
        Returns how many percepts it sent."""
        upd = self.perception.update(t)
        sent = 0
        detections = {d.id: d for d in upd.detections}
        for sym, pid in sorted(upd.report.anchored.items()):
            rec = self.kb.object(sym)
            det = detections.get(pid)
            if det is None or rec.fixed:
                continue
            self.sent += 1
            sent += 1
            self.transport.publish(
                P.PERCEPT_TOPIC,
                P.message(
                    "percept",
                    id=f"{self.name}:{upd.report.frame}:{sym}",
                    object=sym,
                    object_type=rec.type,
                    pose=[round(float(v), 5) for v in rec.position],
                    t=t,
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
