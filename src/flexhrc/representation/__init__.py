"""Task representation: hierarchical first-order AND/OR graphs (paper 000, section IV).

* :class:`Node`, :class:`Hyperarc`, :class:`AndOrGraph` — graph definitions;
* :class:`HierarchicalGraph` — definitions nested by transitions (eqs. 12-16), and
  :class:`Transfer` — how a grounding passes through one (M1/M2, eqs. 15-16);
* :class:`OnlineGraph` — the online phase: statuses, DP costs, suggestions, event history;
* :func:`load` / :func:`save` — ANDOR text, YAML and DOT formats (``formats``).
"""

from flexhrc.representation.formats import load, save
from flexhrc.representation.graph import AndOrGraph, Hyperarc, Node
from flexhrc.representation.hierarchy import (
    HierarchicalGraph,
    Transfer,
    qualify,
    split_qualified,
)
from flexhrc.representation.online import (
    Event,
    GraphArgumentError,
    InfeasibleUpdateError,
    OnlineGraph,
    QueryResult,
    Suggestion,
)

__all__ = [
    "AndOrGraph",
    "Event",
    "GraphArgumentError",
    "HierarchicalGraph",
    "Hyperarc",
    "InfeasibleUpdateError",
    "Node",
    "OnlineGraph",
    "QueryResult",
    "Suggestion",
    "Transfer",
    "load",
    "qualify",
    "save",
    "split_qualified",
]
