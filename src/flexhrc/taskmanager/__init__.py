"""Task Manager: action schemas, Action-State table, decision tree, allocation (paper 000, V).

* :class:`Domain`, :class:`ActionSchema`, :class:`Agent` — eq. (20) and agents(a);
* :class:`ActionStateTable`, :class:`DecisionTree`, :class:`Branch` — rows and branches;
* :class:`Simulator`, :class:`AnalyticSimulator` — branch simulation, utility of eq. (21);
* :class:`TaskManager` — the sans-IO manager (commands, suggestions, adaptation);
* :mod:`~flexhrc.taskmanager.kinds` — the action kinds (timing, motions, effect, words, colour).

A whole cooperation — the manager with simulated arms and operators — is a configuration of the
one loop that drives it, :class:`flexhrc.cell.Cell` (:func:`flexhrc.scenario.run`).
"""

from flexhrc.taskmanager.decision import ActionStateTable, Branch, DecisionTree, Row
from flexhrc.taskmanager.domain import ActionSchema, Agent, AgentSpec, Domain, GroundAction
from flexhrc.taskmanager.manager import (
    Ack,
    Command,
    HumanAction,
    Stop,
    Suggest,
    TaskManager,
)
from flexhrc.taskmanager.operator import PROFILES
from flexhrc.taskmanager.simulator import (
    AnalyticSimulator,
    ExecutionModel,
    SimulationResult,
    Simulator,
    StepReport,
    Timing,
    default_simulator,
)

__all__ = [
    "PROFILES",
    "Ack",
    "ActionSchema",
    "ActionStateTable",
    "Agent",
    "AgentSpec",
    "AnalyticSimulator",
    "Branch",
    "Command",
    "DecisionTree",
    "Domain",
    "ExecutionModel",
    "GroundAction",
    "HumanAction",
    "Row",
    "SimulationResult",
    "Simulator",
    "StepReport",
    "Stop",
    "Suggest",
    "TaskManager",
    "Timing",
    "default_simulator",
]
