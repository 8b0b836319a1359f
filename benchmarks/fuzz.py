"""Fuzz flexhrc's readers for a while (issue 20, item 5).

Runs the targets of ``tests/fuzz/targets.py`` — the protocol parser and the event catalogue,
the ANDOR readers (compiled against pure Python), the scenario reader, the event store and
``replay`` — with random seeds, the time shared equally between them. Each target runs in
rounds of ``--examples`` inputs, each round with a seed of its own, until its share of the
time is used. Prints the inputs tried per target and, for every failure, the exception, the
minimised input and the command that runs that round again. Inputs that hit a known finding
(``KNOWN`` in the targets: a bug of a module other work owns, pinned by an ``xfail`` test) are
counted per finding, not reported again.

    python benchmarks/fuzz.py --minutes 10
    python benchmarks/fuzz.py --target andor --seed 123 --examples 200   # one round again

Exit status 1 when a target failed. CI runs the same targets with a small fixed budget
(``tests/fuzz/test_fuzz.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import random
import sys
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(ROOT))

from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis import seed as with_seed  # noqa: E402
from tests.fuzz.targets import TARGETS, Hang, Target, Workspace  # noqa: E402


@dataclass
class Tally:
    """What one target did: inputs tried, rounds, seconds and failures (one per round)."""

    inputs: int = 0
    known: dict[str, int] = field(default_factory=dict)  # known finding -> inputs that hit it
    rounds: int = 0
    seconds: float = 0.0
    failures: list[str] = field(default_factory=list)


class _OutOfTime(BaseException):
    """The round's time is up (a BaseException: Hypothesis stops at once, no shrinking)."""


def one_round(
    target: Target,
    ws: Workspace,
    seed: int,
    examples: int,
    tally: Tally,
    until: float = float("inf"),
) -> bool:
    """Run ``examples`` inputs of ``target`` from ``seed`` (fewer when ``until``, a
    ``perf_counter`` time, comes first); False (and a report in the tally) when one broke the
    property."""
    failing: dict[str, tuple[str, Any]] = {}  # where -> (message, its last, smallest, input)

    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        derandomize=False,
        suppress_health_check=list(HealthCheck),
        phases=[Phase.generate, Phase.shrink],
        print_blob=False,
    )
    @with_seed(seed)
    @given(target.inputs())
    def run(value: Any) -> None:
        if time.perf_counter() > until and not failing:
            raise _OutOfTime
        tally.inputs += 1
        try:
            finding = target.run(ws, value, known=True)
            if finding is not None:
                tally.known[finding.module] = tally.known.get(finding.module, 0) + 1
        except Hang as exc:  # not shrunk: each try would take the watchdog's time
            failing["Hang"] = (str(exc), value)
            raise
        except Exception as exc:
            # one failure per place it is raised (the message varies with the input)
            frame = traceback.extract_tb(exc.__traceback__)[-1]
            where = f"{type(exc).__name__} at {Path(frame.filename).name}:{frame.lineno}"
            first = (str(exc).splitlines() or [""])[0][:300]
            failing[where] = (first, value)
            raise

    start = time.perf_counter()
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # (its report: ours is below)
            run()
    except _OutOfTime:
        pass
    except (Exception, Hang):
        cause = traceback.format_exc(limit=-3)
        for where, (what, value) in failing.items():
            tally.failures.append(
                f"{target.name}: {where}: {what}\n  minimal input: {value!r:.3000}\n"
                f"  reproduce: python benchmarks/fuzz.py --target {target.name} --seed {seed} "
                f"--examples {examples}"
            )
        if not failing:
            tally.failures.append(f"{target.name} (seed {seed}):\n{cause}")
        return False
    finally:
        tally.rounds += 1
        tally.seconds += time.perf_counter() - start
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=1.0, help="total time (default 1)")
    ap.add_argument("--target", action="append", choices=sorted(TARGETS), help="only these")
    ap.add_argument("--seed", type=int, help="run one round of this seed (reproduce a failure)")
    ap.add_argument("--examples", type=int, default=200, help="inputs per round (default 200)")
    args = ap.parse_args(argv)
    if args.minutes <= 0 or args.examples < 1:
        ap.error("--minutes and --examples must be positive")
    names = args.target or sorted(TARGETS)
    tallies = {n: Tally() for n in names}
    ws = Workspace()
    rng = random.Random()
    try:
        if args.seed is not None:
            for n in names:
                one_round(TARGETS[n], ws, args.seed, args.examples, tallies[n])
        else:
            share = args.minutes * 60 / len(names)
            for n in names:
                tally = tallies[n]
                print(f"{n}: fuzzing for {share:.0f} s ...", flush=True)
                until = time.perf_counter() + share
                while time.perf_counter() < until:
                    seed = rng.randrange(2**32)
                    if not one_round(TARGETS[n], ws, seed, args.examples, tally, until):
                        break  # one failure per target: a second would mostly repeat it
    finally:
        ws.close()
    print()
    print(f"{'target':<10}{'inputs':>10}{'rounds':>8}{'seconds':>9}{'inputs/s':>10}  result")
    for n, t in tallies.items():
        rate = t.inputs / t.seconds if t.seconds else 0.0
        result = f"{len(t.failures)} failure(s)" if t.failures else "no failure"
        if t.known:
            result += "; known: " + ", ".join(f"{m} x{c}" for m, c in sorted(t.known.items()))
        print(f"{n:<10}{t.inputs:>10}{t.rounds:>8}{t.seconds:>9.1f}{rate:>10.1f}  {result}")
    failures = [f for t in tallies.values() for f in t.failures]
    for f in failures:
        print()
        print(f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
