"""A live cell: the Task Manager as a service, agents as components or processes.

* :class:`~flexhrc.cell.supervisor.Cell` — the manager side: receive, store, feed, send;
  lost agents, resume, a JSON snapshot and one entry for human input (``docs/cell.md``);
* :class:`~flexhrc.cell.components.RobotAgent`, :class:`~flexhrc.cell.components.HumanAgent` —
  simulated agents that speak the protocol (:mod:`flexhrc.cell.protocol`, ``docs/protocol.md``);
* :class:`~flexhrc.cell.store.EventStore` — the SQLite event store;
* :func:`~flexhrc.cell.scenario_ref.load_scenario` — a scenario by name or file.

The cell sits on top of the layers: it imports the Task Manager and the transports, nothing
imports it but the command line (and later the operator panel and the ROS 2 bridge).
"""

from flexhrc.cell.components import HumanAgent, RobotAgent
from flexhrc.cell.scenario_ref import load_scenario
from flexhrc.cell.store import EventStore, read_store, summarise_store
from flexhrc.cell.supervisor import Cell

__all__ = [
    "Cell",
    "EventStore",
    "HumanAgent",
    "RobotAgent",
    "load_scenario",
    "read_store",
    "summarise_store",
]
