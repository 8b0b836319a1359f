"""The engine in one process: the cell's loop with simulated agents on an in-process bus.

There is one loop that drives the Task Manager: :class:`~flexhrc.cell.supervisor.Cell`
(receive, store, feed, send). :class:`LocalCell` is its in-process configuration — an ordered
:class:`~flexhrc.transport.InProcessBus`, one :class:`~flexhrc.cell.components.RobotAgent` per
arm and one :class:`~flexhrc.cell.components.HumanAgent` per operator, the simulated clock —
and what ``flexhrc run``, ``flexhrc demo`` and :func:`flexhrc.scenario.run` are made of. Over
Zenoh or ROS 2 the same loop talks to the same agents in other processes; nothing about the
cooperation differs but the transport.

What a run adds to the loop is only configuration and observation:

* ``failures`` — :class:`InjectedFailure` s, applied by wrapping the arms' execution model (the
  simulated real world), so the manager sees them exactly as it would see a real failure;
* ``observers`` — callables that get every event of the cooperation log as it happens (the
  streamed ``--log``, a trace printer); :class:`RunResult` keeps the whole log as well;
* ``realtime`` — the agents take ``duration / realtime`` seconds of wall time, the loop keeps
  the simulated order;
* ``human_sensing`` — the operators' wrist sensor: the manager learns of a person's action only
  as the sensor recognised it (a miss is a miss), the summary counts what it made of them;
* :meth:`LocalCell.request_stop` — from a signal handler: the run ends with ``interrupted``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from flexhrc.cell.components import HumanAgent, OnExecuted, Replies, RobotAgent, ScenarioLike
from flexhrc.cell.supervisor import Cell
from flexhrc.errors import FlexhrcError
from flexhrc.knowledge import KnowledgeBase
from flexhrc.taskmanager.domain import Domain, GroundAction
from flexhrc.taskmanager.operator import PROFILES, operator_seed
from flexhrc.taskmanager.simulator import (
    AnalyticSimulator,
    ExecutionModel,
    StepReport,
    simulator_name,
)
from flexhrc.transport import InProcessBus

Observer = Callable[[dict[str, Any]], None]


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
    """The end of one cooperation: outcome, reason, the whole log and its summary."""

    outcome: str
    reason: str | None
    events: list[dict[str, Any]]
    summary: dict[str, Any]
    #: wall seconds the Task Manager took to answer each input that made a decision
    #: (:attr:`flexhrc.cell.supervisor.Cell.decision_latencies_s`)
    decision_latency_s: list[float] = field(default_factory=list)


class FailureInjection:
    """An execution model that fails the N-th execution of an action, as told (the counts are
    over every arm that shares this object, in the order the cell dispatches)."""

    def __init__(self, inner: ExecutionModel, failures: Sequence[InjectedFailure]) -> None:
        self.inner = inner
        self.failures = list(failures)
        self.counts: dict[int, int] = {}

    def execute(
        self, action: GroundAction, positions: dict[str, Any], kb: KnowledgeBase, domain: Domain
    ) -> StepReport:
        report = self.inner.execute(action, positions, kb, domain)
        for i, f in enumerate(self.failures):
            if f.action == action.name and (f.agent is None or f.agent in action.agents):
                n = self.counts.get(i, 0) + 1
                self.counts[i] = n
                if n == f.nth:
                    report = StepReport(f.status, report.duration_s / 2, f.reason)
        return report

    def joint_state(self, arms: Iterable[str]) -> dict[str, list[float]]:
        """The wrapped world's arms' joints (none when it has no robot model)."""
        joint_state = getattr(self.inner, "joint_state", None)
        return {} if joint_state is None else dict(joint_state(arms))

    def set_joint_state(self, joints: Mapping[str, Sequence[float]]) -> None:
        set_joint_state = getattr(self.inner, "set_joint_state", None)
        if set_joint_state is not None:
            set_joint_state(joints)

    def unfired(self) -> list[InjectedFailure]:
        return [f for i, f in enumerate(self.failures) if self.counts.get(i, 0) < f.nth]


def real_world(simulator: Any, execution: ExecutionModel | None = None) -> ExecutionModel:
    """The simulated real world the agents execute on: ``execution`` if given, else the
    manager's ``simulator`` when it can execute (one model: branches and world agree), else the
    analytic model."""
    if execution is not None:
        return execution
    return simulator if hasattr(simulator, "execute") else AnalyticSimulator()


def add_world_record(summary: dict[str, Any], world: object) -> None:
    """Add to a summary's ``simulated`` how the arms' simulated world played each action (the
    manager's simulator says how it scored them; in one process they are often one object)."""
    summary["simulated"] = {
        **summary.get("simulated", {}),
        **(getattr(world, "simulated", None) or {}),
    }


class LocalCell:
    """One cooperation of ``scenario`` in this process (see the module docstring).

    ``scenario`` is a :class:`flexhrc.scenario.Scenario` (what the cell reads of it:
    :class:`~flexhrc.cell.components.ScenarioLike`). ``humans`` are (operator, profile) pairs — by
    default every human agent with ``profile``; ``human_takes`` scripts the first operator
    (the K-th cooperation steps, 1-based) and ``replies`` answers its requests beyond "done"
    (:data:`~flexhrc.cell.components.Replies`); ``answer_timeout``: see :class:`Cell`.
    ``simulator`` is the manager's branch simulator;
    ``execution`` the simulated real world (by default the simulator, when it can execute);
    ``store`` an :class:`~flexhrc.cell.store.EventStore` to keep every event in (new, not
    resumed), as ``flexhrc cell --store`` does.

    What other in-process configurations add (perception in the loop,
    :class:`flexhrc.sensing.loop.PerceivedCell`): ``watchers`` and ``publish_state`` — agents the
    cell waits for and the states they watch (see :class:`Cell`); ``on_executed`` — every agent
    reports what it carried out (to a simulated truth); ``human_execution`` — the operators'
    execution model, if not ``execution``; ``name`` — the cell's name in its messages.
    """

    def __init__(
        self,
        scenario: ScenarioLike,
        *,
        simulator: Any = None,
        execution: ExecutionModel | None = None,
        profile: str = "passive",
        humans: Iterable[tuple[str, str]] | None = None,
        seed: int = 0,
        failures: Iterable[InjectedFailure] = (),
        human_takes: Iterable[int | str] | None = None,
        reaction: str = "conflicts",
        observers: Iterable[Observer] = (),
        realtime: float = 0.0,
        max_time_s: float | None = 3600.0,
        timeout_factor: float = 3.0,
        human_sensing: Any = None,
        on_failure: str | None = None,
        answer_timeout: float | None = None,
        replies: Replies | None = None,
        store: Any = None,
        policy: str | None = None,
        watchers: Iterable[str] = (),
        publish_state: bool = False,
        on_executed: OnExecuted | None = None,
        human_execution: ExecutionModel | None = None,
        name: str = "default",
    ) -> None:
        domain = scenario.domain
        if simulator is None:
            simulator = scenario.make_simulator(None)  # the scenario's own choice
        execution = real_world(simulator, execution)
        pairs = (
            list(humans)
            if humans is not None
            else [(a.name, profile) for a in domain.agents.values() if a.is_human]
        )
        for prof in [profile, *(p for _, p in pairs)]:  # a bad ``profile`` even when unused
            if prof not in PROFILES:
                raise FlexhrcError(
                    f"unknown human profile {prof!r}; choose one of {', '.join(PROFILES)}"
                )
        for who, _ in pairs:
            if who not in domain.agents or not domain.agent(who).is_human:
                raise FlexhrcError(f"operator {who!r} is not a human agent of the domain")
        self.scenario = scenario
        self.simulator_name = simulator_name(simulator)
        self.profiles = pairs
        self.human_sensing = human_sensing  # the wrist sensor: what the manager learns
        self.watchers = list(watchers)
        self.injection = FailureInjection(execution, list(failures))
        self.events: list[dict[str, Any]] = []
        self.bus = InProcessBus()
        self.cell = Cell(
            scenario,
            self.bus,
            liveliness=False,
            simulator=simulator,
            seed=seed,
            reaction=reaction,
            on_failure=on_failure,
            answer_timeout=answer_timeout,
            policy=policy,
            realtime=realtime,
            ordered=True,
            observers=[self.events.append, *observers],
            max_time_s=max_time_s,
            idle_s=0.0,  # every agent is in this process: nothing can come later
            publish_state=publish_state,
            watchers=self.watchers,
            name=name,
            quiescent=self._quiescent,
            shared_model=execution is simulator,  # the arms execute on the manager's model
            store=store,
        )
        arm_model: ExecutionModel = self.injection
        self.agents: list[RobotAgent | HumanAgent] = [
            RobotAgent(
                a.name,
                scenario,
                self.bus,
                execution=arm_model,
                timeout_factor=timeout_factor,
                on_executed=on_executed,
            )
            for a in domain.agents.values()
            if not a.is_human
        ]
        takes = list(human_takes) if human_takes is not None else None
        for i, (who, prof) in enumerate(pairs):
            self.agents.append(
                HumanAgent(
                    who,
                    scenario,
                    self.bus,
                    profile=prof,
                    seed=operator_seed(seed, i),
                    execution=human_execution if human_execution is not None else execution,
                    takes=takes if i == 0 else None,
                    on_executed=on_executed,
                    sensing=human_sensing,
                    replies=replies if i == 0 else None,
                )
            )
        if not self.watchers:  # watchers subscribe after this; their maker flushes then
            self.bus.flush()  # the operators' profiles reach the cell before it starts

    def _quiescent(self) -> bool:
        return not self.bus.pending() and all(a.next_due() is None for a in self.agents)

    def pump(self, timeout: float) -> None:
        """Deliver what is on the bus and let every agent act (paced agents: wait for the
        next one due, at most ``timeout``)."""
        if not self.bus.pending():
            due = [d for a in self.agents if (d := a.next_due()) is not None]
            if due:
                time.sleep(max(0.0, min(timeout, min(due) - time.monotonic())))
        self.bus.flush()
        for agent in self.agents:
            agent.poll()

    def request_stop(self, reason: str = "interrupted") -> None:
        """End the run at the next turn of the loop with the outcome ``interrupted``."""
        self.cell.request_stop(reason)

    def run(self) -> RunResult:
        """Run the cooperation to its end."""
        try:
            summary = self.cell.run(pump=self.pump)
        finally:
            self.close()
        if self.human_sensing is not None:
            summary["human_sensing"] = self.sensing_figures()
        add_world_record(summary, self.injection.inner)
        return RunResult(
            self.cell.tm.outcome,
            self.cell.tm.reason,
            self.events,
            summary,
            list(self.cell.decision_latencies_s),
        )

    def close(self) -> None:
        for agent in self.agents:
            agent.close()
        self.cell.close()

    # -- what the command line reports -------------------------------------------------------
    def sensing_figures(self) -> dict[str, int]:
        """``human_sensing``: what the wrist sensor made of the operators' actions."""
        out = {"performed": 0, "recognised": 0, "missed": 0, "false_reports": 0, "uncovered": 0}
        for agent in self.agents:
            if isinstance(agent, HumanAgent):
                for key, n in agent.sensing_figures().items():
                    out[key] += n
        return out

    def operator_profiles(self) -> list[tuple[str, str]]:
        """(operator, profile) of this run."""
        return list(self.profiles)

    def unfired_failures(self) -> list[InjectedFailure]:
        """Injected failures whose N-th execution never came (e.g. ``transport:99``)."""
        return self.injection.unfired()

    def executions_of(self, action: str) -> int:
        """How many times robot commands of ``action`` were started in this run."""
        return sum(
            1
            for ev in self.events
            if ev["type"] == "action_start" and ev["action"].split("(", 1)[0] == action
        )
