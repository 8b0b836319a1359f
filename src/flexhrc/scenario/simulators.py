"""Choosing the branch simulator at the edge (command line, scenario loader, cell).

The Task Manager knows only the :class:`~flexhrc.taskmanager.Simulator` protocol and defaults to
the :class:`~flexhrc.taskmanager.AnalyticSimulator`; the kinematic simulator lives in
:mod:`flexhrc.action`, which sits *above* the Task Manager. Picking between them therefore
happens here, on top of both, and the chosen object is passed down.
"""

from __future__ import annotations

import importlib.util
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.events import SIMULATORS
from flexhrc.taskmanager.kinds import TIMINGS, timing_profile
from flexhrc.taskmanager.simulator import AnalyticSimulator

CHOICES = ("auto", *SIMULATORS)
#: The timing profiles a run, a scenario's ``timing:`` key and ``--timing`` may name.
TIMING_CHOICES = tuple(TIMINGS)


def resolve_simulator_name(choice: str) -> str:
    """``auto`` -> ``kinematic`` when the ``sim`` extra (pinocchio) is installed, else
    ``analytic``; the other names are returned as they are."""
    if choice not in CHOICES:
        raise FlexhrcError(f"unknown simulator {choice!r}; choose one of {', '.join(CHOICES)}")
    if choice == "auto":
        return "kinematic" if importlib.util.find_spec("pinocchio") is not None else "analytic"
    return choice


def choose_simulator(
    choice: str = "auto", *, option: str = "--simulator", timing: str = "default"
) -> tuple[str, Any]:
    """``(name, simulator)`` for ``choice`` (``auto``, ``analytic`` or ``kinematic``), timed
    by the profile ``timing`` (:data:`~flexhrc.taskmanager.kinds.TIMINGS`: ``default``, or
    ``paper``, the paper's Baxter and operator, to set beside its Table I).

    The kinematic simulator is also an execution model (it plays the real robot); the analytic
    one is both as well. ``option`` names the setting in the error when the ``sim`` extra is
    missing.
    """
    profile = timing_profile(timing)
    name = resolve_simulator_name(choice)
    if name == "analytic":
        return name, AnalyticSimulator(profile)
    try:
        from flexhrc.action.bridge import KinematicTaskSimulator

        return name, KinematicTaskSimulator(timing=profile)
    except ImportError as exc:
        raise FlexhrcError(
            f"{option} kinematic needs the sim extra ({exc.name} is missing): "
            "pip install 'flexhrc[sim]'"
        ) from None
