"""Which scenario a ROS 2 node serves: its knowledge base, domain and graph."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from flexhrc.errors import UnknownNameError

BUILTIN = ("table_assembly",)
ALIASES = {"table": "table_assembly", "table_assembly": "table_assembly"}


@dataclass
class NodeScenario:
    """Fresh copies of a scenario's parts for one node."""

    name: str
    source: Any

    def knowledge(self) -> Any:
        return self.source.knowledge()

    def domain(self) -> Any:
        return self.source.domain()

    def graph(self) -> Any:
        return self.source.graph()


def load_node_scenario(spec: str, seed: int = 0) -> NodeScenario:
    """A built-in scenario by name (``table_assembly``, alias ``table``)."""
    key = ALIASES.get(spec)
    if key is None:
        raise UnknownNameError(
            f"unknown scenario {spec!r} (argument SCENARIO); built in: {', '.join(BUILTIN)}"
        )
    from flexhrc.scenarios.table_assembly import TableScenario

    return NodeScenario(key, TableScenario(seed=seed))
