"""``flexhrc graph ...`` — validate, inspect, query, traverse and render AND/OR graphs."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from flexhrc.cli.common import add_json_flag, emit


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "graph",
        help="hierarchical AND/OR graphs: validate, stats, suggest, play, render",
        description="Work with hierarchical first-order AND/OR graph files (ANDOR text or YAML).",
    )
    gsub = p.add_subparsers(dest="graph_command", metavar="SUBCOMMAND", required=True)

    v = gsub.add_parser("validate", help="check a graph file and every lower graph it uses")
    v.add_argument("file")
    add_json_flag(v)
    v.set_defaults(func=cmd_validate)

    s = gsub.add_parser("stats", help="counts: graphs, layers, nodes, hyper-arcs, instances")
    s.add_argument("file")
    s.add_argument("--paths", action="store_true", help="also count cooperation paths (slow)")
    add_json_flag(s)
    s.set_defaults(func=cmd_stats)

    q = gsub.add_parser(
        "suggest",
        help="feasible elements and their costs after reporting met nodes / solved hyper-arcs",
        description="Names inside a lower-graph instance are qualified by the instance path "
        "from the top graph: 'h4/h3/Node' is Node in the instance created by hyper-arc h3 "
        "inside the instance of top-level hyper-arc h4; a bare name is in the top graph.",
    )
    q.add_argument("file")
    q.add_argument("--met", action="append", default=[], metavar="NAME", help="a met node")
    q.add_argument(
        "--solved", action="append", default=[], metavar="NAME", help="a solved hyper-arc"
    )
    q.add_argument(
        "--infeasible", action="append", default=[], metavar="NAME", help="mark infeasible"
    )
    q.add_argument(
        "--exact",
        action="store_true",
        help="costs by enumerating cooperation paths (exponential; reference mode)",
    )
    q.add_argument("--path-limit", type=int, default=100_000, help="limit for --exact")
    add_json_flag(q)
    q.set_defaults(func=cmd_suggest)

    pl = gsub.add_parser("play", help="traverse the graph to the end with a policy, timed")
    pl.add_argument("file")
    pl.add_argument("--policy", choices=["cheapest", "random"], default="cheapest")
    pl.add_argument("--seed", type=int, default=0)
    pl.add_argument("--steps", action="store_true", help="list every reported element")
    pl.add_argument("--events", metavar="FILE", help="save the event history (JSON lines)")
    add_json_flag(pl)
    pl.set_defaults(func=cmd_play)

    r = gsub.add_parser("render", help="draw the graph (.dot, or .svg/.png through graphviz)")
    r.add_argument("file")
    r.add_argument("-o", "--output", required=True, metavar="OUT")
    r.add_argument("--met", action="append", default=[], metavar="NAME")
    r.add_argument("--solved", action="append", default=[], metavar="NAME")
    r.set_defaults(func=cmd_render)

    from flexhrc.cli.behave import register_graph_to_task  # THEN/AND/OR tasks (branch behavior)

    register_graph_to_task(gsub)


def cmd_validate(args: argparse.Namespace) -> int:
    from flexhrc.representation import load

    h = load(args.file)
    st = h.stats()
    for w in h.warnings:
        print(f"warning: {w}", file=sys.stderr)
    emit(
        args,
        {"file": args.file, "valid": True, "warnings": [str(w) for w in h.warnings], **st},
        f"{args.file}: valid ({st['graphs']} graph definitions, {st['layers']} layers, "
        f"{st['instantiated_nodes']} nodes and {st['instantiated_hyperarcs']} hyper-arcs "
        "instantiated)",
    )
    return 0


def cmd_stats(args: argparse.Namespace) -> int:
    from flexhrc.representation import OnlineGraph, load

    h = load(args.file)
    st: dict[str, Any] = h.stats()
    online = OnlineGraph(h, validate=False)
    st["optimal_cost"] = _num(online.optimal_cost())
    if args.paths:
        from flexhrc.representation.paths import count_paths

        st["paths"] = count_paths(online)

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
    from flexhrc.representation import OnlineGraph, load

    online = OnlineGraph(load(args.file), validate=False)
    result = online.update(
        met_nodes=args.met, solved_hyperarcs=args.solved, infeasible=args.infeasible
    )
    if args.exact:
        from flexhrc.representation.paths import exact_costs

        costs = exact_costs(online, args.path_limit)
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
    import sys

    print(f"{result.outcome}: {result.reason or 'the root is met'}", file=sys.stderr)
    return []


def cmd_play(args: argparse.Namespace) -> int:
    from flexhrc.representation.play import play

    report = play(args.file, args.policy, args.seed, record_steps=args.steps or bool(args.events))
    if args.events:
        import json

        with open(args.events, "w", encoding="utf-8") as fh:
            for ev in report.events:
                fh.write(json.dumps(ev) + "\n")
    data = report.to_dict()
    if not args.steps:
        data.pop("steps", None)

    def text() -> str:
        out = []
        for st in report.steps:
            out.append(f"  query {st['query']:>4}: {st['element']}  (cost {_num(st['cost'])})")
        out.append(
            f"{report.outcome} after {report.queries} queries, cost {_num(report.cost)}; "
            f"offline {report.offline_s * 1e3:.2f} ms, online {report.online_s_total * 1e3:.2f} ms "
            f"({report.online_s_per_query_median * 1e6:.1f} µs per query, median)"
        )
        if report.reason:
            out.append(f"reason: {report.reason}")
        return "\n".join(out)

    emit(args, data, text)
    return 0 if report.outcome == "solved" else 1


def cmd_render(args: argparse.Namespace) -> int:
    from flexhrc.representation import OnlineGraph, load
    from flexhrc.representation.formats.dot import render, to_dot

    h = load(args.file)
    online = None
    if args.met or args.solved:
        online = OnlineGraph(h, validate=False)
        online.update(met_nodes=args.met, solved_hyperarcs=args.solved)
    out = render(to_dot(h, online), args.output)
    print(f"wrote {out}")
    return 0


def _num(x: float) -> float | int | None:
    if x == float("inf"):
        return None
    return int(x) if float(x).is_integer() else x
