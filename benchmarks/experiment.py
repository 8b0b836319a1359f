"""The experiment harness (issue 23, items 4 and 5): the example design's wall time, and the
generator's time for a task of 50 actions and 20 agents.

    python benchmarks/experiment.py [--jobs 2] [--repeat 1] [--config examples/experiment.yaml]

Runs ``flexhrc experiment CONFIG --jobs N`` ``--repeat`` times into temporary folders and prints
the median wall time, the runs, how many were solved and the per-run median, against the
acceptance target of issue 23: the 4 × 2 × 2 × 10 design in under 5 minutes on 2 cores. Then
generates, validates and runs ``scenario generate --actions 50 --agents 20 --width 8`` for
seeds 0..4 and prints the medians of each step.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexhrc.app import RunConfig, run_scenario  # noqa: E402
from flexhrc.app.experiment import read_config, run_experiment  # noqa: E402
from flexhrc.scenario import load, validate  # noqa: E402
from flexhrc.scenario.generate import write_generated  # noqa: E402

TARGET_S = 300.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--config", default=str(ROOT / "examples" / "experiment.yaml"))
    args = ap.parse_args()

    config = read_config(args.config)
    walls, per_run = [], []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            report = run_experiment(config, Path(tmp) / "out", jobs=args.jobs)
            walls.append(time.perf_counter() - t0)
            per_run.append(statistics.median(r["wall_s"] for r in report.rows))
    wall = statistics.median(walls)
    print(
        f"experiment {config.name}: {report.json['runs']} runs, {report.json['solved']} solved, "
        f"{report.json['errors']} errors; wall {wall:.1f} s (median of {args.repeat}, "
        f"--jobs {args.jobs}); a run's median {statistics.median(per_run):.3f} s; "
        f"target < {TARGET_S:.0f} s: {wall / TARGET_S:.2f} of it"
    )
    for policy in config.policies:
        xs = [r["wall_s"] for r in report.rows if r["policy"] == policy]
        print(f"  policy {policy}: {len(xs)} runs, median {statistics.median(xs):.3f} s per run")

    gen, val, run, spans = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(5):
            p = Path(tmp) / f"g{seed}.yaml"
            t0 = time.perf_counter()
            write_generated(p, actions=50, agents=20, width=8, seed=seed)
            t1 = time.perf_counter()
            assert not [f for f in validate(p) if f.severity == "error"]
            load(p)
            t2 = time.perf_counter()
            r = run_scenario(RunConfig(p, seed=seed, quiet=True))
            t3 = time.perf_counter()
            assert r.result.outcome == "solved", r.json["reason"]
            gen.append(t1 - t0)
            val.append(t2 - t1)
            run.append(t3 - t2)
            spans.append(r.json["timing"]["total_s"])
    print(
        "scenario generate --actions 50 --agents 20 --width 8, seeds 0..4 (medians): "
        f"generate {statistics.median(gen) * 1e3:.1f} ms, validate+load "
        f"{statistics.median(val):.2f} s, run {statistics.median(run):.2f} s "
        f"(makespan {statistics.median(spans):.1f} s simulated)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
