"""A fast kinematic decision (issue 23, item 3): the table's first decision, old path vs new.

The first decision of the 4-leg table (8 branches: every leg x every arm, 6 controller actions
each, integrated with the task-priority controller at 40 ms steps, the outcome cache of the
simulator off) is timed with the old path — each branch simulated on its own, each motion
integrated by the scalar controller (``KinematicTaskSimulator(share=False)``) — and with the new
one — the branches advance together, repeated motions come from the motion cache and the rest
are integrated by the compiled control loop (:mod:`flexhrc.action.batch`,
:mod:`flexhrc.action.lockstep`, :mod:`flexhrc.action.kernel`; numba) — and, between them, the
same sharing with the numpy lockstep (the path taken without numba). The three alternate within
one run (median of N each), so all see the same machine load; the load average is printed
beside them, and the one-off compile (or load from numba's cache) of the kernel is timed apart.
It checks that all choose the same branch with the same utility J (eq. 21) within 1e-6, and
counts the controller steps each integrated (a figure that does not depend on the load).

    python benchmarks/kinematic_decision.py [--runs 15] [--seed 0] [--assemblies 3]

``--assemblies``: whole seeded runs of the 4-leg table (cooperative operator), old vs new: the
simulator's compute per run and the steps integrated — later decisions reuse motions of earlier
ones (the arm that did not move), which the first decision cannot.

Target (issue 23): the new first decision <= 25 ms median (the old one: ~90 ms on a quiet
machine).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

TARGET_S = 0.025


def first_decision(share: bool, seed: int, compiled: bool = True) -> tuple[float, float, Any, Any]:
    """The simulator's time of the first decision (wall clock, and this thread's CPU time),
    its tree, and the simulator; ``compiled=False``: the numpy lockstep instead of the kernel."""
    from flexhrc.action import KinematicTaskSimulator, kernel

    kernel.enabled = compiled
    from flexhrc.action.simulator import KinematicSimulator
    from flexhrc.scenario.builtin.table import table_assembly
    from flexhrc.taskmanager import TaskManager

    sc = table_assembly(4, seed=seed, segments="legs")
    kin = KinematicTaskSimulator(KinematicSimulator(dt=0.04, cache_size=0), share=share)
    tm = TaskManager(sc.online_graph(), sc.domain, sc.world(), kin)
    trees: list[Any] = []
    build = tm._tree

    def keep(*args: Any, **kw: Any) -> Any:
        trees.append(build(*args, **kw))
        return trees[-1]

    tm._tree = keep  # type: ignore[method-assign]
    cpu = time.thread_time()
    tm.start(0.0)
    return tm.timing.simulator_s, time.thread_time() - cpu, trees[0], kin


def assembly(share: bool, seed: int) -> tuple[float, int, list[Any]]:
    from flexhrc.action import KinematicTaskSimulator, kernel

    kernel.enabled = True
    from flexhrc.cell.local import LocalCell
    from flexhrc.scenario.builtin.table import table_assembly

    kin = KinematicTaskSimulator(share=share)
    sc = table_assembly(4, seed=seed, segments="legs")
    result = LocalCell(sc, simulator=kin, execution=kin, profile="cooperative", seed=seed).run()
    decisions = [
        (e["element"], e["chosen"], [b["utility"] for b in e["branches"]])
        for e in result.events
        if e["type"] == "decision"
    ]
    return result.summary["timing"]["simulator_s"], kin.steps_integrated, decisions


def main() -> int:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--runs", type=int, default=15)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--assemblies", type=int, default=3)
    args = ap.parse_args()
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        print("kinematic simulator not installed: pip install 'flexhrc[sim]'")
        return 0
    from flexhrc.action import kernel

    t0 = time.perf_counter()
    warm = kernel.warm_up()  # the kernel compiled, or loaded from numba's cache, once
    first_decision(True, args.seed)  # warm up: imports, the robot model
    first_decision(False, args.seed)
    first_decision(True, args.seed, compiled=False)
    warm_all = time.perf_counter() - t0
    # True: shared + compiled; False: the old path; "numpy": shared + the numpy lockstep
    variants: tuple[Any, ...] = (False, "numpy", True)
    times: dict[Any, list[float]] = {v: [] for v in variants}
    cpus: dict[Any, list[float]] = {v: [] for v in variants}
    load = [os.getloadavg()[0]]
    agree = True
    worst_dj = 0.0
    steps = {}
    for _ in range(args.runs):
        trees = {}
        for v in variants:
            t, cpu, tree, kin = first_decision(v is not False, args.seed, compiled=v is True)
            times[v].append(t)
            cpus[v].append(cpu)
            trees[v] = tree
            steps[v] = (kin.steps_integrated, kin.motions_integrated, kin.motions_requested)
        old = trees[False]
        best_old = max(old.branches, key=lambda b: b.utility)
        for v in ("numpy", True):
            best_new = max(trees[v].branches, key=lambda b: b.utility)
            agree = agree and best_old.grounding == best_new.grounding
            for a, b in zip(old.branches, trees[v].branches, strict=True):
                worst_dj = max(worst_dj, abs(a.utility - b.utility))
    load.append(os.getloadavg()[0])
    m_old, m_new = statistics.median(times[False]), statistics.median(times[True])
    m_np = statistics.median(times["numpy"])
    n_branches = len(trees[True].branches)
    print(
        f"first decision of the 4-leg table (seed {args.seed}, {n_branches} branches), "
        f"median of {args.runs} interleaved runs; load average {load[0]:.2f} -> {load[1]:.2f} "
        f"on {os.cpu_count()} cores"
    )
    c_old, c_new = statistics.median(cpus[False]), statistics.median(cpus[True])
    c_np = statistics.median(cpus["numpy"])
    print("                               simulator (wall)         CPU of this thread")
    print(
        f"  old (share=False, scalar)    {m_old * 1e3:8.1f} ms (min {min(times[False]) * 1e3:5.1f})"
        f"   {c_old * 1e3:8.1f} ms"
    )
    print(
        f"  shared, numpy lockstep       {m_np * 1e3:8.1f} ms "
        f"(min {min(times['numpy']) * 1e3:5.1f})   {c_np * 1e3:8.1f} ms"
    )
    name = "new (shared, compiled)" if kernel.available() else "new (no numba: numpy)"
    print(
        f"  {name:<28} {m_new * 1e3:8.1f} ms (min {min(times[True]) * 1e3:5.1f})"
        f"   {c_new * 1e3:8.1f} ms"
    )
    gap = " " * 16
    print(f"  ratio old/new                {m_old / m_new:8.2f} x{gap}{c_old / c_new:8.2f} x")
    print(f"  ratio numpy lockstep/new     {m_np / m_new:8.2f} x{gap}{c_np / c_new:8.2f} x")
    print(
        f"  once per process, not in the figures: the kernel's compile or cache load "
        f"{warm:.2f} s (all warm-up runs {warm_all:.2f} s)"
    )
    so, sn = steps[False], steps[True]
    print(
        f"  controller steps integrated: old {so[0]} ({so[1]} motions), new {sn[0]} "
        f"({sn[1]} of {sn[2]} motions integrated)"
    )
    same = "same" if agree else "DIFFERENT"
    print(
        f"  chosen branch: {same} ({dict(best_new.grounding)}); "
        f"largest |J_old - J_new| over the branches: {worst_dj:.2e} (<= 1e-6)"
    )
    ok = agree and worst_dj <= 1e-6
    verdict = "PASS" if m_new <= TARGET_S else "FAIL"
    print(f"  target: new <= {TARGET_S * 1e3:.0f} ms median: {verdict}")
    if args.assemblies:
        rows = {False: [], True: []}
        same_runs = True
        for seed in range(args.assemblies):
            runs = {}
            for share in (False, True):
                t0 = time.perf_counter()
                sim_s, n_steps, decisions = assembly(share, seed)
                rows[share].append((sim_s, n_steps, time.perf_counter() - t0))
                runs[share] = decisions
            for (e1, c1, u1), (e2, c2, u2) in zip(runs[False], runs[True], strict=True):
                same_runs = same_runs and e1 == e2 and c1 == c2
                same_runs = same_runs and all(
                    abs(x - y) <= 1e-6 for x, y in zip(u1, u2, strict=True)
                )
            same_runs = same_runs and len(runs[False]) == len(runs[True])
        print(
            f"\nwhole 4-leg assemblies (cooperative operator, seeds 0..{args.assemblies - 1}), "
            "medians per run:"
        )
        for share, name in ((False, "old"), (True, "new")):
            r = rows[share]
            print(
                f"  {name}: simulator {statistics.median(x[0] for x in r) * 1e3:7.1f} ms, "
                f"controller steps {statistics.median(x[1] for x in r):7.0f}"
            )
        print(f"  every decision the same (element, chosen branch, J within 1e-6): {same_runs}")
        ok = ok and same_runs
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
