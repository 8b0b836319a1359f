"""``flexhrc graph ...`` — validate, inspect, query, traverse and render AND/OR graphs."""

from __future__ import annotations

import argparse
import gc
import sys
from typing import Any

from flexhrc.cli.common import add_json_flag, emit

RENDER_SUFFIXES = (".dot", ".gv", ".svg", ".png", ".pdf")
MAX_PATH_LIMIT = 100_000_000
MAX_SEED = 2**63 - 1


def _seed(value: str) -> int:
    try:
        n = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {value!r}") from None
    if not 0 <= n <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be in 0..2**63-1, got {n}")
    return n


def _path_limit(value: str) -> int:
    try:
        n = int(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {value!r}") from None
    if not 1 <= n <= MAX_PATH_LIMIT:
        raise argparse.ArgumentTypeError(f"must be in 1..{MAX_PATH_LIMIT:_}, got {n}")
    return n


GRAPH_FILE_HELP = (
    "graph file: ANDOR text (.txt, the FlexHRC+ authors' format) or flexhrc YAML (.yaml); "
    "lower graphs are looked up in its folder; or a scenario file (flexhrc: 1): its graph"
)
NAME_HELP = (
    "names inside a lower-graph instance are qualified by the instance path from the top "
    "graph: 'h4/h3/Node'"
)


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "graph",
        help="hierarchical AND/OR graphs: validate, stats, suggest, play, render",
        description="Work with hierarchical first-order AND/OR graph files (ANDOR text or YAML).",
    )
    gsub = p.add_subparsers(dest="graph_command", metavar="SUBCOMMAND", required=True)

    v = gsub.add_parser(
        "validate",
        help="check a graph file and every lower graph it uses",
        description="Check the structure (errors: file:line, exit 2) and warn about oddities: "
        "a root that is a leaf, nodes on no hyper-arc, dead ends, nodes shared between the "
        "children of one hyper-arc (costs then differ from the paper's path definition), a "
        "graph that can never be solved.",
    )
    v.add_argument("file", help=GRAPH_FILE_HELP)
    add_json_flag(v)
    v.set_defaults(func=cmd_validate)

    s = gsub.add_parser("stats", help="counts: graphs, layers, nodes, hyper-arcs, instances")
    s.add_argument("file", help=GRAPH_FILE_HELP)
    s.add_argument(
        "--paths",
        action="store_true",
        help="also count cooperation paths by enumerating them (exponential: small graphs only)",
    )
    s.add_argument(
        "--path-limit",
        type=_path_limit,
        default=None,
        metavar="N",
        help="with --paths: give up past N paths per graph instance (default 100000)",
    )
    add_json_flag(s)
    s.set_defaults(func=cmd_stats)

    q = gsub.add_parser(
        "suggest",
        help="feasible elements and their costs after reporting met nodes / solved hyper-arcs",
        description="Names inside a lower-graph instance are qualified by the instance path "
        "from the top graph: 'h4/h3/Node' is Node in the instance created by hyper-arc h3 "
        "inside the instance of top-level hyper-arc h4; a bare name is in the top graph.",
    )
    q.add_argument("file", help=GRAPH_FILE_HELP)
    q.add_argument(
        "--met", action="append", default=[], metavar="NAME", help=f"a met node ({NAME_HELP})"
    )
    q.add_argument(
        "--solved", action="append", default=[], metavar="NAME", help="a solved hyper-arc"
    )
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
    q.add_argument(
        "--path-limit",
        type=_path_limit,
        default=None,
        metavar="N",
        help="with --exact: give up past N cooperation paths per graph instance (default 100000)",
    )
    add_json_flag(q)
    q.set_defaults(func=cmd_suggest)

    pl = gsub.add_parser(
        "play",
        help="traverse the graph to the end with a policy, timed",
        description="The FlexHRC+ authors' test client: query 1 reports nothing, every later "
        "query reports one element of the previous answer. Offline = load + build; online = "
        "the queries (medians). Exit 0 when solved, 1 when failed.",
    )
    pl.add_argument("file", help=GRAPH_FILE_HELP)
    pl.add_argument(
        "--policy",
        choices=["cheapest", "random"],
        default="cheapest",
        help="which feasible element to report: the cheapest (default) or one at random",
    )
    pl.add_argument(
        "--seed", type=_seed, default=0, metavar="N", help="random seed (0..2**63-1, default 0)"
    )
    pl.add_argument(
        "--steps", action="store_true", help="list every reported element with its query number"
    )
    pl.add_argument(
        "--events",
        metavar="FILE",
        help="stream the event history to FILE (JSON lines, one per event, flushed as it "
        "goes; the same query numbers as --steps)",
    )
    add_json_flag(pl)
    pl.set_defaults(func=cmd_play)

    r = gsub.add_parser(
        "render",
        help="draw the graph (.dot, or .svg/.png/.pdf through graphviz), with a colour legend",
    )
    r.add_argument("file", help=GRAPH_FILE_HELP)
    r.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="OUT",
        help="output file: .dot/.gv (DOT text) or .svg/.png/.pdf (needs graphviz's dot)",
    )
    r.add_argument(
        "--met",
        action="append",
        default=[],
        metavar="NAME",
        help="show this node as met (colours the top graph; repeat for several)",
    )
    r.add_argument(
        "--solved",
        action="append",
        default=[],
        metavar="NAME",
        help="show this hyper-arc as solved (repeat for several)",
    )
    r.add_argument(
        "--no-legend", action="store_true", help="leave out the legend of shapes and colours"
    )
    add_json_flag(r)
    r.set_defaults(func=cmd_render)

    from flexhrc.cli.behave import register_graph_to_task  # THEN/AND/OR tasks (branch behavior)

    register_graph_to_task(gsub)


