"""Drive the online phase to the end, like the FlexHRC+ authors' random test client.

Query 0 reports nothing. Every later query reports one element taken from the previous answer's
feasible nodes and hyper-arcs (any layer): a node is met, a hyper-arc is solved. ``random``
picks uniformly (seeded); ``cheapest`` picks the lowest cost (ties: definition order). The run
ends when the graph is solved or has failed.
"""

from __future__ import annotations

import random
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.representation.graph import plain_number
from flexhrc.representation.hierarchy import HierarchicalGraph
from flexhrc.representation.online import OnlineGraph

POLICIES = ("cheapest", "random")


@dataclass
class PlayReport:
    outcome: str
    queries: int
    offline_s: float
    online_s_total: float
    online_s_per_query_median: float
    cost: float
    reason: str | None = None
    steps: list[dict[str, Any]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list, repr=False)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "outcome": self.outcome,
            "queries": self.queries,
            "offline_s": self.offline_s,
            "online_s_total": self.online_s_total,
            "online_s_per_query_median": self.online_s_per_query_median,
            "cost": plain_number(self.cost),
        }
        if self.reason:
            d["reason"] = self.reason
        if self.steps:
            d["steps"] = self.steps
        return d


def play(
    source: str | Path | HierarchicalGraph,
    policy: str = "cheapest",
    seed: int = 0,
    *,
    record_steps: bool = False,
    max_queries: int = 1_000_000,
    clock: Callable[[], float] = time.perf_counter,
    on_offline: Callable[[HierarchicalGraph], None] | None = None,
    on_event: Callable[[dict[str, Any]], None] | None = None,
) -> PlayReport:
    """Load (offline phase) and traverse (online phase) a graph; time both.

    ``on_offline(hierarchy)`` is called once the graph is loaded, ``on_event(event)`` after
    every query for each event it recorded (``{"query", "type", "element"}``, the numbering of
    :attr:`OnlineGraph.events`) — both outside the timed parts, e.g. to stream a log.
    Step numbers (``record_steps``) are the same query numbers.
    """
    if policy not in POLICIES:
        raise FlexhrcError(f"unknown policy {policy!r}; choose one of {', '.join(POLICIES)}")
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise FlexhrcError(f"seed must be an integer, got {seed!r}")
    if isinstance(max_queries, bool) or not isinstance(max_queries, int) or max_queries < 1:
        raise FlexhrcError(f"max_queries must be a positive integer, got {max_queries!r}")
    from flexhrc.representation.formats import load, reader_for

    if not isinstance(source, HierarchicalGraph):
        # the reader's code is loaded before the clock starts, as the C++ binary's is at
        # process start-up: offline time is the work of loading the graph, not of Python
        # compiling a module (which it does on every run under PYTHONDONTWRITEBYTECODE)
        reader_for(source)
    t0 = clock()
    hierarchy = source if isinstance(source, HierarchicalGraph) else load(source)
    online = OnlineGraph(hierarchy, validate=isinstance(source, HierarchicalGraph))
    offline = clock() - t0
    if on_offline is not None:
        on_offline(hierarchy)

    rng = random.Random(seed)
    kinds = online._kind
    weights = online._w
    times: list[float] = []
    steps: list[dict[str, Any]] = []
    cost = 0.0
    t = clock()
    answer = online.update()
    times.append(clock() - t)
    log = online._log
    n_logged = 0
    while answer.outcome == "running":
        if len(times) >= max_queries:
            raise FlexhrcError(f"no end after {max_queries} queries")
        ids = answer.element_ids
        if policy == "random":
            e = rng.choice(sorted(ids))
        else:
            e = min(ids.items(), key=lambda ec: (ec[1], ec[0]))[0]
        cost += weights[e]
        name = online._names[e]
        if record_steps:
            steps.append(
                {
                    "query": online.queries + 1,  # the query that reports it, as in events
                    "element": name,
                    "kind": "hyperarc" if kinds[e] else "node",
                    "cost": ids[e],
                }
            )
        t = clock()
        if kinds[e]:
            answer = online.update(solved_hyperarcs=(name,))
        else:
            answer = online.update(met_nodes=(name,))
        times.append(clock() - t)
        if on_event is not None:
            names = online._names
            for q, typ, x in log[n_logged:]:
                on_event({"query": q, "type": typ, "element": names[x]})
            n_logged = len(log)
    return PlayReport(
        outcome=answer.outcome,
        queries=len(times),
        offline_s=offline,
        online_s_total=sum(times),
        online_s_per_query_median=statistics.median(times),
        cost=cost,
        reason=answer.reason,
        steps=steps,
        events=[ev.to_dict() for ev in online.events] if record_steps else [],
    )
