"""Task Manager: action schemas, Action-State table, decision tree, allocation (paper 000, V).

* :class:`Domain`, :class:`ActionSchema`, :class:`Agent` — eq. (20) and agents(a);
* :class:`ActionStateTable`, :class:`DecisionTree`, :class:`Branch` — rows and branches;
* :class:`Simulator`, :class:`AnalyticSimulator` — branch simulation, utility of eq. (21);
* :class:`TaskManager` — the sans-IO manager (commands, suggestions, adaptation);
* :class:`CooperationRun` — a whole cooperation with simulated arms and a simulated human.
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
from flexhrc.taskmanager.runner import PROFILES, CooperationRun, InjectedFailure, RunResult
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
    "CooperationRun",
    "DecisionTree",
    "Domain",
    "ExecutionModel",
    "GroundAction",
    "HumanAction",
    "InjectedFailure",
    "Row",
    "RunResult",
    "SimulationResult",
    "Simulator",
    "StepReport",
    "Stop",
    "Suggest",
    "TaskManager",
    "Timing",
    "default_simulator",
]
