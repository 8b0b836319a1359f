"""Perception in the loop as a configuration of the one cooperation loop, the cell.

:class:`PerceivedCell` wires a :class:`~flexhrc.cell.Cell` over an ordered
:class:`~flexhrc.transport.InProcessBus` with in-process agents: the simulated arms
(:class:`~flexhrc.cell.RobotAgent`), the simulated operators (:class:`~flexhrc.cell.HumanAgent`,
with the wrist sensor when one is given) and the head camera's
:class:`~flexhrc.sensing.agent.PerceptionAgent`. Two worlds are kept apart:

* the **truth** — :class:`WorkspaceTruth`, a :class:`~flexhrc.sensing.world.SimulatedWorkspace`
  changed only by what the agents physically do: each agent reports what it carries out to the
  truth (its ``on_executed`` observer), which applies the physical effect
  (:func:`physical_effect`: robots and the operator act where they *believe* things are) at the
  action's end on the cell's clock — a grasp that closes on nothing fails; a stopped arm lays
  what it holds back; the operator nudges parts (:class:`Nudge`);
* the **belief** — the manager's knowledge base: symbols without positions at the start, then
  where the percepts anchored them, moved meanwhile by the predicted effects of the actions
  acknowledged and reported.

Order. The perception agent is a *watcher* of the cell: the manager makes its first decision
once the camera has looked, and after every input the ordered loop waits until the camera has
looked at the state the input left (``looked``); the percepts are inputs at that time. A nudge
is a time the camera asks to look at by itself. So every run with the same seed gives the same
events.

Human actions reach the manager as the wrist sensor recognises them (``human_sensing``): a miss
is a miss — the manager is not told; scene perception may still notice the change. A false
report (:class:`FalseReport`) is a report of an action the operator did not do: the manager's
belief follows it, the next look contradicts it, the base is inconsistent and the manager waits.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from flexhrc.cell import protocol as P
from flexhrc.cell.local import (
    InjectedFailure,
    LocalCell,
    RunResult,
    add_world_record,
    real_world,
)
from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.scenario.model import Scenario, WorldSpec
from flexhrc.sensing.truth import (
    WORLD_CHANGING,
    Nudge,
    WorkspaceTruth,
    physical_effect,
)
from flexhrc.sensing.world import SimulatedWorkspace
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.transport import InProcessBus


@dataclass
class FalseReport:
    """The wrist sensor reports ``action(human, leg)`` that the operator did not do, when the
    ``nth`` robot action ``after`` is acknowledged (``leg``: a leg on the table if None)."""

    after: str = "rest"
    nth: int = 1
    action: str = "pick_up"
    leg: str | None = None


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


# -- the configuration -----------------------------------------------------------------------
class _ReportedHand:
    """The operator's execution model: where a reported action leaves the operator's hand —
    at the place the action names (a screw at its bolt, a ``moves_to``), else in front of the
    operator (the workspace's ``hand``). The report carries it, so the manager's belief moves
    what the action ``carries`` there: the predicted effect a recognition implies."""

    def __init__(self, inner: Any, hand: tuple[float, float, float]) -> None:
        self.inner, self.hand = inner, hand

    def execute(self, action: GroundAction, positions: Any, kb: Any, domain: Any) -> Any:
        report = self.inner.execute(action, positions, kb, domain)
        schema, binding = action.schema, action.binding
        carried = binding.get(getattr(schema, "carries", None) or "")
        if carried is None or not action.agents or carried not in kb.objects:
            return report
        to = binding.get(getattr(schema, "moves_to", None) or "")
        if to is None:
            to = next(
                (a for a in action.args
                 if a in kb.objects and a != carried and a not in domain.agents),
                None,
            )  # fmt: skip
        positions[action.agents[0]] = tuple(kb.position(to)) if to else self.hand
        return report


class _FalseReporter:
    """The wrist sensor's false reports (:class:`FalseReport`): when the cell has handled the
    ``nth`` acknowledgement of a robot action ``after``, it reports an action the operator did
    not do; the manager's belief follows the report (the part in the operator's hand)."""

    def __init__(
        self, truth: WorkspaceTruth, bus: InProcessBus, domain: Domain,
        reports: list[FalseReport],
    ) -> None:  # fmt: skip
        self.truth, self.bus, self.domain = truth, bus, domain
        self.todo = list(reports)
        self.sent: list[str] = []
        self.events: list[dict[str, Any]] = []
        self.human = next((a.name for a in domain.agents.values() if a.is_human), "human")
        self._sub = bus.subscribe(P.STATE_TOPIC, self._on_state)

    def _on_state(self, data: Any) -> None:
        if not self.todo or not isinstance(data, dict) or data.get("type") != "state":
            return
        t = float(data.get("t", 0.0))
        acked = {
            int(e["command"])
            for e in data.get("timeline", [])
            if e.get("type") == "action_end" and e.get("status") == "done" and "command" in e
        }
        for fr in list(self.todo):
            done = [c for end, kind, c in sorted(self.truth.ends) if kind == fr.after and end <= t]
            if len(done) < fr.nth or done[fr.nth - 1] not in acked:
                continue
            self.todo.remove(fr)
            self._report(fr, data, t)

    def _report(self, fr: FalseReport, state: dict[str, Any], t: float) -> None:
        knowledge = state.get("knowledge") or {}
        facts = {tuple(f) for f in knowledge.get("facts", [])}
        busy: set[str] = set()
        for a in (state.get("agents") or {}).values():
            if a.get("command"):
                busy.update(_args(a["command"]["action"]))
        for s in state.get("suggestions") or []:
            for act in s.get("actions", []):
                busy.update(_args(act))
        leg = fr.leg
        if leg is None:
            legs = sorted(
                o["id"] for o in knowledge.get("objects", [])
                if o["type"] == "leg" and ("on_table", o["id"]) in facts and o["id"] not in busy
            )  # fmt: skip
            if not legs:
                return
            leg = legs[-1]
        action = f"{fr.action}({self.human}, {leg})"
        hand = [float(v) for v in self.truth.world.hand]
        self.sent.append(action)
        self.events.append({"t": round(t, 6), "type": "false_report", "action": action})
        self.bus.publish(
            P.HUMAN_TOPIC,
            P.message(
                "human_action", id=f"false:{len(self.sent)}", agent=self.human, action=action,
                t=t, start=t, positions={self.human: hand, leg: hand},
            ),
        )  # fmt: skip

    def close(self) -> None:
        self._sub.cancel()


class _Repair:
    """Repair from normative knowledge (``repair``): when a percept contradicts a reported
    belief, the camera has looked again at once; what is still inconsistent, the operator is
    asked about — "did you do what was reported?" — and answers after ``confirm_s`` with the
    truth (a false report: no). The cell undoes a denied report (``answer``)."""

    def __init__(self, bus: InProcessBus, confirm_s: float) -> None:
        self.bus, self.confirm_s = bus, confirm_s
        self.events: list[dict[str, Any]] = []
        self.repaired = 0
        self.reports: list[tuple[float, str, str, str, bool]] = []  # t, id, agent, action, real
        self.open: dict[str, float] = {}  # object -> when a percept contradicted it
        self.asked: set[str] = set()
        self.run: str | None = None  # the run the reports belong to (the answers name it)
        self._subs = [
            bus.subscribe(P.HUMAN_TOPIC, self._on_report),
            bus.subscribe(P.PERCEPT_TOPIC, self._on_percept),
        ]

    def _on_report(self, data: Any) -> None:
        if not isinstance(data, dict) or data.get("type") != "human_action":
            return
        if isinstance(data.get("run"), str):
            self.run = data["run"]
        if data.get("recognised") is False:
            return
        sensed = data.get("sensed") or {}
        real = not str(data["id"]).startswith("false:") and sensed.get("outcome") in (
            None, "recognised", "uncovered",
        )  # fmt: skip
        self.reports.append(
            (float(data["t"]), str(data["id"]), str(data["agent"]), str(data["action"]), real)
        )

    def _on_percept(self, data: Any) -> None:
        if not isinstance(data, dict):
            return
        t = round(float(data.get("t", 0.0)), 6)
        if data.get("type") == "percept":
            obj = str(data["object"])
            if data.get("contradicts"):
                if obj not in self.open:
                    self.open[obj] = t
                    self.events.append(
                        {"t": t, "type": "repair", "step": "re-perceive", "objects": [obj],
                         "_after": True}
                    )  # fmt: skip
            elif obj in self.open and obj not in self.asked:
                del self.open[obj]  # the second look saw it where it is believed
                self.repaired += 1
                self.events.append(
                    {"t": t, "type": "repaired", "object": obj, "by": "re-perceive",
                     "_after": True}
                )  # fmt: skip
            return
        if data.get("type") != "looked":
            return
        for obj in sorted(self.open):
            if obj in self.asked:
                continue
            self.asked.add(obj)
            about = [r for r in self.reports if r[0] <= t and obj in _args(r[3])]
            if not about:
                self.events.append(
                    {"t": t, "type": "repair", "step": "none", "object": obj, "_after": True,
                     "reason": "no unconfirmed report explains it; waiting for a compatible "
                     "percept"}
                )  # fmt: skip
                continue
            _, rid, agent, action, real = about[-1]
            question = f"did you {action}?"
            self.events.append(
                {"t": t, "type": "repair", "step": "ask operator", "object": obj,
                 "question": question, "_after": True}
            )  # fmt: skip
            self.bus.publish(
                P.HUMAN_TOPIC,
                P.message(
                    "answer", id=f"answer:{rid}", agent=agent, report=rid, object=obj,
                    question=question, answer="yes" if real else "no", t=t + self.confirm_s,
                    **({"run": self.run} if self.run else {}),
                ),
            )  # fmt: skip

    def close(self) -> None:
        for sub in self._subs:
            sub.cancel()


def _args(text: str) -> list[str]:
    inner = text.split("(", 1)[1].rstrip(")") if "(" in text else ""
    return [a.strip() for a in inner.split(",") if a.strip()]


class PerceivedCell:
    """A cooperation with perception in the loop, as a configuration of the cell (see the
    module docstring); :meth:`run` runs it to its end."""

    def __init__(
        self,
        graph: Any,
        domain: Domain,
        truth: KnowledgeBase,
        *,
        types: Iterable[str] | None = None,
        destinations: dict[str, list[str]] | None = None,
        camera: Any = None,
        simulator: Any = None,
        execution: Any = None,
        human_profile: str = "passive",
        humans: Iterable[tuple[str, str]] | None = None,
        seed: int = 0,
        human_takes: Iterable[int | str] | None = None,
        human_sensing: Any = None,
        nudges: Iterable[Nudge] = (),
        false_reports: Iterable[FalseReport] = (),
        repair: bool = False,
        confirm_s: float = 1.0,
        failures: Iterable[Any] = (),
        realtime: float = 0.0,
        trace: Callable[[dict[str, Any]], None] | None = None,
        sink: Callable[[dict[str, Any]], None] | None = None,
        observers: Iterable[Callable[[dict[str, Any]], None]] = (),
        reaction: str = "conflicts",
        on_failure: str | None = None,
        timeout_factor: float = 3.0,
        max_wall_s: float = 3600.0,
        name: str = "perceived",
    ) -> None:
        from flexhrc.sensing.agent import PerceptionAgent
        from flexhrc.taskmanager.simulator import default_simulator

        false_reports = list(false_reports)
        for fr in false_reports:
            if fr.action not in domain.actions:
                raise FlexhrcError(
                    f"false report of {fr.action!r}: the domain has no such action "
                    f"(actions: {', '.join(sorted(domain.actions))})"
                )
        if not (math.isfinite(confirm_s) and confirm_s >= 0):
            raise FlexhrcError(f"confirm_s must be a finite number >= 0, got {confirm_s!r}")
        wanted = list(types) if types is not None else None
        world, names = SimulatedWorkspace.from_knowledge(
            truth, types=wanted, destinations=destinations
        )
        if not world.parts:
            raise FlexhrcError(
                "--perception scene: the scenario has no object with a body to see (a size with "
                "a length and a diameter, or a width and a depth)"
            )
        self.belief = forget_positions(truth, sorted({truth.object(o).type for o in names}))
        self.world = world
        self.truth = WorkspaceTruth(world, nudges)
        self.simulator = simulator if simulator is not None else default_simulator()
        self.execution = real_world(self.simulator, execution)  # the operators' hand wraps it
        hier = getattr(graph, "hierarchy", graph)
        # the scenario the cell and its agents load: the task, with the manager's belief as its
        # world (each call a fresh copy: every agent keeps its own)
        scenario = Scenario(
            name, "the task as the manager believes it", hier, domain, WorldSpec(),
            world_factory=self.belief.copy,
        )  # fmt: skip
        self.scenario = scenario
        self.domain = domain
        # who sees the log, in this order (a streamed log first: what was shown was also stored)
        self.observers = [f for f in (sink, trace) if f is not None] + list(observers)
        self.max_wall_s = max_wall_s
        # the cell's in-process configuration, with the camera as a watcher of its states and
        # every agent's execution applied to the truth; the operators' reports say where their
        # hand is
        self.local = LocalCell(
            scenario, simulator=self.simulator, execution=self.execution, profile=human_profile,
            humans=humans, seed=seed, failures=failures, human_takes=human_takes,
            reaction=reaction, realtime=realtime, max_time_s=None, timeout_factor=timeout_factor,
            human_sensing=human_sensing, on_failure=on_failure, watchers=["perception"],
            publish_state=True, on_executed=self.truth.on_executed, name=name,
            human_execution=_ReportedHand(self.execution, world.hand),
        )  # fmt: skip
        self.bus, self.cell, self.injection = self.local.bus, self.local.cell, self.local.injection
        self.human_sensing = human_sensing
        self.eye = PerceptionAgent(
            scenario, self.bus, truth=self.truth, camera=camera, belief=self.belief.copy(),
            repair=repair,
        )  # fmt: skip
        self.perception = self.eye.perception
        self.false = _FalseReporter(self.truth, self.bus, domain, false_reports)
        self.bus.flush()  # the operators' profiles reach the cell before it starts
        self.repair = _Repair(self.bus, confirm_s) if repair else None

    # -- running ----------------------------------------------------------------------------
    def request_stop(self, reason: str = "interrupted") -> None:
        """End the run at the next turn of the loop with ``interrupted`` (signal-safe)."""
        self.cell.request_stop(reason)

    def run(self) -> RunResult:
        """Run the cooperation to its end."""
        try:
            summary = self.cell.run(pump=self.local.pump, max_wall_s=self.max_wall_s)
            self.bus.flush()
        finally:
            self.close()
        events = self.events()
        add_world_record(summary, self.injection.inner)
        summary["perception"] = self.perception.stats.to_dict()
        summary["perception"]["repaired"] = sum(1 for e in events if e["type"] == "repaired")
        summary["human_sensing"] = self.human_figures()
        for ev in events:  # with the operator's nudges and the repairs in their places
            for observer in self.observers:
                observer(ev)
        latencies = list(self.cell.decision_latencies_s)
        return RunResult(summary["outcome"], summary["reason"], events, summary, latencies)

    def events(self) -> list[dict[str, Any]]:
        """The cell's stored events in log form, with what nobody reports (the operator's
        nudges, the false reports) put in at their times."""
        log = self.local.events
        # (what the wrist sensor made of each action is in the cell's log already)
        extra = self.truth.events + self.false.events
        if self.repair is not None:
            extra += self.repair.events
        # what happened at a time comes before the cell's events of that time; what answers
        # them (a repair's steps, ``_after``), after them
        extra.sort(key=lambda e: (e["t"], bool(e.get("_after"))))
        out: list[dict[str, Any]] = []
        i = 0
        for ev in log:
            while (
                i < len(extra)
                and ev["type"] != "start"
                and (
                    extra[i]["t"] < ev["t"]
                    or (extra[i]["t"] == ev["t"] and not extra[i].get("_after"))
                )
            ):
                out.append({k: v for k, v in extra[i].items() if k != "_after"})
                i += 1
            out.append(ev)
        tail = out.pop() if out and out[-1]["type"] == "summary" else None
        out += [{k: v for k, v in e.items() if k != "_after"} for e in extra[i:]]
        if tail is not None:
            out.append(tail)
        return out

    def human_figures(self) -> dict[str, int]:
        """``human_sensing``: what the wrist sensor made of the operators' actions."""
        out = self.local.sensing_figures()
        if self.human_sensing is None:
            done = sum(1 for ev in self.cell.events if ev.kind == "human_action"
                       and not str(ev.body.get("id", "")).startswith("false:"))  # fmt: skip
            out["performed"] = out["recognised"] = done
        out["false_reports"] += len(self.false.sent)
        return out

    def operator_profiles(self) -> list[tuple[str, str]]:
        return self.local.operator_profiles()

    def unfired_failures(self) -> list[InjectedFailure]:
        """Injected failures whose N-th execution never came (e.g. ``transport:99``)."""
        return self.local.unfired_failures()

    def executions_of(self, action: str) -> int:
        return self.local.executions_of(action)

    def close(self) -> None:
        if self.repair is not None:
            self.repair.close()
        self.false.close()
        self.eye.close()
        self.local.close()


__all__ = [
    "WORLD_CHANGING",
    "FalseReport",
    "Nudge",
    "PerceivedCell",
    "WorkspaceTruth",
    "forget_positions",
    "lying_layout",
    "physical_effect",
]
