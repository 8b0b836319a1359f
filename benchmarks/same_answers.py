"""Do two trees cooperate alike? Every shipped scenario x the four profiles x seeds, old and new.

    git worktree add /tmp/flexhrc-old <commit>
    python benchmarks/same_answers.py --old /tmp/flexhrc-old [--seeds 3]

Each tree runs ``flexhrc.scenario.run`` (analytic simulator) in a process of its own; the
report lists every run whose cooperation differs — outcome, the solved hyper-arcs in order with
their agents, ``by_agent`` — with both sequences, every run whose makespan alone differs, and,
for each event type whose count differs between the logs, in how many runs. Exit 1 when a
cooperation differs.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

NEW = Path(__file__).resolve().parents[1]

DUMP = """
import json, sys
from flexhrc import scenario
out = {}
for name in scenario.SHIPPED:
    sc = scenario.load(name)
    for profile in ("passive", "takeover", "cooperative", "random"):
        for seed in range(int(sys.argv[1])):
            r = scenario.run(sc, profile=profile, seed=seed, simulator="analytic")
            s = r.summary
            out[f"{name}/{profile}/{seed}"] = {
                "outcome": s["outcome"],
                "solved": [[h["hyperarc"], h["agent"]] for h in s["solved_hyperarcs"]],
                "by_agent": s["by_agent"],
                "total_s": s["timing"]["total_s"],
                "types": [e["type"] for e in r.events if e["type"] != "summary"],
            }
print(json.dumps(out))
"""


def dump(tree: Path, seeds: int) -> dict[str, Any]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree / "src")
    out = subprocess.run(
        [sys.executable, "-c", DUMP, str(seeds)],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
        timeout=1800,
    ).stdout
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", type=Path, required=True, help="a worktree of the old commit")
    ap.add_argument("--seeds", type=int, default=3, help="seeds per scenario and profile")
    args = ap.parse_args(argv)
    if not (args.old / "src" / "flexhrc").is_dir():
        ap.error(f"--old {args.old}: not a flexhrc tree (no src/flexhrc)")
    old, new = dump(args.old, args.seeds), dump(NEW, args.seeds)
    differ = 0
    types: collections.Counter[tuple[str, str]] = collections.Counter()
    for key in sorted(old.keys() & new.keys()):
        o, n = old[key], new[key]
        same = (o["outcome"], o["solved"], o["by_agent"]) == (
            n["outcome"],
            n["solved"],
            n["by_agent"],
        )
        if not same:
            differ += 1
            print(f"cooperation differs: {key} (makespan {o['total_s']} -> {n['total_s']} s)")
            print(f"  old {o['solved']}")
            print(f"  new {n['solved']}")
        elif abs(o["total_s"] - n["total_s"]) > 1e-9:
            print(f"makespan differs: {key}: {o['total_s']} -> {n['total_s']} s")
        co, cn = collections.Counter(o["types"]), collections.Counter(n["types"])
        for t in co.keys() | cn.keys():
            if co[t] != cn[t]:
                types[(t, "more in old" if co[t] > cn[t] else "more in new")] += 1
    runs = len(old.keys() & new.keys())
    print(f"{runs - differ} of {runs} runs cooperate identically")
    for (t, where), count in sorted(types.items()):
        print(f"  event type {t:<26} {where}: in {count} runs")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
