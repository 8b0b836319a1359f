"""A live cell: the Task Manager as a service, agents as components or processes.

* :class:`~flexhrc.cell.supervisor.Cell` — the manager side: receive, store, feed, send;
  lost agents, resume, a JSON snapshot and one entry for human input (``docs/cell.md``);
* :class:`~flexhrc.cell.components.RobotAgent`, :class:`~flexhrc.cell.components.HumanAgent` —
  simulated agents that speak the protocol (:mod:`flexhrc.cell.protocol`, ``docs/protocol.md``);
* :class:`~flexhrc.cell.store.EventStore` — the SQLite event store;
* :class:`~flexhrc.cell.local.LocalCell` — the loop in one process with simulated agents
  (what ``flexhrc run`` and :func:`flexhrc.scenario.run` are made of);
* :func:`~flexhrc.cell.serve.serve_cell` (:class:`~flexhrc.cell.serve.CellConfig`) and
  :func:`~flexhrc.cell.serve.join_cell` (:class:`~flexhrc.cell.serve.AgentConfig`) —
  ``flexhrc cell`` and ``flexhrc agent`` as functions.

The cell is the one loop that drives the Task Manager. It imports the Task Manager and the
transports, never :mod:`flexhrc.scenario`: a :class:`flexhrc.scenario.Scenario` reaches it
through :class:`~flexhrc.cell.components.ScenarioLike`, the protocol of the members it reads
(``name``, ``domain``, ``world()``, ``online_graph()``, ``make_simulator(choice)``); scenario,
panel, ROS 2 and the command line sit above it.
"""

from flexhrc.cell.components import HumanAgent, RobotAgent, ScenarioLike
from flexhrc.cell.serve import AgentConfig, CellConfig, join_cell, serve_cell
from flexhrc.cell.store import EventStore, read_store, summarise_store
from flexhrc.cell.supervisor import Cell

__all__ = [
    "AgentConfig",
    "Cell",
    "CellConfig",
    "EventStore",
    "HumanAgent",
    "RobotAgent",
    "ScenarioLike",
    "join_cell",
    "read_store",
    "serve_cell",
    "summarise_store",
]
