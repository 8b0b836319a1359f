"""Build a behaviour network from a task and run it on a simulated clock (paper 002, Sec. III-C/D).

:class:`BehaviorNetwork` turns every :class:`~flexhrc.behavior.task.TaskNode` into a node object
(THEN/AND/OR goal nodes, :class:`~flexhrc.behavior.behaviors.PickAndPlace` leaves), adds one
:class:`~flexhrc.behavior.mutex.ArmMutex` per arm of the world, and wires nothing but topics
on a transport. One :meth:`~BehaviorNetwork.tick` is:

1. advance the world to the tick's time (scheduled object moves, arm motions);
2. the *driver* — standing in for whoever gives the robot its task — sends activation 1.0 to
   the root;
3. run every node's update loop (Algorithm 1) and every mutex — by default only the nodes that
   are busy or were woken by a message or a sensing change (a quiescent node's update would do
   nothing; ``event_driven=False`` runs them all, with identical results);
4. flush the transport: messages sent in this tick arrive before the next one.

Because of step 4 the order of step 3 does not matter; the whole run is a deterministic function
of the task, the world, the parameters and the seed. The runner itself learns about the network
only by listening: to the root's state topic (to know when the task is done) and to the log
topic (for the event log).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from flexhrc.behavior.behaviors import BehaviorNode, PickAndPlace
from flexhrc.behavior.goals import GOAL_CLASSES
from flexhrc.behavior.messages import (
    LOG_TOPIC,
    ActivationMsg,
    ActivationRelease,
    LogEvent,
    StateMsg,
    activation_topic,
    state_topic,
)
from flexhrc.behavior.mutex import ArmMutex
from flexhrc.behavior.node import DONE, Node
from flexhrc.behavior.params import NetworkParams
from flexhrc.behavior.task import BEHAVIOR, Task
from flexhrc.behavior.types import BehaviorFactory
from flexhrc.behavior.world import TabletopWorld
from flexhrc.errors import UnknownNameError
from flexhrc.transport.base import SimClock, Transport
from flexhrc.transport.inprocess import InProcessBus

DRIVER = "driver"


@dataclass(frozen=True)
class Run:
    """One execution of a behaviour: started on an arm, ended done or reset."""

    behavior: str
    arm: str
    start: float
    end: float | None
    outcome: str  # "done", "reset" or "unfinished"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class RunResult:
    """What happened: outcome, order of the completed behaviours, runs, the full event log."""

    outcome: str  # "done" or "timeout"
    ticks: int
    time: float
    order: list[str]
    runs: list[Run]
    resets: int
    log: list[LogEvent] = field(repr=False)
    behaviors: list[str] = field(default_factory=list)
    arms: list[str] = field(default_factory=list)

    @classmethod
    def of_log(
        cls,
        outcome: str,
        ticks: int,
        time: float,
        log: list[LogEvent],
        behaviors: list[str],
        arms: list[str],
    ) -> RunResult:
        """The result whose runs, order and resets are those of the event ``log``."""
        runs = runs_from_log(log)
        order = [r.behavior for r in runs if r.outcome == "done"]
        resets = sum(1 for r in runs if r.outcome == "reset")
        return cls(outcome, ticks, time, order, runs, resets, list(log), behaviors, arms)

    def state_intervals(self) -> dict[str, list[tuple[str, float, float]]]:
        """Per behaviour, the (state, start, end) intervals of the paper's Fig. 4 Gantt chart."""
        wanted = set(self.behaviors)
        current: dict[str, tuple[str, float]] = {b: ("inactive", 0.0) for b in self.behaviors}
        out: dict[str, list[tuple[str, float, float]]] = {b: [] for b in self.behaviors}
        for ev in self.log:
            if ev.kind != "state" or ev.source not in wanted:
                continue
            state, since = current[ev.source]
            if ev.t > since:
                out[ev.source].append((state, since, ev.t))
            current[ev.source] = (str(ev.data["to"]), ev.t)
        for b, (state, since) in current.items():
            if self.time > since:
                out[b].append((state, since, self.time))
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "outcome": self.outcome,
            "order": list(self.order),
            "ticks": self.ticks,
            "resets": self.resets,
            "time": self.time,
            "arms": list(self.arms),
            "runs": [r.to_dict() for r in self.runs],
        }


def runs_from_log(log: list[LogEvent]) -> list[Run]:
    """Every run of every behaviour, in the order the runs started (log order for equal times)."""
    open_runs: dict[str, tuple[str, float, int]] = {}
    runs: list[tuple[int, Run]] = []
    for seq, ev in enumerate(log):
        if ev.kind == "start":
            open_runs[ev.source] = (str(ev.data["arm"]), ev.t, seq)
        elif ev.kind in ("done", "reset") and ev.source in open_runs:
            arm, start, first = open_runs.pop(ev.source)
            runs.append((first, Run(ev.source, arm, start, ev.t, ev.kind)))
    for name, (arm, start, first) in open_runs.items():
        runs.append((first, Run(name, arm, start, None, "unfinished")))
    runs.sort(key=lambda item: item[0])
    return [run for _, run in runs]


