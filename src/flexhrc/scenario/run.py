"""Running a scenario end to end: the engine in one process, on the simulated clock.

:func:`run` (and :func:`prepare`, which builds the run without starting it) configures the one
cooperation loop, :class:`~flexhrc.cell.Cell`, in its in-process form
(:class:`~flexhrc.cell.local.LocalCell`): an ordered in-process bus, one simulated arm agent per
robot, one simulated operator per entry of the scenario's ``humans`` (with its profile, or
``profile`` for all), the scenario's simulator (or ``simulator``). The result carries the event
log and the summary (``outcome``, ``reason``, ``solved_hyperarcs``, ``by_agent``, the timing of
Table I, ...).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from flexhrc.cell.local import InjectedFailure, LocalCell, RunResult
from flexhrc.errors import FlexhrcError
from flexhrc.scenario.model import PROFILES, Scenario


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
    on_failure: str | None = None,
    answer_timeout: float | None = None,
    policy: str | None = None,
) -> LocalCell:
    """One run of ``scenario``, ready to go (call ``.run()`` on it).

    ``profile`` overrides every operator's profile; ``simulator`` is ``analytic``,
    ``kinematic`` (a name) or a simulator object; it also plays the real world unless
    ``execution`` is given. ``sink`` and ``trace`` see every event of the log as it happens.
    ``on_failure`` (``retry`` or ``paper``) overrides the scenario's failure policy,
    ``answer_timeout`` (seconds) the scenario's ``answer_timeout``; ``policy`` (``paper`` or
    ``lookahead``) the scenario's decision policy.
    """
    if profile is not None and profile not in PROFILES:
        raise FlexhrcError(
            f"unknown human profile {profile!r}; choose one of {', '.join(PROFILES)}"
        )
    # (the Task Manager refuses an unknown reaction; the cell makes the scenario's simulator)
    sim = scenario.make_simulator(simulator) if isinstance(simulator, str) else simulator
    pairs = [(h.name, profile or h.profile) for h in scenario.humans]
    observers = [f for f in (sink, trace) if f is not None]  # the log first: shown = stored
    return LocalCell(
        scenario,
        simulator=sim,
        execution=execution,
        humans=pairs,
        seed=seed,
        failures=failures,
        human_takes=human_takes,
        reaction=reaction,
        on_failure=on_failure,
        answer_timeout=answer_timeout,
        policy=policy,
        observers=observers,
        realtime=realtime,
        max_time_s=max_time_s,
        human_sensing=human_sensing,
    )


def run(scenario: Scenario, **kwargs: Any) -> RunResult:
    """Run ``scenario`` to its end; keyword arguments as :func:`prepare`."""
    return prepare(scenario, **kwargs).run()
