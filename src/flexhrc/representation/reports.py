"""What ``flexhrc graph validate | stats | suggest | render`` compute, callable from Python.

Each function takes a loaded graph (:func:`flexhrc.representation.load` reads a graph file,
:func:`flexhrc.scenario.graph_of` a graph or a scenario file) and returns the document the
command prints with ``--json``; the command adds nothing but the printing. ``graph play`` is
:func:`flexhrc.representation.play.play`.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from flexhrc.representation.hierarchy import HierarchicalGraph
from flexhrc.representation.online import OnlineGraph, QueryResult
from flexhrc.representation.online import _num as number  # a cost as JSON has it (inf: None)
from flexhrc.representation.paths import DEFAULT_LIMIT

#: the files ``render`` writes: DOT text as is, the others through graphviz's ``dot``
RENDER_SUFFIXES = (".dot", ".gv", ".svg", ".png", ".pdf")


def validation(graph: HierarchicalGraph, file: str | Path) -> dict[str, Any]:
    """The counts of ``graph`` (read from ``file``), whether it can ever be solved, and its
    warnings: the reader's, the lint's (dead ends, shared children, ...) and, when it cannot
    be solved, why. A graph that loads is valid; a fault is an error of the loader."""
    stats = graph.stats()
    warnings = [str(w) for w in [*graph.warnings, *graph.lint()]]
    answer = OnlineGraph(graph, validate=False).query()
    solvable = answer.outcome != "failed"
    if not solvable:
        warnings.append(f"{file}: the graph can never be solved: {answer.reason}")
    return {"file": str(file), "valid": True, "solvable": solvable, "warnings": warnings, **stats}


def statistics(
    graph: HierarchicalGraph, *, paths: bool = False, path_limit: int = DEFAULT_LIMIT
) -> dict[str, Any]:
    """The counts of ``graph``, its optimal cost and, with ``paths``, the number of cooperation
    paths of each graph instance (enumerated: exponential, up to ``path_limit`` each)."""
    stats: dict[str, Any] = graph.stats()
    online = OnlineGraph(graph, validate=False)
    stats["optimal_cost"] = number(online.optimal_cost())
    if paths:
        from flexhrc.representation.paths import count_paths

        stats["paths"] = count_paths(online, path_limit)
    return stats


def suggestions(
    graph: HierarchicalGraph,
    *,
    met: Iterable[str] = (),
    solved: Iterable[str] = (),
    infeasible: Iterable[str] = (),
    exact: bool = False,
    path_limit: int = DEFAULT_LIMIT,
) -> tuple[QueryResult, list[dict[str, Any]]]:
    """The answer after reporting ``met`` nodes, ``solved`` hyper-arcs and ``infeasible``
    elements, with one row (element, kind, cost, graph) per feasible element, cheapest first.
    ``exact`` costs them by enumerating cooperation paths (the reference mode)."""
    online = OnlineGraph(graph, validate=False)
    result = online.update(met_nodes=met, solved_hyperarcs=solved, infeasible=infeasible)
    if not exact:
        rows = [
            {k: v for k, v in s.to_dict().items() if k != "graph_name"} for s in result.suggestions
        ]
        return result, rows
    from flexhrc.representation.paths import exact_costs

    rows = [
        {
            "element": name,
            "kind": online.kind(name),
            "cost": number(c),
            "graph": online.graph_of(name),
        }
        for name, c in exact_costs(online, path_limit).items()
    ]
    rows.sort(key=lambda r: (r["cost"], online.element_id(r["element"])))
    return result, rows


def render_graph(
    graph: HierarchicalGraph,
    output: str | Path,
    *,
    file: str | Path,
    met: Iterable[str] = (),
    solved: Iterable[str] = (),
    legend: bool = True,
) -> dict[str, Any]:
    """Draw ``graph`` (read from ``file``) to ``output`` (a suffix of :data:`RENDER_SUFFIXES`;
    never one of the graph's files), the ``met`` nodes and ``solved`` hyper-arcs coloured."""
    from flexhrc.files import check_output
    from flexhrc.representation.formats.dot import render, to_dot

    sources = [g.source for g in graph.graphs.values() if g.source]
    check_output(output, option="-o", suffixes=RENDER_SUFFIXES, inputs=[file, *sources])
    met, solved = list(met), list(solved)
    online = None
    if met or solved:
        online = OnlineGraph(graph, validate=False)
        online.update(met_nodes=met, solved_hyperarcs=solved)
    out = render(to_dot(graph, online, legend=legend), output)
    stats = graph.stats()
    return {
        "file": str(file),
        "output": str(out),
        "format": out.suffix.lower().lstrip("."),
        "legend": legend,
        "statuses": online is not None,
        "graphs": stats["graphs"],
        "nodes": stats["nodes"],
        "hyperarcs": stats["hyperarcs"],
    }
