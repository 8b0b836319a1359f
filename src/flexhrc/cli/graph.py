"""``flexhrc graph ...`` — validate, inspect, query, traverse and render AND/OR graphs.

Every command reads the graph with :func:`flexhrc.scenario.graph_of` and prints a report of
:mod:`flexhrc.representation.reports` (``play``: :func:`flexhrc.representation.play.play`).
"""

from __future__ import annotations

import argparse
import gc
import sys
from typing import Any

from flexhrc.cli.common import add_json_flag, add_seed_option, emit, int_range
from flexhrc.taskmanager.replay import plural

MAX_PATH_LIMIT = 100_000_000
MAX_SEED = 2**63 - 1

GRAPH_FILE_HELP = (
    "graph file: ANDOR text (.txt, the FlexHRC+ authors' format) or flexhrc YAML (.yaml); "
    "lower graphs are looked up in its folder; or a scenario file (flexhrc: 1): its graph"
)
NAME_HELP = (
    "names inside a lower-graph instance are qualified by the instance path from the top "
    "graph: 'h4/h3/Node'"
)


def _graph_command(gsub: Any, name: str, func: Any, **kwargs: Any) -> argparse.ArgumentParser:
    """A sub-command that reads one graph (FILE) and prints a report (``--json``)."""
    p: argparse.ArgumentParser = gsub.add_parser(name, **kwargs)
    p.add_argument("file", help=GRAPH_FILE_HELP)
    add_json_flag(p)
    p.set_defaults(func=func)
    return p


def _add_path_limit(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument(
        "--path-limit",
        type=int_range(1, MAX_PATH_LIMIT),
        default=None,
        metavar="N",
        help=f"with {what} per graph instance (default 100000)",
    )


def _add_statuses(p: argparse.ArgumentParser, met_help: str, solved_help: str) -> None:
    for option, help_ in (("--met", met_help), ("--solved", solved_help)):
        p.add_argument(option, action="append", default=[], metavar="NAME", help=help_)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "graph",
        help="hierarchical AND/OR graphs: validate, stats, suggest, play, render",
        description="Work with hierarchical first-order AND/OR graph files (ANDOR text or YAML).",
    )
    gsub = p.add_subparsers(dest="graph_command", metavar="SUBCOMMAND", required=True)

    _graph_command(
        gsub,
        "validate",
        cmd_validate,
        help="check a graph file and every lower graph it uses",
        description="Check the structure (errors: file:line, exit 2) and warn about oddities: "
        "a root that is a leaf, nodes on no hyper-arc, dead ends, nodes shared between the "
        "children of one hyper-arc (costs then differ from the paper's path definition), a "
        "graph that can never be solved.",
    )

    s = _graph_command(
        gsub, "stats", cmd_stats, help="counts: graphs, layers, nodes, hyper-arcs, instances"
    )
    s.add_argument(
        "--paths",
        action="store_true",
        help="also count cooperation paths by enumerating them (exponential: small graphs only)",
    )
    _add_path_limit(s, "--paths: give up past N paths")

    q = _graph_command(
        gsub,
        "suggest",
        cmd_suggest,
        help="feasible elements and their costs after reporting met nodes / solved hyper-arcs",
        description="Names inside a lower-graph instance are qualified by the instance path "
        "from the top graph: 'h4/h3/Node' is Node in the instance created by hyper-arc h3 "
        "inside the instance of top-level hyper-arc h4; a bare name is in the top graph.",
    )
    _add_statuses(q, f"a met node ({NAME_HELP})", "a solved hyper-arc")
    q.add_argument(
        "--infeasible",
        action="append",
        default=[],
        metavar="NAME",
        help="an element to mark infeasible (for good)",
    )
    q.add_argument(
        "--exact",
        action="store_true",
        help="costs by enumerating cooperation paths (exponential; reference mode)",
    )
    _add_path_limit(q, "--exact: give up past N cooperation paths")

    pl = _graph_command(
        gsub,
        "play",
        cmd_play,
        help="traverse the graph to the end with a policy, timed",
        description="The FlexHRC+ authors' test client: query 1 reports nothing, every later "
        "query reports one element of the previous answer. Offline = load + build; online = "
        "the queries (medians). Exit 0 when solved, 1 when failed.",
    )
    pl.add_argument(
        "--policy",
        choices=["cheapest", "random"],
        default="cheapest",
        help="which feasible element to report: the cheapest (default) or one at random",
    )
    add_seed_option(pl, "random seed (default 0)")
    pl.add_argument(
        "--steps", action="store_true", help="list every reported element with its query number"
    )
    pl.add_argument(
        "--events",
        metavar="FILE",
        help="stream the event history to FILE (JSON lines, one per event, flushed as it "
        "goes; the same query numbers as --steps)",
    )

    r = _graph_command(
        gsub,
        "render",
        cmd_render,
        help="draw the graph (.dot, or .svg/.png/.pdf through graphviz), with a colour legend",
    )
    r.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="output file: .dot/.gv (DOT text) or .svg/.png/.pdf (needs graphviz's dot)",
    )
    _add_statuses(
        r,
        "show this node as met (colours the top graph; repeat for several)",
        "show this hyper-arc as solved (repeat for several)",
    )
    r.add_argument(
        "--no-legend", action="store_true", help="leave out the legend of shapes and colours"
    )

    from flexhrc.cli.behave import register_graph_to_task  # THEN/AND/OR tasks (branch behavior)

    register_graph_to_task(gsub)


