"""``flexhrc experiment CONFIG.yaml [-o DIR] [--jobs N] [--force] [--json]``."""

from __future__ import annotations

import argparse
import sys

from flexhrc.cli.common import emit, int_range


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "experiment",
        help="run a design (scenarios x profiles x policies x seeds) in parallel, with tables "
        "and plots",
        description="Run every run of the design CONFIG.yaml describes (scenarios x operator "
        "profiles x decision policies x utilities x seeds) in parallel processes, with a "
        "progress bar on stderr, and write runs.csv, summary.csv, summary.md, makespan.png, "
        "idle.png and experiment.json into DIR (docs/experiment.md). A failed run is a row "
        "with its error.",
    )
    p.add_argument("config", metavar="CONFIG.yaml", help="the experiment config")
    p.add_argument(
        "-o",
        "--output",
        metavar="DIR",
        default=None,
        help="output folder (default: experiment-NAME); created if missing; refused if it "
        "has files unless --force",
    )
    p.add_argument(
        "--jobs",
        type=int_range(1, 256),
        default=None,
        metavar="N",
        help="parallel processes (default: the CPU count; 1: in this process)",
    )
    p.add_argument("--force", action="store_true", help="write into a folder that has files")
    p.add_argument("--json", action="store_true", help="print experiment.json on stdout")
    p.set_defaults(func=cmd_experiment)


def cmd_experiment(args: argparse.Namespace) -> int:
    from flexhrc.app.experiment import (
        ProgressBar,
        can_solve,
        design_words,
        read_config,
        run_experiment,
    )

    config = read_config(args.config)
    optima = can_solve()
    n = len(config.scenarios)
    extra = f" and {n} CP-SAT {'optimum' if n == 1 else 'optima'}" if optima else ""
    runs = f"{config.runs} run{'s' * (config.runs != 1)}"
    print(f"{config.name}: {runs} ({design_words(config)}){extra}", file=sys.stderr)
    bar = ProgressBar(sys.stderr, label="runs+optima" if optima else "runs")
    report = run_experiment(config, args.output, jobs=args.jobs, force=args.force, progress=bar)
    if args.json:
        emit(args, report.json)
    else:
        print(report.text)
        for note in report.notes:
            print(f"note: {note}")
    return 0
