"""Old against new, side by side in one run: compute per decision and the cell's round trip.

    git worktree add /tmp/flexhrc-old <commit>          # the tree to compare with
    python benchmarks/compare.py --old /tmp/flexhrc-old [--rounds 5] [--runs 5] [--commands 300]

Each figure is measured in fresh processes of each tree, the two trees taking turns (old, new,
old, new, ...) so that a machine that gets busier or quieter during the run weighs on both
alike. Each tree runs its own ``benchmarks/scenarios.py::per_decision`` (compute of the Task
Manager, task representation and simulator per decision tree, median over every scenario
both trees ship x the four operator profiles x ``--runs`` seeds, analytic simulator) and its own
``benchmarks/cell.py::round_trip`` (a command -> its ack between two processes over Zenoh on
loopback, median of ``--commands``). The report is the median of the rounds' medians for each
tree and the ratio new / old (the issue's bound: <= 1.1).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path
from typing import Any

NEW = Path(__file__).resolve().parents[1]

PER_DECISION = """
import importlib.util, json, statistics, sys
spec = importlib.util.spec_from_file_location("bench_scenarios", sys.argv[1])
mod = importlib.util.module_from_spec(spec); spec.loader.exec_module(mod)
from flexhrc import scenario
runs = int(sys.argv[2])
names = sys.argv[3].split(",") if len(sys.argv) > 3 else scenario.SHIPPED
values = []
for name in names:
    sc = scenario.load(name)
    mod.per_decision(sc, "passive", 0)  # warm caches
    for profile in mod.PROFILES:
        values += [mod.per_decision(sc, profile, s) for s in range(runs)]
print(json.dumps({"median_s": statistics.median(values)}))
"""

SHIPPED = """
import json
from flexhrc import scenario
print(json.dumps({"shipped": list(scenario.SHIPPED)}))
"""

ROUND_TRIP = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("bench_cell", sys.argv[1])
mod = importlib.util.module_from_spec(spec); spec.loader.exec_module(mod)
print(json.dumps({"median_s": mod.round_trip(int(sys.argv[2]))["median_ms"] / 1e3}))
"""


def _python(tree: Path, code: str, *argv: str) -> dict[str, Any]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree / "src")
    out = subprocess.run(
        [sys.executable, "-c", code, *argv],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
        timeout=1800,
    ).stdout
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def measure(tree: Path, code: str, script: str, arg: int, *extra: str) -> float:
    return float(
        _python(tree, code, str(tree / "benchmarks" / script), str(arg), *extra)["median_s"]
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="a worktree of the old commit")
    ap.add_argument("--rounds", type=int, default=5, help="turns of each tree (default 5)")
    ap.add_argument("--runs", type=int, default=5, help="seeds per scenario and profile")
    ap.add_argument("--commands", type=int, default=300, help="round trips per measurement")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not (args.old / "src" / "flexhrc").is_dir():
        ap.error(f"--old {args.old}: not a flexhrc tree (no src/flexhrc)")
    # per decision over the scenarios both trees ship: the same work (a scenario only one tree
    # has would weigh on its median alone)
    new_shipped = _python(NEW, SHIPPED)["shipped"]
    old_shipped = set(_python(args.old, SHIPPED)["shipped"])
    common = [name for name in new_shipped if name in old_shipped]
    print(f"per decision over the scenarios both ship: {', '.join(common)}", file=sys.stderr)
    figures: dict[str, tuple[str, str, int, tuple[str, ...], float, str]] = {
        "per decision": (PER_DECISION, "scenarios.py", args.runs, (",".join(common),), 1e3, "ms"),
        "cell round trip": (ROUND_TRIP, "cell.py", args.commands, (), 1e3, "ms"),
    }
    results: dict[str, dict[str, Any]] = {}
    for label, (code, script, arg, extra, scale, unit) in figures.items():
        got: dict[str, list[float]] = {"old": [], "new": []}
        for i in range(args.rounds):
            for which, tree in (("old", args.old), ("new", NEW)):
                got[which].append(measure(tree, code, script, arg, *extra))
            print(f"{label}: round {i + 1}/{args.rounds}", file=sys.stderr)
        old, new = statistics.median(got["old"]), statistics.median(got["new"])
        results[label] = {
            "old": old * scale,
            "new": new * scale,
            "ratio": new / old,
            "old_rounds": [v * scale for v in got["old"]],
            "new_rounds": [v * scale for v in got["new"]],
        }
        if not args.json:
            print(
                f"{label:<16} old {old * scale:8.3f} {unit}   new {new * scale:8.3f} {unit}   "
                f"new/old {new / old:5.2f}x   {'PASS' if new / old <= 1.1 else 'FAIL'} (<= 1.1x)"
            )
    if args.json:
        print(json.dumps(results, indent=2))
    return 0 if all(r["ratio"] <= 1.1 for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