def cmd_validate(args: argparse.Namespace) -> int:
    from flexhrc.representation.reports import validation
    from flexhrc.scenario import graph_of

    report = validation(graph_of(args.file), args.file)
    messages = report["warnings"]
    for m in messages:
        print(f"warning: {m}", file=sys.stderr)
    emit(
        args,
        report,
        f"{args.file}: valid ({plural(report['graphs'], 'graph definition')}, "
        f"{plural(report['layers'], 'layer')}, {plural(report['instantiated_nodes'], 'node')} "
        f"and {plural(report['instantiated_hyperarcs'], 'hyper-arc')} instantiated)"
        + ("" if report["solvable"] else "; it can never be solved")
        + (f"; {plural(len(messages), 'warning')}" if messages else ""),
    )
    return 0


def cmd_stats(args: argparse.Namespace) -> int:
    from flexhrc.errors import FlexhrcError
    from flexhrc.representation.paths import DEFAULT_LIMIT
    from flexhrc.representation.reports import statistics
    from flexhrc.scenario import graph_of

    if args.path_limit is not None and not args.paths:
        raise FlexhrcError("--path-limit needs --paths")
    st = statistics(
        graph_of(args.file), paths=args.paths, path_limit=args.path_limit or DEFAULT_LIMIT
    )

    def text() -> str:
        rows = [
            ("graph definitions", st["graphs"]),
            ("layers", st["layers"]),
            ("nodes (designed)", st["nodes"]),
            ("hyper-arcs (designed)", st["hyperarcs"]),
            ("graph instances", st["instances"]),
            ("nodes (instantiated)", st["instantiated_nodes"]),
            ("hyper-arcs (instantiated)", st["instantiated_hyperarcs"]),
            ("optimal cost", st["optimal_cost"]),
        ]
        width = max(len(r[0]) for r in rows)
        out = [f"{args.file}"] + [f"  {k:<{width}}  {v}" for k, v in rows]
        if "paths" in st:
            out.append(f"  {'cooperation paths':<{width}}  {sum(st['paths'].values())}")
        return "\n".join(out)

    emit(args, st, text)
    return 0


