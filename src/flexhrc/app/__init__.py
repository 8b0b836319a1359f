"""The application layer: each command of ``flexhrc`` as one call of the library.

A command's options become a frozen config, the call returns a report, and the command only
prints that report — so a program can do everything a command does:

* :func:`run_scenario` — ``flexhrc run FILE|NAME`` and ``flexhrc demo table``
  (:class:`RunConfig`, :class:`TableDemo` in; :class:`RunReport` out);
* :func:`replay` — ``flexhrc replay LOG`` (:class:`ReplayReport` out);
* :func:`what_if` — ``flexhrc replay STORE --fork-at K`` (:class:`ForkReport` out);
* :func:`learn_model` — ``flexhrc learn STORE... -o FILE`` (an operator model out);
* :func:`plan_scenario` — ``flexhrc plan SCENARIO`` (:class:`PlanConfig` in,
  :class:`PlanReport` out: the CP-SAT plan of :mod:`flexhrc.planning`).

This package stands above the front ends (the perception in the loop of
:mod:`flexhrc.sensing` is one of the run's configurations) and below the command line.
"""

from __future__ import annotations

from flexhrc.app.learn import learn_model
from flexhrc.app.plan import PlanConfig, PlanReport, plan_scenario
from flexhrc.app.run import RunConfig, RunReport, TableDemo, run_scenario
from flexhrc.app.whatif import ForkReport, what_if
from flexhrc.cell.replay import ReplayReport, replay

__all__ = [
    "ForkReport",
    "PlanConfig",
    "PlanReport",
    "ReplayReport",
    "RunConfig",
    "RunReport",
    "TableDemo",
    "learn_model",
    "plan_scenario",
    "replay",
    "run_scenario",
    "what_if",
]
