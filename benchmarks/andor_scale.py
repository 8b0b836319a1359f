"""The AND/OR graph engine at scale (issue 9, item 5).

* a 10 000-node random AND/OR tree (1-2 alternatives per node, 1-3 children per hyper-arc,
  weights 1-9) played to the end by the random test client: per-query median (target <= 1 ms),
  90th percentile and maximum, over 3 seeds;
* a 10 000-node chain (review case A13): build, first answer, then 200 queries;
* a chain played to the end (probe case R12, ``--chain-play``, default 10 000 nodes): whole
  play and per-query median: a query must pay neither for the done part below it nor for the
  chain above it (quadratic before: 25 s for 10 000 nodes);
* the table assembly with 500 legs (review case A2), played to the end (cheapest policy).

Per-query time is the time of ``OnlineGraph.update`` (the answer with every feasible element's
cost included), as in ``flexhrc graph play``; the client's own choice is outside the timer.

    python benchmarks/andor_scale.py [--nodes 10000] [--seeds 3] [--json out/andor_scale.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexhrc.representation import HierarchicalGraph, OnlineGraph  # noqa: E402
from flexhrc.representation.play import play  # noqa: E402
from flexhrc.representation.synthetic import chain, random_tree  # noqa: E402

TARGET_PER_QUERY_S = 1e-3


def percentile(xs: list[float], q: float) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, int(q * len(s)))]


def tree_play(n_nodes: int, seeds: int) -> dict[str, float]:
    g = random_tree(n_nodes, seed=1)
    h = HierarchicalGraph.single(g)
    medians, p90s, maxes, queries, walls = [], [], [], [], []
    for seed in range(1, seeds + 1):
        times: list[float] = []
        clock = time.perf_counter
        t0 = clock()
        report = play(h, "random", seed, clock=_recording(times, clock))
        walls.append(clock() - t0)
        assert report.outcome == "solved", report.outcome
        per_query = _query_times(times)
        medians.append(report.online_s_per_query_median)
        p90s.append(percentile(per_query, 0.9))
        maxes.append(max(per_query))
        queries.append(report.queries)
        print(
            f"  seed {seed}: {report.queries} queries, "
            f"median {report.online_s_per_query_median * 1e3:.3f} ms",
            file=sys.stderr,
            flush=True,
        )
    return {
        "nodes": len(g.nodes),
        "hyperarcs": len(g.hyperarcs),
        "leaves": len(g.leaves()),
        "queries": statistics.median(queries),
        "per_query_median_s": statistics.median(medians),
        "per_query_p90_s": statistics.median(p90s),
        "per_query_max_s": statistics.median(maxes),
        "wall_s": statistics.median(walls),
    }


def _recording(times: list[float], clock):  # type: ignore[no-untyped-def]
    # play() reads the clock twice per query; keep the readings to get every query's time
    def tick() -> float:
        t = clock()
        times.append(t)
        return t

    return tick


def _query_times(ticks: list[float]) -> list[float]:
    # ticks: t0, t_offline_end, then (start, end) per query
    pairs = ticks[2:]
    return [b - a for a, b in zip(pairs[::2], pairs[1::2], strict=False)]


def chain_run(n: int, queries: int = 200) -> dict[str, float]:
    g = chain(n)
    t0 = time.perf_counter()
    online = OnlineGraph(g)
    answer = online.query()
    build = time.perf_counter() - t0
    times = []
    for _ in range(queries):
        e = next(iter(answer.element_ids))
        name = online.element_name(e)
        t = time.perf_counter()
        if online.kind(name) == "node":
            answer = online.update(met_nodes=[name])
        else:
            answer = online.update(solved_hyperarcs=[name])
        times.append(time.perf_counter() - t)
    return {"nodes": n, "offline_s": build, "per_query_median_s": statistics.median(times)}


def chain_play(n: int) -> dict[str, float]:
    h = HierarchicalGraph.single(chain(n))
    t0 = time.perf_counter()
    report = play(h, "cheapest")
    wall = time.perf_counter() - t0
    assert report.outcome == "solved", report.outcome
    return {
        "nodes": n,
        "queries": report.queries,
        "per_query_median_s": report.online_s_per_query_median,
        "wall_s": wall,
    }


def table_run(legs: int) -> dict[str, float]:
    from flexhrc.scenario.builtin.table import build_graph

    t0 = time.perf_counter()
    h = build_graph(legs)
    report = play(h, "cheapest")
    wall = time.perf_counter() - t0
    assert report.outcome == "solved"
    return {
        "legs": legs,
        "queries": report.queries,
        "offline_s": report.offline_s,
        "per_query_median_s": report.online_s_per_query_median,
        "wall_s": wall,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nodes", type=int, default=10_000)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--legs", type=int, default=500)
    ap.add_argument("--chain-play", type=int, default=10_000, metavar="N")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    if args.nodes < 2 or args.seeds < 1 or args.legs < 1 or args.chain_play < 2:
        ap.error("--nodes and --chain-play must be >= 2, --seeds and --legs >= 1")
    print(f"random tree, {args.nodes} nodes ...", file=sys.stderr, flush=True)
    tree = tree_play(args.nodes, args.seeds)
    print(f"chain, {args.nodes} nodes ...", file=sys.stderr, flush=True)
    ch = chain_run(args.nodes)
    print(f"chain played to the end, {args.chain_play} nodes ...", file=sys.stderr, flush=True)
    played = chain_play(args.chain_play)
    print(f"table assembly, {args.legs} legs ...", file=sys.stderr, flush=True)
    table = table_run(args.legs)
    ok = tree["per_query_median_s"] <= TARGET_PER_QUERY_S
    print(
        f"random AND/OR tree: {tree['nodes']} nodes, {tree['hyperarcs']} hyper-arcs, "
        f"{tree['leaves']} leaves; played to the end, {tree['queries']:.0f} queries "
        f"(median of {args.seeds} seeds)"
    )
    print(
        f"  per query: median {tree['per_query_median_s'] * 1e3:.3f} ms "
        f"({'PASS' if ok else 'FAIL'} <= {TARGET_PER_QUERY_S * 1e3:.0f} ms), "
        f"p90 {tree['per_query_p90_s'] * 1e3:.3f} ms, max {tree['per_query_max_s'] * 1e3:.1f} ms; "
        f"whole play {tree['wall_s']:.1f} s wall"
    )
    print(
        f"chain: {ch['nodes']} nodes, build + first answer {ch['offline_s'] * 1e3:.1f} ms, "
        f"per query median {ch['per_query_median_s'] * 1e6:.1f} µs (every query lowers the "
        "inside cost of every node above it)"
    )
    print(
        f"chain played to the end: {played['nodes']} nodes, {played['queries']:.0f} queries, "
        f"per query median {played['per_query_median_s'] * 1e6:.1f} µs, "
        f"{played['wall_s']:.2f} s wall"
    )
    print(
        f"table assembly, {table['legs']} legs: {table['queries']} queries, offline "
        f"{table['offline_s'] * 1e3:.1f} ms, per query median "
        f"{table['per_query_median_s'] * 1e6:.0f} µs, {table['wall_s']:.1f} s wall"
    )
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(
            json.dumps({"tree": tree, "chain": ch, "chain_play": played, "table": table}, indent=2)
        )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