def cmd_suggest(args: argparse.Namespace) -> int:
    from flexhrc.errors import FlexhrcError
    from flexhrc.representation.paths import DEFAULT_LIMIT
    from flexhrc.representation.reports import suggestions
    from flexhrc.scenario import graph_of

    if args.path_limit is not None and not args.exact:
        raise FlexhrcError("--path-limit needs --exact (it limits the path enumeration)")
    result, rows = suggestions(
        graph_of(args.file),
        met=args.met,
        solved=args.solved,
        infeasible=args.infeasible,
        exact=args.exact,
        path_limit=args.path_limit or DEFAULT_LIMIT,
    )

    def text() -> str:
        if result.solved:
            return "solved: the root is met"
        if result.failed:
            return f"failed: {result.reason}"
        width = max((len(r["element"]) for r in rows), default=7)
        out = [f"{'element':<{width}}  {'kind':<8}  {'cost':>6}  graph"]
        for r in rows:
            graph = r["graph"] or "(top)"
            out.append(f"{r['element']:<{width}}  {r['kind']:<8}  {r['cost']!s:>6}  {graph}")
        return "\n".join(out)

    if args.json and result.outcome != "running":
        # solved/failed: no feasible element; the list is empty, stderr says why
        print(f"{result.outcome}: {result.reason or 'the root is met'}", file=sys.stderr)
        rows = []
    emit(args, rows, text)
    return 0


def _sources(hierarchy: Any) -> list[str]:
    return [g.source for g in hierarchy.graphs.values() if g.source]


def cmd_play(args: argparse.Namespace) -> int:
    from flexhrc.files import EventLogWriter, check_output
    from flexhrc.representation.play import play
    from flexhrc.representation.reports import number
    from flexhrc.scenario import graph_of, is_scenario_file

    writer: EventLogWriter | None = None
    if args.events is not None:  # "" too: check_output says it is empty
        # before the work: never an input, never a folder or a device, its folder exists
        check_output(args.events, option="--events", inputs=[args.file])

    def opened(hierarchy: Any) -> None:
        nonlocal writer
        if args.events is not None:
            # the lower graphs are known now (outside the timed offline phase)
            check_output(args.events, option="--events", inputs=_sources(hierarchy))
            writer = EventLogWriter(args.events, option="--events")

    def event(ev: dict[str, Any]) -> None:
        assert writer is not None
        writer.write(ev)

    # The objects of start-up (every imported module, the argument parser) are moved out of the
    # garbage collector's sight, so its passes during the timed phases scan what the graph
    # created, not what the process did before (the C++ reference has no collector at all).
    gc.collect()
    gc.freeze()
    try:
        report = play(
            # a scenario's graph is read first (not timed); a graph file in the offline phase
            graph_of(args.file) if is_scenario_file(args.file) else args.file,
            args.policy,
            args.seed,
            record_steps=args.steps,
            on_offline=opened,
            on_event=event if args.events is not None else None,
        )
    finally:
        if writer is not None:
            writer.close()
    data = report.to_dict()
    if not args.steps:
        data.pop("steps", None)

    def text() -> str:
        out = []
        for st in report.steps:
            out.append(f"  query {st['query']:>4}: {st['element']}  (cost {number(st['cost'])})")
        out.append(
            f"{report.outcome} after {plural(report.queries, 'query', 'queries')}, cost "
            f"{number(report.cost)}; offline {report.offline_s * 1e3:.2f} ms, online "
            f"{report.online_s_total * 1e3:.2f} ms "
            f"({report.online_s_per_query_median * 1e6:.1f} µs per query, median)"
        )
        if report.reason:
            out.append(f"reason: {report.reason}")
        if args.events:
            out.append(f"events: {args.events}")
        return "\n".join(out)

    emit(args, data, text)
    return 0 if report.outcome == "solved" else 1


def cmd_render(args: argparse.Namespace) -> int:
    from flexhrc.files import check_output
    from flexhrc.representation.reports import RENDER_SUFFIXES, render_graph
    from flexhrc.scenario import graph_of

    # before the work: never the file read
    check_output(args.output, option="-o", suffixes=RENDER_SUFFIXES, inputs=[args.file])
    report = render_graph(
        graph_of(args.file),
        args.output,
        file=args.file,
        met=args.met,
        solved=args.solved,
        legend=not args.no_legend,
    )
    emit(args, report, f"wrote {report['output']}")
    return 0
