"""Evaluation of action recognisers: metrics, volunteer-wise cross-validation and a baseline.

Trials of the same volunteer are strongly correlated, so HMP results are only meaningful when
training and test volunteers differ: :func:`cross_validate` runs leave-one-volunteer-out (or a
k-fold split by volunteer), never a split by trial. :class:`SummaryFeatureBaseline` is the
simple comparison the issue asks for: a random forest over per-trial summary statistics.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from flexhrc.errors import FlexhrcError
from flexhrc.perception._deps import require
from flexhrc.perception.human.dataset import Trial


def classification_report(
    y_true: Sequence[str], y_pred: Sequence[str], labels: Sequence[str] | None = None
) -> dict[str, Any]:
    """``accuracy``, ``macro_f1``, per-class precision/recall/F1/support, confusion matrix."""
    if len(y_true) != len(y_pred):
        raise ValueError(f"{len(y_true)} labels but {len(y_pred)} predictions")
    labels = list(labels) if labels is not None else sorted(set(y_true) | set(y_pred))
    index = {lab: i for i, lab in enumerate(labels)}
    cm = np.zeros((len(labels), len(labels)), dtype=int)
    for t, p in zip(y_true, y_pred, strict=True):
        cm[index[t], index[p]] += 1
    per_class: dict[str, dict[str, float]] = {}
    f1s = []
    for i, lab in enumerate(labels):
        tp = cm[i, i]
        prec = tp / cm[:, i].sum() if cm[:, i].sum() else 0.0
        rec = tp / cm[i].sum() if cm[i].sum() else 0.0
        f1 = 2 * prec * rec / (prec + rec) if prec + rec else 0.0
        per_class[lab] = {
            "precision": round(float(prec), 4),
            "recall": round(float(rec), 4),
            "f1": round(float(f1), 4),
            "support": int(cm[i].sum()),
        }
        if cm[i].sum():
            f1s.append(f1)
    n = int(cm.sum())
    return {
        "n_trials": n,
        "accuracy": round(float(np.trace(cm) / n), 4) if n else 0.0,
        "macro_f1": round(float(np.mean(f1s)), 4) if f1s else 0.0,
        "labels": labels,
        "per_class": per_class,
        "confusion_matrix": cm.tolist(),
    }


def volunteer_folds(trials: Sequence[Trial], n_folds: int | None = None) -> list[list[str]]:
    """Groups of test volunteers: one per volunteer (``None``), or ``n_folds`` balanced groups."""
    vols = sorted({t.volunteer for t in trials})
    if len(vols) < 2:
        raise FlexhrcError(
            f"a split by volunteer needs at least 2 volunteers, found {len(vols)} ({vols})"
        )
    if n_folds is None or n_folds >= len(vols):
        return [[v] for v in vols]
    if n_folds < 2:
        raise ValueError(f"n_folds must be >= 2, got {n_folds}")
    # Greedy balancing by number of trials (largest volunteer first), deterministic.
    counts = {v: sum(t.volunteer == v for t in trials) for v in vols}
    folds: list[list[str]] = [[] for _ in range(n_folds)]
    sizes = [0] * n_folds
    for v in sorted(vols, key=lambda v: (-counts[v], v)):
        i = int(np.argmin(sizes))
        folds[i].append(v)
        sizes[i] += counts[v]
    return [sorted(f) for f in folds]


def cross_validate(
    trials: Sequence[Trial],
    make_model: Callable[[], Any],
    n_folds: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> tuple[list[str], list[str]]:
    """Volunteer-wise cross-validation: returns ``(y_true, y_pred)`` over all test trials.

    ``make_model()`` returns an unfitted object with ``fit(trials)`` and ``predict(trials)``.
    A test volunteer's action that no training volunteer performed cannot be predicted, so
    such folds train on all actions of the others (the trial will count as an error).
    """
    y_true: list[str] = []
    y_pred: list[str] = []
    for fold in volunteer_folds(trials, n_folds):
        train = [t for t in trials if t.volunteer not in fold]
        test = [t for t in trials if t.volunteer in fold]
        model = make_model().fit(train)
        y_pred.extend(model.predict(test))
        y_true.extend(t.action for t in test)
        if progress:
            progress(f"fold {','.join(fold)}: {len(train)} train / {len(test)} test trials")
    return y_true, y_pred


def summary_features(samples: np.ndarray, rate_hz: float = 32.0) -> np.ndarray:
    """Per-axis mean, std, min, max, first and last second means, and the duration (s)."""
    x = np.asarray(samples, dtype=float)
    k = max(1, int(rate_hz))
    parts = [
        x.mean(0),
        x.std(0),
        x.min(0),
        x.max(0),
        x[:k].mean(0),
        x[-k:].mean(0),
        np.abs(np.diff(x, axis=0)).mean(0) if len(x) > 1 else np.zeros(3),
        [len(x) / rate_hz],
    ]
    return np.concatenate([np.ravel(p) for p in parts])


class SummaryFeatureBaseline:
    """Baseline: a random forest on :func:`summary_features` (scikit-learn)."""

    def __init__(self, n_estimators: int = 200, random_state: int = 0):
        self.n_estimators = n_estimators
        self.random_state = random_state

    def fit(self, trials: Sequence[Trial]) -> SummaryFeatureBaseline:
        ensemble = require("sklearn.ensemble", "the summary-feature baseline")
        X = np.stack([summary_features(t.samples, t.rate_hz) for t in trials])
        y = [t.action for t in trials]
        self.clf_ = ensemble.RandomForestClassifier(
            n_estimators=self.n_estimators, random_state=self.random_state, n_jobs=1
        ).fit(X, y)
        return self

    def predict(self, trials: Sequence[Trial]) -> list[str]:
        X = np.stack([summary_features(t.samples, t.rate_hz) for t in trials])
        return [str(p) for p in self.clf_.predict(X)]
