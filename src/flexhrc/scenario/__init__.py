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
    scenario.graph_of("my_task.yaml")          # the task graph of a scenario or a graph file

Every call of :meth:`Scenario.world` and :meth:`Scenario.online_graph` returns new objects, so a
loaded scenario can be run many times; nothing in it reads a clock or a file after loading.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.scenario.format import (
    Fault,
    ScenarioError,
    check,
    graph_of,
    is_scenario_file,
    parse,
)
from flexhrc.scenario.model import PROFILES, SIMULATORS, HumanSpec, ObjectSpec, Scenario, WorldSpec
from flexhrc.scenario.run import prepare, run

#: The scenarios shipped with flexhrc (package data ``flexhrc/scenarios/data/NAME/NAME.yaml``).
SHIPPED = ("table_assembly", "ball_in_box", "kitchen_drawer")


def shipped_path(name: str) -> Path:
    """The file of a shipped scenario."""
    if name not in SHIPPED:
        raise UnknownNameError(
            f"unknown scenario {name!r}; shipped: {', '.join(SHIPPED)} (or give a .yaml file)"
        )
    ref = resources.files("flexhrc.scenarios").joinpath(f"data/{name}/{name}.yaml")
    return Path(str(ref))


def resolve(path_or_name: str | Path) -> Path:
    """A scenario file from a path or a shipped name."""
    p = Path(path_or_name)
    if p.suffix.lower() in (".yaml", ".yml") or p.exists() or "/" in str(path_or_name):
        return p
    return shipped_path(str(path_or_name))


def load(path_or_name: str | Path) -> Scenario:
    """Load a scenario file (or a shipped scenario by name); raises :class:`ScenarioError`
    (a :class:`~flexhrc.errors.FormatError` naming file and line) when it has errors."""
    return parse(resolve(path_or_name))


def validate(path_or_name: str | Path) -> list[Fault]:
    """Every fault of a scenario file (errors and warnings), each with its file and line."""
    try:
        return check(resolve(path_or_name))[1]
    except FlexhrcError as exc:
        return [Fault(str(path_or_name), None, str(exc))]


def describe_shipped() -> list[tuple[str, str]]:
    """(name, one-line description) of every shipped scenario."""
    out = []
    for name in SHIPPED:
        sc = load(name)
        out.append((name, sc.description.strip().splitlines()[0] if sc.description else ""))
    return out


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
    "graph_of",
    "is_scenario_file",
    "load",
    "prepare",
    "resolve",
    "run",
    "shipped_path",
    "validate",
]
