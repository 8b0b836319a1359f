"""The planner at scale (issue 23, acceptance "Scale"): a generated task of 50 actions over 20
agents, solved to optimality or to a proven gap <= 5 % within 1 s.

For each seed, ``flexhrc scenario generate --actions 50 --agents 20 --width W --seed S``
(:func:`flexhrc.scenario.generate.generate`) writes a task; :func:`flexhrc.planning.solve` plans
it with a 1 s limit (CP-SAT, ``--workers`` search workers: 1 is what ``flexhrc plan`` and the
lookahead policy use). Printed per seed: the status, the makespan, the proven bound, the gap,
the solver's wall time and the whole call's (grounding and timing every branch included); then
the medians over the seeds and how many seeds met the target.

    python benchmarks/plan_scale.py [--seeds 5] [--actions 50] [--agents 20] [--width 8]
                                    [--time-limit 1.0] [--workers 1 4]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

from flexhrc.planning import solve
from flexhrc.scenario import load_scenario
from flexhrc.scenario.generate import generate

TARGET_GAP = 0.05


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--actions", type=int, default=50)
    ap.add_argument("--agents", type=int, default=20)
    ap.add_argument("--width", type=int, default=8)
    ap.add_argument("--time-limit", type=float, default=1.0)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 4])
    ap.add_argument("--travel", action="store_true", help="model the hands' travel (plan --travel)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tasks = []
        for seed in range(args.seeds):
            path = Path(tmp) / f"generated_{seed}.yaml"
            path.write_text(
                generate(actions=args.actions, agents=args.agents, width=args.width, seed=seed)
            )
            tasks.append((seed, load_scenario(path)))
        print(
            f"generated tasks: {args.actions} actions, {args.agents} agents, width {args.width}, "
            f"seeds 0..{args.seeds - 1}; time limit {args.time_limit:g} s; "
            f"{'with' if args.travel else 'without'} --travel (the target is shown without)"
        )
        for workers in args.workers:
            print(f"\nCP-SAT, {workers} worker(s)")
            print(f"{'seed':>4} {'status':>9} {'makespan':>9} {'bound':>9} {'gap':>7} "
                  f"{'solver s':>9} {'call s':>7}")  # fmt: skip
            gaps, solver_s, call_s, met = [], [], [], 0
            for seed, sc in tasks:
                t0 = time.perf_counter()
                plan = solve(
                    sc,
                    time_limit_s=args.time_limit,
                    workers=workers,
                    seed=seed,
                    travel=args.travel,
                )
                call = time.perf_counter() - t0
                gap = plan.gap if plan.gap is not None else float("inf")
                ok = plan.status == "optimal" or gap <= TARGET_GAP
                met += ok
                gaps.append(gap)
                solver_s.append(plan.solve_s)
                call_s.append(call)
                print(
                    f"{seed:>4} {plan.status:>9} {plan.makespan_s or float('nan'):>9.3f} "
                    f"{plan.bound or float('nan'):>9.3f} {gap:>7.1%} {plan.solve_s:>9.3f} "
                    f"{call:>7.3f}"
                )
            med_gap = statistics.median(gaps)
            print(
                f"median: gap {med_gap:.1%}, solver {statistics.median(solver_s):.3f} s, "
                f"whole call {statistics.median(call_s):.3f} s; {met}/{len(tasks)} seeds "
                f"optimal or gap <= {TARGET_GAP:.0%} within {args.time_limit:g} s -> target "
                f"(median) {'MET' if med_gap <= TARGET_GAP else 'MISSED'}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
