"""Running a scenario end to end: Task Manager, simulator, simulated operators, log.

:func:`run` builds a fresh knowledge base and online graph from the :class:`Scenario`, makes
its operators (one :class:`~flexhrc.taskmanager.operator.SimulatedOperator` per entry of
``humans``), chooses the simulator, and runs a :class:`~flexhrc.taskmanager.CooperationRun`
on the simulated clock. The result carries the event log and the summary (``outcome``,
``reason``, ``solved_hyperarcs``, ``by_agent``, the timing of Table I, ...).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.scenario.model import PROFILES, Scenario
from flexhrc.taskmanager.manager import REACTIONS
from flexhrc.taskmanager.runner import CooperationRun, InjectedFailure, RunResult


def prepare(
    scenario: Scenario,
    *,
    profile: str | None = None,
    seed: int = 0,
    simulator: str | Any = None,
    reaction: str = "conflicts",
    trace: Callable[[dict[str, Any]], None] | None = None,
    sink: Callable[[dict[str, Any]], None] | None = None,
    failures: Iterable[InjectedFailure] = (),
    human_takes: Iterable[int | str] | None = None,
    human_sensing: Any = None,
    execution: Any = None,
    realtime: float = 0.0,
    max_time_s: float = 3600.0,
) -> CooperationRun:
    """The :class:`CooperationRun` of one run of ``scenario`` (call ``.run()`` on it).

    ``profile`` overrides every operator's profile; ``simulator`` is ``analytic``,
    ``kinematic`` (a name) or a simulator object; it also plays the real world unless
    ``execution`` is given.
    """
    if profile is not None and profile not in PROFILES:
        raise FlexhrcError(
            f"unknown human profile {profile!r}; choose one of {', '.join(PROFILES)}"
        )
    if reaction not in REACTIONS:
        raise FlexhrcError(f"unknown reaction {reaction!r}; choose one of {', '.join(REACTIONS)}")
    sim = (
        scenario.make_simulator(simulator)
        if simulator is None or isinstance(simulator, str)
        else simulator
    )
    pairs = [(h.name, profile or h.profile) for h in scenario.humans]
    return CooperationRun(
        scenario.online_graph(),
        scenario.domain,
        scenario.world(),
        simulator=sim,
        execution=execution,
        human_profile=pairs[0][1] if pairs else "passive",
        seed=seed,
        failures=list(failures),
        trace=trace,
        sink=sink,
        human_takes=human_takes,
        human_sensing=human_sensing,
        humans=pairs,
        reaction=reaction,
        realtime=realtime,
        max_time_s=max_time_s,
    )


def run(scenario: Scenario, **kwargs: Any) -> RunResult:
    """Run ``scenario`` to its end; keyword arguments as :func:`prepare`."""
    return prepare(scenario, **kwargs).run()
