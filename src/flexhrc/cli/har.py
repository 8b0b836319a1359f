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

from flexhrc.cli.common import add_json_flag, emit, log
from flexhrc.errors import FlexhrcError


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
    t.add_argument("data_dir", metavar="DATA_DIR")
    t.add_argument("-o", "--output", required=True, metavar="MODEL", help="model file (.npz)")
    t.add_argument("--actions", help="comma-separated action names (default: all folders)")
    t.add_argument("--min-trials", type=int, default=1, help="skip actions with fewer trials")
    t.add_argument("--max-components", type=int, default=4, help="largest GMM tried (BIC)")
    t.add_argument("--seed", type=int, default=0)
    add_json_flag(t)
    t.set_defaults(func=_train)

    e = sub.add_parser(
        "eval",
        help="evaluate a model on a dataset, or cross-validate by volunteer",
        description="With MODEL DATA_DIR: every trial is classified by its best-matching "
        "model. With --cv volunteer DATA_DIR: leave-one-volunteer-out (or --folds K "
        "groups of volunteers) training and testing on DATA_DIR.",
    )
    e.add_argument("paths", nargs="+", metavar="MODEL DATA_DIR | DATA_DIR")
    e.add_argument("--cv", choices=["volunteer"], help="cross-validate split by volunteer")
    e.add_argument("--folds", type=int, default=None, help="volunteer groups (default: LOVO)")
    e.add_argument("--baseline", action="store_true", help="also run the summary-feature RF")
    e.add_argument("--actions", help="comma-separated action names")
    e.add_argument("--min-trials", type=int, default=1, help="skip actions with fewer trials")
    e.add_argument("--seed", type=int, default=0)
    add_json_flag(e)
    e.set_defaults(func=_eval)

    s = sub.add_parser("stream", help="replay a recording and print recognitions as they occur")
    s.add_argument("model", metavar="MODEL")
    s.add_argument("file", metavar="FILE", help="trial file: HMP .txt, .csv (g) or .npy")
    s.add_argument("--speed", type=float, default=0.0, help="replay speed (0: as fast as possible)")
    s.add_argument("--stride", type=int, default=8, help="samples between two evaluations")
    add_json_flag(s)
    s.set_defaults(func=_stream)

    y = sub.add_parser("synth", help="synthesise a wearable recording from a model")
    y.add_argument("model", metavar="MODEL")
    y.add_argument("actions", metavar="ACTION[,ACTION...]")
    y.add_argument("-o", "--output", required=True, metavar="FILE.csv")
    y.add_argument("--seed", type=int, default=0)
    y.add_argument("--gap", type=float, default=2.0, help="still seconds before each action")
    add_json_flag(y)
    y.set_defaults(func=_synth)


def _train(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, load_dataset
    from flexhrc.perception.human.dataset import summarise

    trials = load_dataset(args.data_dir, _actions(args.actions), args.min_trials)
    log(args, f"training on {len(trials)} trials: {summarise(trials)}")
    t0 = time.perf_counter()
    try:
        rec = GMMGMRRecognizer(max_components=args.max_components, random_state=args.seed)
        rec.fit(trials)
    except ValueError as exc:
        raise FlexhrcError(str(exc)) from None
    path = rec.save(args.output)
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
        lines = [f"saved {path} ({len(models)} actions, {data['seconds']} s)"]
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
        f"{title}: {rep['n_trials']} trials  accuracy {rep['accuracy']:.3f}  "
        f"macro F1 {rep['macro_f1']:.3f}"
    ]
    labels = rep["labels"]
    for lab in labels:
        pc = rep["per_class"][lab]
        lines.append(
            f"  {lab:16s} precision {pc['precision']:.2f}  recall {pc['recall']:.2f}  "
            f"n={pc['support']}"
        )
    lines.append("confusion matrix (rows: true, columns: predicted):")
    width = max(len(lab) for lab in labels)
    for lab, row in zip(labels, rep["confusion_matrix"], strict=True):
        lines.append(f"  {lab:>{width}s} " + " ".join(f"{v:4d}" for v in row))
    return "\n".join(lines)


def _progress(args: argparse.Namespace, method: str, message: str) -> None:
    log(args, f"[{method}] {message}")


def _eval(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, load_dataset
    from flexhrc.perception.human.evaluation import (
        SummaryFeatureBaseline,
        classification_report,
        cross_validate,
    )

    if args.cv:
        if len(args.paths) != 1:
            raise FlexhrcError("eval --cv volunteer takes one argument: DATA_DIR")
        trials = load_dataset(args.paths[0], _actions(args.actions), args.min_trials)
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
    trials = load_dataset(args.paths[1], _actions(args.actions), args.min_trials)
    unknown = sorted({t.action for t in trials} - set(rec.classes_))
    if unknown:
        log(args, f"note: the model has no template for {', '.join(unknown)} (counted as errors)")
    pred = rec.predict(trials)
    rep = classification_report([t.action for t in trials], pred)
    emit(args, rep, lambda: _report_text(Path(args.paths[0]).name, rep))
    return 0


def _stream(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, OnlineRecognizer, read_trial_file

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
        f"{len(found)} recognition(s) in {duration:.2f} s of signal (processed in {elapsed:.3f} s)",
    )
    return 0


def _synth(args: argparse.Namespace) -> int:
    from flexhrc.perception.human import GMMGMRRecognizer, SimulatedWearable
    from flexhrc.perception.human.dataset import save_csv

    rec = GMMGMRRecognizer.load(args.model)
    names = _actions(args.actions) or []
    wearable = SimulatedWearable(rec, seed=args.seed)
    samples, truth = wearable.sequence(names, gap_s=args.gap)
    save_csv(args.output, samples, rec.preprocessor.rate_hz)
    data = {
        "file": args.output,
        "samples": len(samples),
        "actions": [{"name": n, "t_start": round(a, 3), "t_end": round(b, 3)} for n, a, b in truth],
    }
    emit(args, data, lambda: "\n".join(
        [f"wrote {args.output} ({len(samples)} samples)"]
        + [f"  {n}: {a:.2f}-{b:.2f} s" for n, a, b in truth]))  # fmt: skip
    return 0
