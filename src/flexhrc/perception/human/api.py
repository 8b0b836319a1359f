"""What ``flexhrc har train | eval | stream | synth`` do, callable from Python.

Each function takes the command's arguments and returns the document the command prints with
``--json``. ``progress`` receives the lines a command writes on stderr (skipped trials, folds).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.perception.human.dataset import load_dataset, read_trial_file, save_csv, summarise
from flexhrc.perception.human.models import GMMGMRRecognizer
from flexhrc.perception.human.online import OnlineRecognizer, RecognisedAction
from flexhrc.perception.human.wearable import SimulatedWearable

Progress = Callable[[str], None]


def _quiet(message: str) -> None:
    """The default ``progress``: the lines go nowhere."""


def train(
    data_dir: str | Path,
    output: str | Path,
    *,
    actions: Sequence[str] | None = None,
    min_trials: int = 1,
    max_components: int = 4,
    seed: int = 0,
    progress: Progress = _quiet,
) -> dict[str, Any]:
    """Fit one GMM/GMR template per action of ``data_dir`` (one folder per action; ``actions``
    only, each with ``min_trials`` trials or more) and save the model to ``output`` (.npz).
    The report: the file, the seconds taken and each action's window, components, threshold."""
    from flexhrc.files import atomic_output

    trials = load_dataset(data_dir, actions, min_trials, warn=progress)
    progress(
        f"training on {len(trials)} trial{'' if len(trials) == 1 else 's'}: {summarise(trials)}"
    )
    t0 = time.perf_counter()
    try:
        rec = GMMGMRRecognizer(max_components=max_components, random_state=seed)
        rec.fit(trials)
    except ValueError as exc:
        raise FlexhrcError(str(exc)) from None
    with atomic_output(output) as tmp:
        rec.save(tmp)
    models = {
        c: {
            "length_s": round(m.length / rec.preprocessor.rate_hz, 2),
            "components": m.n_components,
            "threshold": round(m.threshold, 4),
        }
        for c, m in rec.models_.items()
    }
    return {
        "model": str(Path(output)),
        "seconds": round(time.perf_counter() - t0, 2),
        "actions": models,
    }


def evaluate(
    model: str | Path,
    data_dir: str | Path,
    *,
    actions: Sequence[str] | None = None,
    min_trials: int = 1,
    progress: Progress = _quiet,
) -> dict[str, Any]:
    """Classify every trial of ``data_dir`` by its best-matching template of ``model``: the
    :func:`~flexhrc.perception.human.evaluation.classification_report` (an action the model
    has no template for counts as errors)."""
    from flexhrc.perception.human.evaluation import classification_report

    rec = GMMGMRRecognizer.load(model)
    trials = load_dataset(data_dir, actions, min_trials, warn=progress)
    unknown = sorted({t.action for t in trials} - set(rec.classes_))
    if unknown:
        progress(f"note: the model has no template for {', '.join(unknown)} (counted as errors)")
    return classification_report([t.action for t in trials], rec.predict(trials))


def cross_validation(
    data_dir: str | Path,
    *,
    folds: int | None = None,
    baseline: bool = False,
    actions: Sequence[str] | None = None,
    min_trials: int = 1,
    seed: int = 0,
    progress: Progress = _quiet,
) -> dict[str, Any]:
    """Train and test split by volunteer: leave one volunteer out, or ``folds`` groups of
    volunteers. The report: ``split`` and a classification report per method, ``gmm_gmr`` and
    (with ``baseline``) ``baseline_rf``, the summary-feature random forest."""
    from flexhrc.perception.human.evaluation import (
        SummaryFeatureBaseline,
        classification_report,
        cross_validate,
    )

    trials = load_dataset(data_dir, actions, min_trials, warn=progress)
    volunteers = len({t.volunteer for t in trials})
    if folds is not None and folds > volunteers:
        raise FlexhrcError(
            f"--folds {folds}: the data have {volunteers} volunteer"
            f"{'' if volunteers == 1 else 's'}; give at most {volunteers}"
        )
    labels = sorted({t.action for t in trials})
    methods: list[tuple[str, Callable[[], Any]]] = [
        ("gmm_gmr", lambda: GMMGMRRecognizer(random_state=seed))
    ]
    if baseline:
        methods.append(("baseline_rf", lambda: SummaryFeatureBaseline(random_state=seed)))
    out: dict[str, Any] = {
        "split": "leave-one-volunteer-out" if folds is None else f"{folds} folds by volunteer"
    }
    for name, make in methods:
        fold_progress = functools.partial(_fold, progress, name)
        y_true, y_pred = cross_validate(trials, make, folds, progress=fold_progress)
        out[name] = classification_report(y_true, y_pred, labels)
    return out


def _fold(progress: Callable[[str], None], method: str, message: str) -> None:
    progress(f"[{method}] {message}")


def stream(
    model: str | Path,
    file: str | Path,
    *,
    speed: float = 0.0,
    stride: int = 8,
    on_recognition: Callable[[RecognisedAction, bool], None] | None = None,
) -> dict[str, Any]:
    """Replay the recording ``file`` through an online recogniser of ``model``, evaluated every
    ``stride`` samples, paced at ``speed`` times real time (0: as fast as possible).
    ``on_recognition(action, at_end)`` hears each recognition as it occurs."""
    rec = GMMGMRRecognizer.load(model)
    samples = read_trial_file(file)
    online = OnlineRecognizer(rec, stride=stride)
    rate = rec.preprocessor.rate_hz
    found: list[RecognisedAction] = []
    chunk = 8
    t0 = time.perf_counter()
    for start in [*range(0, len(samples), chunk), None]:
        if start is not None and speed > 0:  # pace the replay like a live sensor
            wait = start / rate / speed - (time.perf_counter() - t0)
            if wait > 0:
                time.sleep(wait)
        new = online.finish() if start is None else online.push(samples[start : start + chunk])
        for r in new:
            found.append(r)
            if on_recognition is not None:
                on_recognition(r, start is None)
    elapsed = time.perf_counter() - t0
    duration = len(samples) / rate
    return {
        "file": str(file),
        "duration_s": round(duration, 3),
        "processing_s": round(elapsed, 4),
        "speed_x_realtime": round(duration / elapsed, 1) if elapsed > 0 else None,
        "recognised": [r.to_dict() for r in found],
    }


def synthesise(
    model: str | Path,
    actions: Sequence[str],
    output: str | Path,
    *,
    seed: int = 0,
    gap_s: float = 2.0,
) -> dict[str, Any]:
    """Write to ``output`` (CSV) a wearable recording of ``actions`` in order, synthesised from
    the templates of ``model`` with ``gap_s`` still seconds before each. The report: the file,
    its number of samples and each action's true interval."""
    rec = GMMGMRRecognizer.load(model)
    for n in actions:
        rec.model(n)  # an unknown action: UnknownNameError naming the known ones, before work
    samples, truth = SimulatedWearable(rec, seed=seed).sequence(list(actions), gap_s=gap_s)
    save_csv(output, samples, rec.preprocessor.rate_hz)
    return {
        "file": str(output),
        "samples": len(samples),
        "actions": [{"name": n, "t_start": round(a, 3), "t_end": round(b, 3)} for n, a, b in truth],
    }
