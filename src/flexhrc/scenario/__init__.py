"""Your own cooperation task as one scenario file (``flexhrc: 1``).

A scenario file says everything a cooperation needs — the AND/OR graph, the domain (agents,
action schemas, processes), the world (typed objects with poses and sizes, places, initial
facts, supertypes) and the operators — and runs end to end through the Task Manager, a
simulator and generic simulated operators. See ``docs/scenarios.md`` for the format and a
tutorial; ``flexhrc scenario new DIR`` writes a starter.

The loader API (for the command line, the live cell, notebooks)::

    from flexhrc import scenario

    sc = scenario.load("ball_in_box")          # a shipped name, or a path to a .yaml file
    sc.graph                                   # HierarchicalGraph (definitions)
    sc.online_graph()                          # a fresh OnlineGraph for one run
    sc.domain                                  # Domain: agents, actions, processes
    sc.world()                                 # a fresh KnowledgeBase (objects, places, facts)
    sc.humans                                  # (HumanSpec(name, profile, speed), ...)
    sc.simulator                               # "analytic" or "kinematic" (the file's choice)
    sc.make_simulator("analytic")              # the simulator object (the choice at the edge)
    result = scenario.run(sc, profile="cooperative", seed=3)   # a RunResult

    faults = scenario.validate("my_task.yaml") # [Fault(source, line, message, severity)]
    scenario.validation("my_task.yaml")        # what `flexhrc scenario validate --json` prints
    scenario.graph_of("my_task.yaml")          # the task graph of a scenario or a graph file

    scenario.load_scenario("table_assembly", segments="legs")  # any name or file, any front end
    scenario.table_assembly(legs=6, tabletop="0.6x0.6")         # ready-made tasks, built in code
    scenario.parallel_assembly(arms=4, humans=2, legs=8)

A scenario is the only shape of a task: the ready-made tasks are builders that return one
(:mod:`flexhrc.scenario.builtin`), the older ``scenario: table_assembly`` files are translated
into one (:mod:`flexhrc.scenario.legacy`), and the cell takes one.

Every call of :meth:`Scenario.world` and :meth:`Scenario.online_graph` returns new objects, so a
loaded scenario can be run many times; nothing in it reads a clock or a file after loading.
"""

from __future__ import annotations

from flexhrc.scenario.builtin import parallel_assembly, table_assembly
from flexhrc.scenario.format import Fault, ScenarioError, check, graph_of, is_scenario_file
from flexhrc.scenario.legacy import from_legacy
from flexhrc.scenario.loader import (
    SHIPPED,
    describe_shipped,
    load,
    resolve,
    shipped_path,
    validate,
    validation,
)
from flexhrc.scenario.model import PROFILES, SIMULATORS, HumanSpec, ObjectSpec, Scenario, WorldSpec
from flexhrc.scenario.run import prepare, run
from flexhrc.scenario.source import load_scenario, select

__all__ = [
    "PROFILES",
    "SHIPPED",
    "SIMULATORS",
    "Fault",
    "HumanSpec",
    "ObjectSpec",
    "Scenario",
    "ScenarioError",
    "WorldSpec",
    "check",
    "describe_shipped",
    "from_legacy",
    "graph_of",
    "is_scenario_file",
    "load",
    "load_scenario",
    "parallel_assembly",
    "prepare",
    "resolve",
    "run",
    "select",
    "shipped_path",
    "table_assembly",
    "validate",
    "validation",
]