def _plural(n: Any, one: str, many: str | None = None) -> str:
    return f"{n} {one if n == 1 else (many or one + 's')}"


def cmd_validate(args: argparse.Namespace) -> int:
    from flexhrc.representation import OnlineGraph
    from flexhrc.scenario import graph_of

    h = graph_of(args.file)
    st = h.stats()
    warnings = [*h.warnings, *h.lint()]
    answer = OnlineGraph(h, validate=False).query()
    solvable = answer.outcome != "failed"
    messages = [str(w) for w in warnings]
    if not solvable:
        messages.append(f"{args.file}: the graph can never be solved: {answer.reason}")
    for m in messages:
        print(f"warning: {m}", file=sys.stderr)
    emit(
        args,
        {"file": args.file, "valid": True, "solvable": solvable, "warnings": messages, **st},
        f"{args.file}: valid ({_plural(st['graphs'], 'graph definition')}, "
        f"{_plural(st['layers'], 'layer')}, {_plural(st['instantiated_nodes'], 'node')} and "
        f"{_plural(st['instantiated_hyperarcs'], 'hyper-arc')} instantiated)"
        + ("" if solvable else "; it can never be solved")
        + (f"; {_plural(len(messages), 'warning')}" if messages else ""),
    )
    return 0


def cmd_stats(args: argparse.Namespace) -> int:
    from flexhrc.errors import FlexhrcError
    from flexhrc.representation import OnlineGraph
    from flexhrc.scenario import graph_of

    if args.path_limit is not None and not args.paths:
        raise FlexhrcError("--path-limit needs --paths")
    h = graph_of(args.file)
    st: dict[str, Any] = h.stats()
    online = OnlineGraph(h, validate=False)
    st["optimal_cost"] = _num(online.optimal_cost())
    if args.paths:
        from flexhrc.representation.paths import DEFAULT_LIMIT, count_paths

        st["paths"] = count_paths(online, args.path_limit or DEFAULT_LIMIT)

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
    from flexhrc.representation import OnlineGraph
    from flexhrc.scenario import graph_of

    if args.path_limit is not None and not args.exact:
        raise FlexhrcError("--path-limit needs --exact (it limits the path enumeration)")
    online = OnlineGraph(graph_of(args.file), validate=False)
    result = online.update(
        met_nodes=args.met, solved_hyperarcs=args.solved, infeasible=args.infeasible
    )
    if args.exact:
        from flexhrc.representation.paths import DEFAULT_LIMIT, exact_costs

        costs = exact_costs(online, args.path_limit or DEFAULT_LIMIT)
        rows: list[dict[str, Any]] = [
            {
                "element": name,
                "kind": online.kind(name),
                "cost": _num(c),
                "graph": online.graph_of(name),
            }
            for name, c in costs.items()
        ]
        rows.sort(key=lambda r: (r["cost"], online.element_id(r["element"])))
    else:
        rows = [
            {k: v for k, v in s.to_dict().items() if k != "graph_name"} for s in result.suggestions
        ]

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

    if args.json:
        emit(args, rows if result.outcome == "running" else _outcome_rows(result))
    else:
        emit(args, rows, text)
    return 0


def _outcome_rows(result: Any) -> list[dict[str, Any]]:
    # solved/failed: no feasible element; the list is empty, stderr says why
    print(f"{result.outcome}: {result.reason or 'the root is met'}", file=sys.stderr)
    return []


def _sources(hierarchy: Any) -> list[str]:
    return [g.source for g in hierarchy.graphs.values() if g.source]


def cmd_play(args: argparse.Namespace) -> int:
    from flexhrc.files import EventLogWriter, check_output
    from flexhrc.representation.play import play
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
            out.append(f"  query {st['query']:>4}: {st['element']}  (cost {_num(st['cost'])})")
        out.append(
            f"{report.outcome} after {_plural(report.queries, 'query', 'queries')}, cost "
            f"{_num(report.cost)}; offline {report.offline_s * 1e3:.2f} ms, online "
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
    from flexhrc.representation import OnlineGraph
    from flexhrc.representation.formats.dot import render, to_dot
    from flexhrc.scenario import graph_of

    check_output(args.output, option="-o", suffixes=RENDER_SUFFIXES, inputs=[args.file])
    h = graph_of(args.file)
    check_output(args.output, option="-o", suffixes=RENDER_SUFFIXES, inputs=_sources(h))
    online = None
    if args.met or args.solved:
        online = OnlineGraph(h, validate=False)
        online.update(met_nodes=args.met, solved_hyperarcs=args.solved)
    out = render(to_dot(h, online, legend=not args.no_legend), args.output)
    st = h.stats()
    emit(
        args,
        {
            "file": args.file,
            "output": str(out),
            "format": out.suffix.lower().lstrip("."),
            "legend": not args.no_legend,
            "statuses": online is not None,
            "graphs": st["graphs"],
            "nodes": st["nodes"],
            "hyperarcs": st["hyperarcs"],
        },
        f"wrote {out}",
    )
    return 0


def _num(x: float) -> float | int | None:
    if x == float("inf"):
        return None
    return int(x) if float(x).is_integer() else x
