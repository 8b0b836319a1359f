"""Compute per decision on every shipped scenario, and memory over many runs in one process.

For each shipped scenario (``flexhrc scenario list``) and each operator profile, runs seeded
cooperations with the analytic simulator and reports the median compute per decision — Task
Manager + task representation + simulator, wall clock, divided by the decision trees built —
against the target of issue #10 (<= 2 ms). Then runs ``--memory-runs`` cooperations (all
scenarios, all profiles, in turn) in this one process and compares the traced heap after the
first tenth with the heap at the end: flat means it grows by less than 64 kB over the
remaining nine tenths (a leak of one event log per run would be megabytes).

    python benchmarks/scenarios.py [--runs 20] [--memory-runs 1000]
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc import scenario

PROFILES = ("passive", "takeover", "cooperative", "random")
TARGET_S = 0.002
MEMORY_GROWTH_B = 64_000  # the heap may grow this much between the first tenth and the end


def per_decision(sc: scenario.Scenario, profile: str, seed: int) -> float:
    s = scenario.run(sc, profile=profile, seed=seed, simulator="analytic").summary
    t = s["timing"]
    compute = t["task_manager_s"] + t["task_representation_s"] + t["simulator_s"]
    return compute / max(s["decisions"], 1)


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--runs", type=int, default=20, help="seeded runs per scenario and profile")
    ap.add_argument("--memory-runs", type=int, default=1000)
    args = ap.parse_args()
    loaded = {name: scenario.load(name) for name in scenario.SHIPPED}
    print(f"compute per decision, analytic simulator, median of {args.runs} seeded runs")
    head = f"{'scenario':<16}" + "".join(f"{p:>13}" for p in PROFILES) + "   target 2 ms"
    print(head)
    print("-" * len(head))
    ok = True
    for name, sc in loaded.items():
        per_decision(sc, "passive", 0)  # warm caches (imports, parsing of invocations)
        cells = []
        worst = 0.0
        for profile in PROFILES:
            med = statistics.median(per_decision(sc, profile, s) for s in range(args.runs))
            worst = max(worst, med)
            cells.append(f"{med * 1e3:>11.3f}ms")
        verdict = "PASS" if worst <= TARGET_S else "FAIL"
        ok &= verdict == "PASS"
        print(f"{name:<16}" + "".join(cells) + f"   {verdict}")

    print(f"\nmemory over {args.memory_runs} runs in one process (tracemalloc)")
    cycle = [(sc, p) for sc in loaded.values() for p in PROFILES]
    tracemalloc.start()
    marks: list[tuple[int, float]] = []
    tenth = max(args.memory_runs // 10, 1)
    for i in range(args.memory_runs):
        sc, profile = cycle[i % len(cycle)]
        scenario.run(sc, profile=profile, seed=i, simulator="analytic")
        if (i + 1) % tenth == 0:
            gc.collect()
            current, peak = tracemalloc.get_traced_memory()
            marks.append((i + 1, current, peak))
    tracemalloc.stop()
    for n, current, peak in marks:
        print(f"  after {n:>5} runs: {current / 1e3:9.1f} kB traced (peak {peak / 1e6:.2f} MB)")
    growth = marks[-1][1] - marks[0][1]
    verdict = "PASS" if growth <= MEMORY_GROWTH_B else "FAIL"
    ok &= verdict == "PASS"
    print(
        f"  growth from run {marks[0][0]} to run {marks[-1][0]}: {growth / 1e3:.1f} kB "
        f"(flat: <= {MEMORY_GROWTH_B / 1e3:.0f} kB)   {verdict}"
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
