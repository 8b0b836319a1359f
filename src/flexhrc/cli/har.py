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
import functools
import time
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
    plural,
    progress,
    seed_type,
)
from flexhrc.errors import FlexhrcError

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
    t.add_argument("--actions", help="comma-separated action names (default: all folders)")
    t.add_argument(
        "--min-trials",
        type=int_range(1, 100_000),
        default=1,
        help="skip actions with fewer trials (default 1)",
    )
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
    e.add_argument("--actions", help="comma-separated action names")
    e.add_argument(
        "--min-trials",
        type=int_range(1, 100_000),
        default=1,
        help="skip actions with fewer trials (default 1)",
    )
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
    from flexhrc.files import atomic_output
    from flexhrc.perception.human import GMMGMRRecognizer, load_dataset
    from flexhrc.perception.human.dataset import summarise

    check_outputs([("-o", args.output, (".npz",))])
    trials = load_dataset(args.data_dir, _actions(args.actions), args.min_trials, warn=progress)
    progress(f"training on {plural(len(trials), 'trial')}: {summarise(trials)}")
    t0 = time.perf_counter()
    try:
        rec = GMMGMRRecognizer(max_components=args.max_components, random_state=args.seed)
        rec.fit(trials)
    except ValueError as exc:
        raise FlexhrcError(str(exc)) from None
    with atomic_output(args.output) as tmp:
        rec.save(tmp)
    path = Path(args.output)
    models = {
        c: {
            "length_s": round(m.length / rec.preprocessor.rate_hz, 2),
            "components": m.n_components,
            "threshold": round(m.threshold, 4),
        }
        for c, m in rec.models_.items()
    }
    data = {"model": str(path), "seconds": round(time.perf_counter() - t0, 2), "actions": models}

    def text() -> str:
        lines = [f"saved {path} ({plural(len(models), 'action')}, {data['seconds']} s)"]
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


def _progress(args: argparse.Namespace, method: str, message: str) -> None:
    progress(f"[{method}] {message}")


def _eval(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, load_dataset
    from flexhrc.perception.human.evaluation import (
        SummaryFeatureBaseline,
        classification_report,
        cross_validate,
    )

    needs(args, "--folds", args.folds is not None, "--cv volunteer", bool(args.cv))
    needs(args, "--baseline", args.baseline, "--cv volunteer", bool(args.cv))
    if args.cv:
        if len(args.paths) != 1:
            raise FlexhrcError("eval --cv volunteer takes one argument: DATA_DIR")
        trials = load_dataset(args.paths[0], _actions(args.actions), args.min_trials, warn=progress)
        volunteers = len({t.volunteer for t in trials})
        if args.folds is not None and args.folds > volunteers:
            raise FlexhrcError(
                f"--folds {args.folds}: the data have {plural(volunteers, 'volunteer')}; "
                f"give at most {volunteers}"
            )
        labels = sorted({t.action for t in trials})
        methods: list[tuple[str, Any]] = [
            ("gmm_gmr", lambda: GMMGMRRecognizer(random_state=args.seed))
        ]
        if args.baseline:
            methods.append(("baseline_rf", lambda: SummaryFeatureBaseline(random_state=args.seed)))
        out: dict = {"split": "leave-one-volunteer-out" if args.folds is None else
                     f"{args.folds} folds by volunteer"}  # fmt: skip
        for name, make in methods:
            y_true, y_pred = cross_validate(
                trials, make, args.folds, progress=functools.partial(_progress, args, name)
            )
            out[name] = classification_report(y_true, y_pred, labels)
        emit(
            args,
            out,
            lambda: "\n\n".join(
                [f"split: {out['split']}"] + [_report_text(name, out[name]) for name, _ in methods]
            ),
        )
        return 0
    if len(args.paths) != 2:
        raise FlexhrcError("eval takes MODEL DATA_DIR (or --cv volunteer DATA_DIR)")
    rec = GMMGMRRecognizer.load(args.paths[0])
    trials = load_dataset(args.paths[1], _actions(args.actions), args.min_trials, warn=progress)
    unknown = sorted({t.action for t in trials} - set(rec.classes_))
    if unknown:
        progress(f"note: the model has no template for {', '.join(unknown)} (counted as errors)")
    pred = rec.predict(trials)
    rep = classification_report([t.action for t in trials], pred)
    emit(args, rep, lambda: _report_text(Path(args.paths[0]).name, rep))
    return 0


def _stream(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, OnlineRecognizer, read_trial_file

    if 0 < args.speed < MIN_SPEED:
        raise FlexhrcError(
            f"--speed {args.speed:g}: give 0 (as fast as possible) or {MIN_SPEED:g} to "
            f"{MAX_SPEED:g} times real time"
        )
    rec = GMMGMRRecognizer.load(args.model)
    samples = read_trial_file(args.file)
    online = OnlineRecognizer(rec, stride=args.stride)
    rate = rec.preprocessor.rate_hz
    found = []
    chunk = 8
    t0 = time.perf_counter()
    for start in range(0, len(samples), chunk):
        if args.speed > 0:  # pace the replay like a live sensor (speed x real time)
            due = start / rate / args.speed
            wait = due - (time.perf_counter() - t0)
            if wait > 0:
                time.sleep(wait)
        for r in online.push(samples[start : start + chunk]):
            found.append(r)
            log(args, f"[{r.t_end:8.2f} s] {r.name}  ({r.t_start:.2f}-{r.t_end:.2f} s, "
                      f"confidence {r.confidence:.2f})")  # fmt: skip
    for r in online.finish():
        found.append(r)
        log(args, f"[{r.t_end:8.2f} s] {r.name}  ({r.t_start:.2f}-{r.t_end:.2f} s, "
                  f"confidence {r.confidence:.2f})  (end of stream)")  # fmt: skip
    elapsed = time.perf_counter() - t0
    duration = len(samples) / rate
    data = {
        "file": args.file,
        "duration_s": round(duration, 3),
        "processing_s": round(elapsed, 4),
        "speed_x_realtime": round(duration / elapsed, 1) if elapsed > 0 else None,
        "recognised": [r.to_dict() for r in found],
    }
    emit(
        args,
        data,
        f"{plural(len(found), 'recognition')} in {duration:.2f} s of signal "
        f"(processed in {elapsed:.3f} s)",
    )
    return 0


def _synth(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, SimulatedWearable
    from flexhrc.perception.human.dataset import save_csv

    check_outputs([("-o", args.output, (".csv",))], inputs=[args.model])
    rec = GMMGMRRecognizer.load(args.model)
    names = _actions(args.actions) or []
    for n in names:
        rec.model(n)  # an unknown action: UnknownNameError naming the known ones, before work
    wearable = SimulatedWearable(rec, seed=args.seed)
    samples, truth = wearable.sequence(names, gap_s=args.gap)
    save_csv(args.output, samples, rec.preprocessor.rate_hz)
    data = {
        "file": args.output,
        "samples": len(samples),
        "actions": [{"name": n, "t_start": round(a, 3), "t_end": round(b, 3)} for n, a, b in truth],
    }
    emit(args, data, lambda: "\n".join(
        [f"wrote {args.output} ({plural(len(samples), 'sample')})"]
        + [f"  {n}: {a:.2f}-{b:.2f} s" for n, a, b in truth]))  # fmt: skip
    return 0
