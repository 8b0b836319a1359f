"""``flexhrc har`` — human action recognition from wrist acceleration (GMM/GMR).

    flexhrc har train DATA_DIR -o MODEL [--actions a,b,c]
    flexhrc har eval MODEL DATA_DIR [--json]
    flexhrc har eval --cv volunteer DATA_DIR [--folds K] [--baseline] [--json]
    flexhrc har stream MODEL FILE [--json]
    flexhrc har synth MODEL ACTION -o FILE.csv [--seed S]

Heavy imports happen inside the handlers so ``flexhrc --help`` stays fast.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from flexhrc.cli.common import (
    add_json_flag,
    check_outputs,
    emit,
    float_range,
    int_range,
    log,
    needs,
    progress,
    seed_type,
)
from flexhrc.errors import FlexhrcError
from flexhrc.taskmanager.replay import plural

MAX_COMPONENTS = 20  # BIC tries 1..K components: more is slow and never chosen on HMP data
MAX_GAP_S = 60.0
MIN_SPEED, MAX_SPEED = 0.01, 1000.0


def _actions(value: str | None) -> list[str] | None:
    if value is None:
        return None
    names = [a.strip().lower() for a in value.split(",") if a.strip()]
    if not names:
        raise FlexhrcError("--actions: give a comma-separated list of action names")
    return names


def _add_dataset_options(p: argparse.ArgumentParser, actions_help: str) -> None:
    p.add_argument("--actions", help=actions_help)
    p.add_argument(
        "--min-trials",
        type=int_range(1, 100_000),
        default=1,
        help="skip actions with fewer trials (default 1)",
    )


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "har",
        help="human action recognition from wrist acceleration (GMM/GMR)",
        description="Human motion primitives from wrist accelerometer data: GMM/GMR templates "
        "after Bruno et al. (HMP dataset layout: one folder per action).",
    )
    sub = p.add_subparsers(dest="har_command", metavar="ACTION")
    p.set_defaults(func=lambda a: (p.print_help(), 2)[1])

    t = sub.add_parser("train", help="fit one GMM/GMR model per action")
    t.add_argument("data_dir", metavar="DATA_DIR", help="one folder per action of trial files")
    t.add_argument("-o", "--output", required=True, metavar="MODEL", help="model file (.npz)")
    _add_dataset_options(t, "comma-separated action names (default: all folders)")
    t.add_argument(
        "--max-components",
        type=int_range(1, MAX_COMPONENTS),
        default=4,
        help=f"largest GMM tried (BIC; default 4, at most {MAX_COMPONENTS})",
    )
    t.add_argument("--seed", type=seed_type, default=0, help="seed of the GMM fits (default 0)")
    add_json_flag(t)
    t.set_defaults(func=_train)

    e = sub.add_parser(
        "eval",
        help="evaluate a model on a dataset, or cross-validate by volunteer",
        description="With MODEL DATA_DIR: every trial is classified by its best-matching "
        "model. With --cv volunteer DATA_DIR: leave-one-volunteer-out (or --folds K "
        "groups of volunteers) training and testing on DATA_DIR.",
    )
    e.add_argument(
        "paths",
        nargs="+",
        metavar="MODEL DATA_DIR | DATA_DIR",
        help="a trained model and a dataset, or (with --cv) a dataset",
    )
    e.add_argument("--cv", choices=["volunteer"], help="cross-validate split by volunteer")
    e.add_argument(
        "--folds",
        type=int_range(2, 10_000),
        default=None,
        help="with --cv: volunteer groups (default: leave one volunteer out)",
    )
    e.add_argument(
        "--baseline", action="store_true", help="with --cv: also run the summary-feature RF"
    )
    _add_dataset_options(e, "comma-separated action names")
    e.add_argument("--seed", type=seed_type, default=0, help="seed of the fits (default 0)")
    add_json_flag(e)
    e.set_defaults(func=_eval)

    s = sub.add_parser("stream", help="replay a recording and print recognitions as they occur")
    s.add_argument("model", metavar="MODEL", help="a trained model (flexhrc har train)")
    s.add_argument("file", metavar="FILE", help="trial file: HMP .txt, .csv (g) or .npy")
    s.add_argument(
        "--speed",
        type=float_range(0.0, MAX_SPEED),
        default=0.0,
        help=f"replay speed x real time (0: as fast as possible; else {MIN_SPEED:g} to "
        f"{MAX_SPEED:g})",
    )
    s.add_argument(
        "--stride",
        type=int_range(1, 10_000),
        default=8,
        help="samples between two evaluations (default 8)",
    )
    add_json_flag(s)
    s.set_defaults(func=_stream)

    y = sub.add_parser("synth", help="synthesise a wearable recording from a model")
    y.add_argument("model", metavar="MODEL", help="a trained model (flexhrc har train)")
    y.add_argument("actions", metavar="ACTION[,ACTION...]", help="the actions to perform, in order")
    y.add_argument("-o", "--output", required=True, metavar="FILE.csv", help="the recording")
    y.add_argument("--seed", type=seed_type, default=0, help="seed of the synthesis (default 0)")
    y.add_argument(
        "--gap",
        type=float_range(0.0, MAX_GAP_S),
        default=2.0,
        help=f"still seconds before each action (default 2, at most {MAX_GAP_S:g})",
    )
    add_json_flag(y)
    y.set_defaults(func=_synth)


def _train(args: argparse.Namespace) -> int:
    from flexhrc.perception.human.api import train

    check_outputs([("-o", args.output, (".npz",))])
    data = train(
        args.data_dir,
        args.output,
        actions=_actions(args.actions),
        min_trials=args.min_trials,
        max_components=args.max_components,
        seed=args.seed,
        progress=progress,
    )
    models = data["actions"]

    def text() -> str:
        lines = [f"saved {data['model']} ({plural(len(models), 'action')}, {data['seconds']} s)"]
        for c, m in models.items():
            lines.append(
                f"  {c:16s} window {m['length_s']:6.2f} s  components {m['components']}  "
                f"threshold {m['threshold']:.3f}"
            )
        return "\n".join(lines)

    emit(args, data, text)
    return 0


def _report_text(title: str, rep: dict) -> str:
    lines = [
        f"{title}: {plural(rep['n_trials'], 'trial')}  accuracy {rep['accuracy']:.3f}  "
        f"macro F1 {rep['macro_f1']:.3f}"
    ]
    labels = rep["labels"]
    for lab in labels:
        pc = rep["per_class"][lab]
        lines.append(
            f"  {lab:16s} precision {pc['precision']:.2f}  recall {pc['recall']:.2f}  "
            f"n={pc['support']}"
        )
    lines.append("confusion matrix (rows: true action, columns: predicted action):")
    lines.extend("  " + row for row in confusion_rows(labels, rep["confusion_matrix"]))
    return "\n".join(lines)


def confusion_rows(labels: list[str], matrix: list[list[int]]) -> list[str]:
    """The confusion matrix with its labels on both axes: a key of short column codes (the
    action names do not fit above narrow columns) and one labelled row per true action."""
    codes = [f"[{i + 1}]" for i in range(len(labels))]
    corner = "true \\ predicted"
    width = max(len(corner), *(len(f"{c} {lab}") for c, lab in zip(codes, labels, strict=True)))
    cell = max(5, *(len(c) + 1 for c in codes), *(len(str(v)) + 1 for r in matrix for v in r))
    head = f"{corner:<{width}}" + "".join(f"{c:>{cell}}" for c in codes)
    rows = [head]
    for code, lab, row in zip(codes, labels, matrix, strict=True):
        rows.append(f"{f'{code} {lab}':<{width}}" + "".join(f"{v:>{cell}d}" for v in row))
    return rows


def _eval(args: argparse.Namespace) -> int:
    from flexhrc.perception.human.api import cross_validation, evaluate

    needs(args, "--folds", args.folds is not None, "--cv volunteer", bool(args.cv))
    needs(args, "--baseline", args.baseline, "--cv volunteer", bool(args.cv))
    dataset = {
        "actions": _actions(args.actions),
        "min_trials": args.min_trials,
        "progress": progress,
    }
    if args.cv:
        if len(args.paths) != 1:
            raise FlexhrcError("eval --cv volunteer takes one argument: DATA_DIR")
        out = cross_validation(
            args.paths[0], folds=args.folds, baseline=args.baseline, seed=args.seed, **dataset
        )
        methods = [name for name in out if name != "split"]
        emit(
            args,
            out,
            lambda: "\n\n".join(
                [f"split: {out['split']}"] + [_report_text(name, out[name]) for name in methods]
            ),
        )
        return 0
    if len(args.paths) != 2:
        raise FlexhrcError("eval takes MODEL DATA_DIR (or --cv volunteer DATA_DIR)")
    rep = evaluate(args.paths[0], args.paths[1], **dataset)
    emit(args, rep, lambda: _report_text(Path(args.paths[0]).name, rep))
    return 0


def _stream(args: argparse.Namespace) -> int:
    from flexhrc.perception.human.api import stream

    if 0 < args.speed < MIN_SPEED:
        raise FlexhrcError(
            f"--speed {args.speed:g}: give 0 (as fast as possible) or {MIN_SPEED:g} to "
            f"{MAX_SPEED:g} times real time"
        )

    def heard(r: Any, at_end: bool) -> None:
        log(
            args,
            f"[{r.t_end:8.2f} s] {r.name}  ({r.t_start:.2f}-{r.t_end:.2f} s, "
            f"confidence {r.confidence:.2f})" + ("  (end of stream)" if at_end else ""),
        )

    data = stream(args.model, args.file, speed=args.speed, stride=args.stride, on_recognition=heard)
    emit(
        args,
        data,
        f"{plural(len(data['recognised']), 'recognition')} in {data['duration_s']:.2f} s of "
        f"signal (processed in {data['processing_s']:.3f} s)",
    )
    return 0


def _synth(args: argparse.Namespace) -> int:
    from flexhrc.perception.human.api import synthesise

    check_outputs([("-o", args.output, (".csv",))], inputs=[args.model])
    data = synthesise(
        args.model, _actions(args.actions) or [], args.output, seed=args.seed, gap_s=args.gap
    )
    emit(
        args,
        data,
        lambda: "\n".join(
            [f"wrote {args.output} ({plural(data['samples'], 'sample')})"]
            + [f"  {a['name']}: {a['t_start']:.2f}-{a['t_end']:.2f} s" for a in data["actions"]]
        ),
    )
    return 0
