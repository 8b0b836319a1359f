"""Activation-spreading behaviour network with THEN/AND/OR goal nodes (paper 002, Fraser et al.).

The same compact task tree is both the task representation and the controller: goal nodes spread
activation top-down (Algorithms 2–4), behaviours report activation potential bottom-up
(Algorithms 5–8), every node runs the update loop of Algorithm 1, arm mutexes are won by bidding
and validity checking resets a behaviour whose object moved.

>>> from flexhrc.behavior import parse_prefix, random_world, run_task
>>> task = parse_prefix("(THEN a (AND b c))")
>>> result = run_task(task, random_world(task.behaviors, seed=1))
>>> result.outcome, result.order[0]
('done', 'a')
"""

from flexhrc.behavior.behaviors import BehaviorNode, PickAndPlace
from flexhrc.behavior.goals import AndNode, GoalNode, OrNode, ThenNode
from flexhrc.behavior.messages import ActivationMsg, LogEvent, MutexReply, MutexRequest, StateMsg
from flexhrc.behavior.mutex import ArmMutex
from flexhrc.behavior.network import BehaviorNetwork, Run, RunResult, run_task
from flexhrc.behavior.node import Node
from flexhrc.behavior.params import NetworkParams, NodeState
from flexhrc.behavior.render import to_ascii, to_dot
from flexhrc.behavior.task import (
    AND,
    BEHAVIOR,
    OR,
    THEN,
    Task,
    TaskNode,
    build_task,
    parse_prefix,
)
from flexhrc.behavior.taskfile import TaskDocument, load_task, load_task_document, parse_task
from flexhrc.behavior.types import (
    BehaviorFactory,
    BehaviorTypeBuilder,
    Visit,
    behavior_types,
    register_behavior_type,
)
from flexhrc.behavior.validate import allowed_next, check_nearest_first, check_run
from flexhrc.behavior.validity import ValidityCheck
from flexhrc.behavior.world import (
    Arm,
    MoveRule,
    PickAndPlaceMotion,
    TabletopWorld,
    WorldObject,
    random_world,
)

__all__ = [
    "AND",
    "BEHAVIOR",
    "OR",
    "THEN",
    "ActivationMsg",
    "AndNode",
    "Arm",
    "ArmMutex",
    "BehaviorFactory",
    "BehaviorNetwork",
    "BehaviorNode",
    "BehaviorTypeBuilder",
    "GoalNode",
    "LogEvent",
    "MoveRule",
    "MutexReply",
    "MutexRequest",
    "NetworkParams",
    "Node",
    "NodeState",
    "OrNode",
    "PickAndPlace",
    "PickAndPlaceMotion",
    "Run",
    "RunResult",
    "StateMsg",
    "TabletopWorld",
    "Task",
    "TaskDocument",
    "TaskNode",
    "ThenNode",
    "ValidityCheck",
    "Visit",
    "WorldObject",
    "allowed_next",
    "behavior_types",
    "build_task",
    "check_nearest_first",
    "check_run",
    "load_task",
    "load_task_document",
    "parse_prefix",
    "parse_task",
    "random_world",
    "register_behavior_type",
    "run_task",
    "to_ascii",
    "to_dot",
]