class BehaviorNetwork:
    """A task turned into communicating nodes, plus one mutex per arm, on a simulated clock.

    Every behaviour leaf is a :class:`~flexhrc.behavior.behaviors.PickAndPlace` of the object
    with its name, unless ``behaviors`` maps the leaf's name to a factory of another
    :class:`~flexhrc.behavior.behaviors.BehaviorNode` (your own behaviours; see
    ``docs/behavior.md`` and ``examples/custom_behavior.py``).
    """

    def __init__(
        self,
        task: Task,
        world: TabletopWorld,
        params: NetworkParams | None = None,
        transport: Transport | None = None,
        event_driven: bool = True,
        behaviors: Mapping[str, BehaviorFactory] | None = None,
    ) -> None:
        self.task = task
        #: Skip quiescent nodes (see :mod:`flexhrc.behavior.node`); ``False`` updates every node
        #: every tick — same results, for checking and for worst-case benchmarks.
        self.event_driven = event_driven
        self.world = world
        self.params = params or NetworkParams()
        self.transport: Transport = transport if transport is not None else InProcessBus()
        self.clock = SimClock(self.params.tick_period)
        self.log: list[LogEvent] = []
        #: Called with every log event as it is recorded (live trace, streamed ``--log``).
        self.listeners: list[Callable[[LogEvent], None]] = []
        self.drive = True
        self.finished = False
        self.transport.subscribe(LOG_TOPIC, self._record)
        self.nodes: dict[str, Node] = {}
        for tn in task.walk():
            if tn.kind == BEHAVIOR:
                factory = (behaviors or {}).get(tn.name)
                if factory is not None:
                    self.nodes[tn.name] = factory(tn.name, world, self.transport, self.params)
                    continue
                if not world.has_object(tn.name):
                    where = task.source + (f":{tn.line}" if tn.line else "") + ": "
                    where += f"column {tn.column}: " if tn.column else ""
                    raise UnknownNameError(
                        f"{where}behaviour {tn.name!r} has no object in the world "
                        f"(objects: {', '.join(sorted(world.objects))})"
                    )
                self.nodes[tn.name] = PickAndPlace(
                    tn.name, tn.name, world, self.transport, self.params
                )
            else:
                cls = GOAL_CLASSES[tn.kind]
                self.nodes[tn.name] = cls(
                    tn.name, [c.name for c in tn.children], self.transport, self.params
                )
        self.mutexes = [ArmMutex(arm, self.transport, self.params) for arm in world.arm_names]
        self._order = list(self.nodes.values())
        # Event-driven stepping (see flexhrc.behavior.node): only busy or woken nodes run a tick.
        self._awake: set[int] = set(range(len(self._order)))
        self._sensors: dict[str, int] = {}
        for slot, node in enumerate(self._order):
            node.set_waker(self._awake.add, slot)
            if isinstance(node, BehaviorNode) and node.object is not None:
                self._sensors[node.object] = slot
        world.add_sensing_listener(self._on_sensing)
        self._root_topic = activation_topic(task.root.name)
        self._drive_msg = ActivationMsg(DRIVER, 1.0, self.params.latched)
        self._driving = False  # latched: the root holds the driver's activation
        self.transport.subscribe(state_topic(task.root.name), self._on_root_state)

    def _record(self, ev: LogEvent) -> None:
        self.log.append(ev)
        for listener in self.listeners:
            listener(ev)

    def _on_sensing(self, objects: set[str] | None) -> None:
        if objects is None:
            self._awake.update(self._sensors.values())
        else:
            self._awake.update(self._sensors[o] for o in objects if o in self._sensors)

    def _on_root_state(self, msg: StateMsg) -> None:
        if msg.state == DONE:
            self.finished = True

    def node(self, name: str) -> Node:
        try:
            return self.nodes[name]
        except KeyError:
            raise UnknownNameError(f"no node named {name!r}") from None

    def tick(self) -> None:
        """One update loop of the whole network (see the module docstring)."""
        tick = self.clock.tick
        now = self.clock.now()
        for ev in self.world.step(now):
            kind = ev.pop("kind")
            self._record(LogEvent(tick, now, "world", kind, ev))
        want = self.drive and not self.finished
        if not self.params.latched:
            if want:
                self.transport.publish(self._root_topic, self._drive_msg)
        elif want != self._driving:
            self._driving = want
            self.transport.publish(
                self._root_topic, self._drive_msg if want else ActivationRelease(DRIVER)
            )
        order = self._order
        if self.event_driven:
            awake = sorted(self._awake)
            self._awake.clear()
            for slot in awake:
                node = order[slot]
                node.update(tick, now)
                if node.busy():
                    self._awake.add(slot)
        else:
            for node in order:
                node.update(tick, now)
        for mutex in self.mutexes:
            mutex.update(tick, now)
        self.transport.flush()
        self.clock.advance()

    def run(self, max_ticks: int | None = None) -> RunResult:
        """Tick until the root reports done or ``max_ticks`` ticks have run (default
        :func:`default_max_ticks`: enough for the task's size, so a big task never stops for
        lack of ticks)."""
        if max_ticks is None:
            max_ticks = default_max_ticks(self.task)
        while not self.finished and self.clock.tick < max_ticks:
            self.tick()
        return self.result()

    def result(self) -> RunResult:
        return RunResult.of_log(
            "done" if self.finished else "timeout",
            self.clock.tick,
            self.clock.now(),
            self.log,
            self.task.behaviors,
            self.world.arm_names,
        )


def default_max_ticks(task: Task) -> int:
    """50 000 ticks plus 1 000 per behaviour: a pick-and-place takes about 100 ticks, so a task
    that could finish is never cut short, and one that cannot stops in bounded time."""
    return 50_000 + 1_000 * len(task.behaviors)


def run_task(
    task: Task,
    world: TabletopWorld,
    params: NetworkParams | None = None,
    max_ticks: int | None = None,
) -> RunResult:
    """Build a network for ``task`` in ``world`` and run it to completion (or ``max_ticks``)."""
    return BehaviorNetwork(task, world, params).run(max_ticks)
