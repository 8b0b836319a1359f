"""Benchmark: `flexhrc behave` on one flat AND or THEN of many behaviours (issue 9: an AND of
1000 leaves must finish in <= 10 s; a THEN of 5000 must finish, not stop at max-ticks).

Before the latched protocol, an AND of n leaves cost O(n) per tick (every waiting behaviour
re-bid for the arm every tick, the AND re-sent activation to every child) for O(n) ticks — n²
overall; now a waiting behaviour holds a standing bid and sleeps. Each size is run ``--repeat``
times in this process (the network is built inside the timed region, the Python start-up is
not); the median wall time is reported, with the per-tick protocol for comparison at the
smallest size.

Usage::

    python3 benchmarks/behavior_scale.py [--repeat 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc.behavior import BehaviorNetwork, NetworkParams, check_run, parse_prefix, random_world

CASES = (("AND", 200, False), ("AND", 200, True), ("AND", 1000, True), ("THEN", 5000, True))
TARGET_AND_1000_S = 10.0


def bench(kind: str, n: int, latched: bool, repeat: int) -> dict[str, object]:
    task = parse_prefix(f"({kind} " + " ".join(f"o{i}" for i in range(n)) + ")")
    times = []
    for _ in range(repeat):
        world = random_world(task.behaviors, seed=0)
        t0 = time.perf_counter()
        result = BehaviorNetwork(task, world, NetworkParams(latched=latched)).run()
        times.append(time.perf_counter() - t0)
    return {
        "task": f"{kind} of {n}",
        "protocol": "latched" if latched else "per-tick",
        "outcome": result.outcome,
        "ticks": result.ticks,
        "violations": len(check_run(task, result.runs)),
        "median_s": round(statistics.median(times), 3),
        "us_per_tick": round(statistics.median(times) / result.ticks * 1e6, 2),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rows = [bench(kind, n, latched, args.repeat) for kind, n, latched in CASES]
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(
        f"{'task':>13} {'protocol':>9} {'outcome':>8} {'ticks':>8} {'median s':>9} {'µs/tick':>8}"
    )
    for r in rows:
        print(
            f"{r['task']:>13} {r['protocol']:>9} {r['outcome']:>8} {r['ticks']:>8}"
            f" {r['median_s']:>9.3f} {r['us_per_tick']:>8.2f}"
        )
    big = next(r for r in rows if r["task"] == "AND of 1000")
    ok = big["outcome"] == "done" and float(big["median_s"]) <= TARGET_AND_1000_S  # type: ignore[arg-type]
    print(
        f"target: AND of 1000 done in <= {TARGET_AND_1000_S:.0f} s — "
        f"{'met' if ok else 'NOT met'} ({big['median_s']} s)"
    )


if __name__ == "__main__":
    main()
