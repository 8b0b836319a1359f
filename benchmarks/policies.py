"""The ``lookahead`` policy against the paper's greedy one and the CP-SAT optimum (issue 23,
acceptance "Quality" and the decision latency).

Scenarios: the shipped ones (``examples/scenarios/*.yaml``, ``table_assembly``,
``table_two_arms``, ``kitchen_drawer``), the wide ``parallel_assembly``, ``--generated N``
tasks of ``flexhrc scenario generate`` (default 3: 20 actions, 6 agents, width 4, seeds
0..N-1) and any ``--extra FILE ...``. Every run is
``flexhrc run SCENARIO --policy P --human PROFILE --seed S`` on the analytic simulator (the
scenario's, as ``flexhrc run`` picks it), ``--seeds`` seeds (default 10).

1. **Passive operators.** The makespan (``timing.total_s`` of ``run --json``) of each policy
   over the optimum of ``flexhrc plan`` (:func:`flexhrc.planning.solve`, each hyper-arc timed
   from the hands at the start: runs can beat it) and over the ``plan --exact-travel`` optimum
   (``solve(..., exact_travel=True)``: the hands' travel from one hyper-arc to the next, a
   circuit for every agent, joint branches from both hands' places: a run's own durations
   model; solved with ``--travel-workers`` workers within ``--travel-time-limit``, 120 s;
   where it is not proven, its proven bound, and the status says ``fea``): the median of the
   ratios over the seeds, per scenario; target ``lookahead / optimum <= 1.05``.
2. **Deviating operators** (``takeover``, ``random``): each run's makespan over its hindsight
   optimum (:func:`flexhrc.planning.hindsight`: the best schedule of the cooperation path the run
   took with the person's hyper-arcs as the person did them), medians per scenario and policy.
3. **Decision latency** of ``lookahead``: the advisor's compute per decision (a re-solve, or
   the kept plan's look-up), median and p95 per scenario (the target's verdict on the shipped
   ones) and pooled over the shipped scenarios, the first decision of a run apart (it builds
   the model: grounding and timing every branch); target p95 <= 100 ms; the load average at
   the start and the end.

    python benchmarks/policies.py [--seeds 10] [--generated 3] [--extra FILE ...]
        [--only NAME ...] [--profiles [P ...]] [--travel-time-limit 120] [--travel-workers 2]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import flexhrc.planning  # noqa: F401  (registers the lookahead policy)
from flexhrc.planning import hindsight, solve
from flexhrc.scenario import load_scenario, prepare
from flexhrc.scenario.generate import generate

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = [
    *sorted(str(p) for p in (ROOT / "examples" / "scenarios").glob("*.yaml")),
    "table_assembly",
    "table_two_arms",
    "kitchen_drawer",
]
POLICIES = ("paper", "lookahead")


def _run(
    name: str, policy: str, profile: str, seed: int
) -> tuple[dict[str, Any], list[float], tuple[int, int]]:
    sc = load_scenario(name, seed=seed)
    run = prepare(sc, profile=profile, seed=seed, policy=policy)
    result = run.run()
    advisor = run.cell.tm.policy
    counts = (getattr(advisor, "solves", 0), getattr(advisor, "reused", 0))
    return result.summary, list(run.cell.tm.advice_s), counts


def _p95(xs: list[float]) -> float:
    s = sorted(xs)
    return s[min(len(s) - 1, round(0.95 * (len(s) - 1)))]


def _short(name: str) -> str:
    return Path(name).stem if name.endswith((".yaml", ".yml")) else name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--generated", type=int, default=3, help="generated tasks (default 3)")
    ap.add_argument("--extra", nargs="*", default=[], metavar="FILE")
    ap.add_argument("--profiles", nargs="*", default=["takeover", "random"])
    ap.add_argument(
        "--time-limit", type=float, default=30.0, help="the optimum's solve limit (default 30 s)"
    )
    ap.add_argument(
        "--travel-time-limit",
        type=float,
        default=120.0,
        help="the --exact-travel optimum's solve limit (default 120 s)",
    )
    ap.add_argument("--travel-workers", type=int, default=2, help="its CP-SAT workers (2)")
    ap.add_argument(
        "--only", nargs="*", default=[], metavar="NAME", help="only scenarios whose name has one"
    )
    args = ap.parse_args()
    seeds = range(args.seeds)
    tmp = tempfile.TemporaryDirectory()
    generated = []
    for k in range(args.generated):
        path = Path(tmp.name) / f"generated_{k}.yaml"
        path.write_text(generate(actions=20, agents=6, width=4, seed=k))
        generated.append(str(path))
    scenarios = [*SHIPPED, "parallel_assembly", *generated, *args.extra]
    if args.only:
        scenarios = [n for n in scenarios if any(w in _short(n) for w in args.only)]
    t_all = time.perf_counter()
    latencies: list[float] = []
    firsts: list[float] = []
    per_scenario: dict[str, list[float]] = {}  # lookahead decisions after the first, per scenario
    reuse: dict[str, list[int]] = {}  # scenario -> [solves, decisions that kept the plan]
    print(f"load average at the start: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")

    # -- 1. passive operators against the optimum ------------------------------------------------
    print(
        f"1. passive operators, {args.seeds} seeds: makespan / CP-SAT optimum (median over "
        "seeds); opt: each hyper-arc timed from the hands at the start; tr: `plan "
        "--exact-travel` (the hands' travel from one hyper-arc to the next, a circuit for every "
        f"agent: a run's durations model; {args.travel_workers} workers, "
        f"{args.travel_time_limit:g} s); status fea: the proven bound instead of the optimum"
    )
    print(f"{'scenario':<18} {'opt s':>7} {'tr s':>7} {'status':>13} {'paper':>6} "
          f"{'ahead':>6} {'paper/tr':>8} {'ahead/tr':>8} {'paper s':>8} "
          f"{'ahead s':>8}")  # fmt: skip
    worst = {"opt": 0.0, "tr": 0.0}
    cache: dict[tuple[str, int, bool], Any] = {}

    def optimum(name: str, seed: int, travel: bool) -> Any:
        key = (name, seed if name == "parallel_assembly" else 0, travel)  # seed: its layout
        if key not in cache:
            sc = load_scenario(name, seed=key[1])
            if travel:
                cache[key] = solve(
                    sc,
                    time_limit_s=args.travel_time_limit,
                    seed=key[1],
                    exact_travel=True,
                    workers=args.travel_workers,
                )
            else:
                cache[key] = solve(sc, time_limit_s=args.time_limit, seed=key[1])
        return cache[key]

    for name in scenarios:
        ratios: dict[str, list[float]] = {f"{p}/{r}": [] for p in POLICIES for r in worst}
        spans: dict[str, list[float]] = {p: [] for p in POLICIES}
        optima: dict[str, list[float]] = {r: [] for r in worst}
        statuses: set[str] = set()
        for seed in seeds:
            refs = {"opt": optimum(name, seed, False), "tr": optimum(name, seed, True)}
            ref_s: dict[str, float] = {}
            for r, plan in refs.items():
                statuses.add(f"{r}:{plan.status[:3]}")
                assert plan.makespan_s is not None, (name, r, plan.status)
                # not proven optimal: the bound the solver proved (a lower bound still)
                ref_s[r] = plan.makespan_s if plan.status == "optimal" else plan.bound
                optima[r].append(ref_s[r])
            for policy in POLICIES:
                summary, advice, counts = _run(name, policy, "passive", seed)
                span = summary["timing"]["total_s"]
                spans[policy].append(span)
                for r in refs:
                    ratios[f"{policy}/{r}"].append(span / ref_s[r])
                if policy == "lookahead" and advice:
                    per_scenario.setdefault(name, []).extend(advice[1:])
                    r_ = reuse.setdefault(name, [0, 0])
                    r_[0] += counts[0]
                    r_[1] += counts[1]
                    if name in SHIPPED:
                        firsts.append(advice[0])
                        latencies.extend(advice[1:])
        med = {k: statistics.median(v) for k, v in ratios.items()}
        for r in worst:
            worst[r] = max(worst[r], med[f"lookahead/{r}"])
        print(
            f"{_short(name):<18} {statistics.median(optima['opt']):>7.3f} "
            f"{statistics.median(optima['tr']):>7.3f} {' '.join(sorted(statuses)):>13} "
            f"{med['paper/opt']:>6.3f} {med['lookahead/opt']:>6.3f} "
            f"{med['paper/tr']:>8.3f} {med['lookahead/tr']:>8.3f} "
            f"{statistics.median(spans['paper']):>8.3f} "
            f"{statistics.median(spans['lookahead']):>8.3f}"
        )
    for r, w in worst.items():
        print(f"worst lookahead / {r} optimum (median per scenario): {w:.3f} -> target 1.05 "
              f"{'MET' if w <= 1.05 else 'MISSED'}")  # fmt: skip

    # -- 2. deviating operators against the hindsight optimum -----------------------------------
    print(f"\n2. deviating operators, {args.seeds} seeds: makespan / hindsight optimum (median)")
    print(f"{'scenario':<22} {'profile':>9} {'paper':>7} {'lookahead':>9} {'paper s':>8} "
          f"{'ahead s':>8}")  # fmt: skip
    for name in scenarios:
        for profile in args.profiles:
            ratios = {p: [] for p in POLICIES}
            spans = {p: [] for p in POLICIES}
            for seed in seeds:
                for policy in POLICIES:
                    summary, advice, _ = _run(name, policy, profile, seed)
                    if policy == "lookahead" and advice:
                        per_scenario.setdefault(name, []).extend(advice[1:])
                        if name in SHIPPED:
                            firsts.append(advice[0])
                            latencies.extend(advice[1:])
                    span = summary["timing"]["total_s"]
                    ref = hindsight(
                        load_scenario(name, seed=seed),
                        summary["solved_hyperarcs"],
                        time_limit_s=args.time_limit,
                        seed=seed,
                    )
                    assert ref.makespan_s is not None, (name, profile, seed, ref.status)
                    spans[policy].append(span)
                    ratios[policy].append(span / ref.makespan_s)
            print(
                f"{_short(name):<22} {profile:>9} {statistics.median(ratios['paper']):>7.3f} "
                f"{statistics.median(ratios['lookahead']):>9.3f} "
                f"{statistics.median(spans['paper']):>8.3f} "
                f"{statistics.median(spans['lookahead']):>8.3f}"
            )

    # -- 3. decision latency ----------------------------------------------------------------------
    print("\n3. lookahead decision latency per scenario (every decision after a run's first, "
          "runs of 1. and 2.; solves / decisions that kept the plan: passive runs)")  # fmt: skip
    print(f"{'scenario':<18} {'decisions':>9} {'median ms':>9} {'p95 ms':>7} {'verdict':>8} "
          f"{'solves':>7} {'kept':>6}")  # fmt: skip
    for name, xs in per_scenario.items():
        if not xs:
            continue
        p95 = _p95(xs)
        verdict = ("MET" if p95 <= 0.1 else "MISSED") if name in SHIPPED else "-"
        solves, kept = reuse.get(name, [0, 0])
        print(
            f"{_short(name):<18} {len(xs):>9} {statistics.median(xs) * 1000:>9.1f} "
            f"{p95 * 1000:>7.1f} {verdict:>8} {solves:>7} {kept:>6}"
        )
    print(f"pooled over the shipped scenarios ({len(latencies)} decisions)")
    if latencies:
        p95 = _p95(latencies)
        print(
            f"median {statistics.median(latencies) * 1000:.1f} ms, p95 {p95 * 1000:.1f} ms "
            f"-> target p95 <= 100 ms {'MET' if p95 <= 0.1 else 'MISSED'}; first decision of a "
            f"run (builds the model) median {statistics.median(firsts) * 1000:.1f} ms"
        )
    print(
        f"\n(total {time.perf_counter() - t_all:.0f} s; load average at the end: "
        f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}; target p95 <= 100 ms per shipped "
        "scenario, MET/MISSED above)"
    )
    tmp.cleanup()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
