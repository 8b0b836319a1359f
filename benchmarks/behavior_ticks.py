"""Benchmark: update-loop ticks per second of behaviour networks of 100, 1 000 and 10 000 nodes.

One *tick* is a full update of the network (paper 002, Algorithm 1 for every node, every arm
mutex, the world step and the delivery of all messages of the tick over the in-process bus).

Networks are complete trees with branching factor 5 (root AND, inner nodes THEN/AND/OR drawn with
a seeded RNG, leaves PickAndPlace behaviours in a generated world). The timed ticks are taken
after a warm-up, while activation is spreading and behaviours are bidding and running; the
median of the per-tick wall times is reported (with the p90, mean and max: with latched messages
most ticks change little, and the ticks in which a mutex is granted or a behaviour starts or ends
cost more). Target: one tick of 10 000 nodes <= 5 ms.

Three modes are measured: *event-driven* (the default executor: latched messages — held
activation, standing mutex bids — and quiescent nodes skipped until a message or a sensing change
wakes them), *per-tick msgs* (event-driven, but the paper's literal protocol: activation re-sent
and bids re-sent every tick) and *every node* (all update loops run each tick, per-tick messages
— the same results, the worst case).

Usage::

    python3 benchmarks/behavior_ticks.py [--ticks 60] [--warmup 30] [--json]
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc.behavior import BehaviorNetwork, NetworkParams, build_task, random_world

SIZES = (100, 1_000, 10_000)
BRANCHING = 5
TARGET_MS = 5.0
MODES = {
    "event-driven": (True, True),
    "per-tick msgs": (True, False),
    "every node": (False, False),
}


def tree_spec(n: int, seed: int = 0) -> tuple:
    """A complete ``BRANCHING``-ary tree of exactly ``n`` nodes as a parser spec."""
    rng = random.Random(seed)
    kinds = ["AND"] + [rng.choice(("THEN", "AND", "OR")) for _ in range(1, n)]

    def make(i: int) -> tuple:
        first = BRANCHING * i + 1
        children = [c for c in range(first, first + BRANCHING) if c < n]
        if not children:
            return ("BEHAVIOR", f"b{i}", None, None)
        return (kinds[i], [make(c) for c in children], None, None)

    return make(0)


def bench(n: int, ticks: int, warmup: int, mode: str, arms: int = 2) -> dict[str, float | str]:
    event_driven, latched = MODES[mode]
    task = build_task(tree_spec(n), f"<bench {n}>")
    world = random_world(task.behaviors, seed=1, arms=arms)
    net = BehaviorNetwork(
        task, world, NetworkParams(seed=1, latched=latched), event_driven=event_driven
    )
    for _ in range(warmup):
        net.tick()
    times = []
    for _ in range(ticks):
        t0 = time.perf_counter()
        net.tick()
        times.append(time.perf_counter() - t0)
    median = statistics.median(times)
    return {
        "mode": mode,
        "nodes": task.size,
        "behaviours": len(task.behaviors),
        "median_ms": round(median * 1e3, 4),
        "p90_ms": round(sorted(times)[int(0.9 * (len(times) - 1))] * 1e3, 4),
        "mean_ms": round(statistics.fmean(times) * 1e3, 4),
        "max_ms": round(max(times) * 1e3, 4),
        "ticks_per_s": round(1.0 / median, 1),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=200)
    ap.add_argument("--warmup", type=int, default=30)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rows = [bench(n, args.ticks, args.warmup, mode) for mode in MODES for n in SIZES]
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(
        f"{'mode':>13} {'nodes':>7} {'behaviours':>10} {'median ms/tick':>15}"
        f" {'p90 ms':>8} {'mean ms':>8} {'max ms':>8} {'ticks/s':>9}"
    )
    for r in rows:
        print(
            f"{r['mode']:>13} {r['nodes']:>7} {r['behaviours']:>10} {r['median_ms']:>15.3f}"
            f" {r['p90_ms']:>8.3f} {r['mean_ms']:>8.3f} {r['max_ms']:>8.3f}"
            f" {r['ticks_per_s']:>9.1f}"
        )
    big = rows[len(SIZES) - 1]
    verdict = "met" if float(big["median_ms"]) <= TARGET_MS else "NOT met"
    print(
        f"target: one tick of {big['nodes']} nodes <= {TARGET_MS:.0f} ms — {verdict}"
        f" ({big['median_ms']:.2f} ms, event-driven)"
    )


if __name__ == "__main__":
    main()
