"""Online recognition of human motion primitives from a wrist-acceleration stream.

As in Bruno et al., a sliding window of the most recent pre-processed samples is compared with
every action template. Each model has its own window length ``L`` (the median duration of its
training trials); because people perform a motion faster or slower, the window is tried at a few
scales (``0.8 L, L, 1.25 L`` by default) and time-normalised to ``L`` before matching.

An action is *reported* once per occurrence: when a model's distance falls below its threshold
it becomes the candidate; the candidate is kept while its distance keeps decreasing (or another
model matches better) and is emitted ``patience`` steps after its best match, or as soon as the
distance rises above the threshold (with ``exclusive=True`` a report also silences every other
action over the window it covers). So a replayed trial is reported shortly after it ends —
within one window length, usually a fraction of a second. The confidence is
``1 - distance / threshold`` at the best match (0 at the threshold, 1 for a perfect match).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from flexhrc.perception.human.models import GMMGMRRecognizer


@dataclass(frozen=True)
class RecognisedAction:
    """A recognised human action: name, time span (s, stream clock) and confidence in [0, 1]."""

    name: str
    t_start: float
    t_end: float
    confidence: float

    def to_dict(self) -> dict[str, float | str]:
        return {
            "name": self.name,
            "t_start": round(self.t_start, 4),
            "t_end": round(self.t_end, 4),
            "confidence": round(self.confidence, 4),
        }


@dataclass
class _Candidate:
    name: str
    score: float  # distance / threshold
    t_start: float
    t_end: float
    age: int = 0


class OnlineRecognizer:
    """Sliding-window recogniser over a stream (feed it with :meth:`push`).

    ``stride`` is the number of samples between two evaluations, ``scales`` the window lengths
    tried relative to each model's length, ``patience`` the number of evaluations without
    improvement after which the candidate is reported. ``t0`` is the time of the first sample.
    """

    def __init__(
        self,
        recognizer: GMMGMRRecognizer,
        stride: int = 8,
        scales: Sequence[float] = (0.8, 1.0, 1.25),
        patience: int = 4,
        t0: float = 0.0,
        exclusive: bool = False,
    ):
        recognizer._check_fitted()
        if stride < 1:
            raise ValueError(f"stride must be >= 1, got {stride}")
        if not scales or min(scales) <= 0:
            raise ValueError(f"scales must be positive, got {scales!r}")
        if patience < 1:
            raise ValueError(f"patience must be >= 1, got {patience}")
        self.recognizer = recognizer
        self.stride = stride
        self.scales = tuple(scales)
        self.patience = patience
        self.exclusive = exclusive
        self.rate_hz = recognizer.preprocessor.rate_hz
        self._pre = recognizer.preprocessor.stream()
        self._classes = recognizer.classes_
        self._models = [recognizer.models_[c] for c in self._classes]
        self._thresholds = recognizer.thresholds()
        self._lengths = [
            sorted({max(4, round(m.length * s)) for s in self.scales}) for m in self._models
        ]
        self._max_len = max(max(ls) for ls in self._lengths)
        self._buf = np.empty((0, 6))
        self._n = 0  # samples seen
        self._since_eval = 0
        self._t0 = t0
        self._candidate: _Candidate | None = None
        self._last: dict[str, float] = {}  # action -> t_end of its last report

    # ------------------------------------------------------------------------------ stream
    def push(self, samples: np.ndarray) -> list[RecognisedAction]:
        """Feed raw samples ``(n, 3)`` in g; returns the actions recognised meanwhile."""
        feats = self._pre.push(samples)
        out: list[RecognisedAction] = []
        while len(feats):
            need = self.stride - self._since_eval
            if len(feats) < need:
                self._since_eval += len(feats)
                self._append(feats)
                break
            self._append(feats[:need])
            feats = feats[need:]
            self._since_eval = 0
            out.extend(self._evaluate())
        return out

    def finish(self) -> list[RecognisedAction]:
        """End of stream: report the pending candidate, if any."""
        return self._emit() if self._candidate is not None else []

    def replay(self, samples: np.ndarray, chunk: int = 32) -> list[RecognisedAction]:
        """Feed a whole recording chunk by chunk (as a live stream would) and finish it."""
        out: list[RecognisedAction] = []
        for start in range(0, len(samples), chunk):
            out.extend(self.push(samples[start : start + chunk]))
        out.extend(self.finish())
        return out

    # ---------------------------------------------------------------------------- internals
    def _append(self, feats: np.ndarray) -> None:
        if len(feats) == 0:
            return
        self._buf = np.vstack([self._buf, feats])[-self._max_len :]
        self._n += len(feats)

    def _now(self) -> float:
        return self._t0 + self._n / self.rate_hz

    def _evaluate(self) -> list[RecognisedAction]:
        now = self._now()
        best: tuple[float, int, int] | None = None  # (score, class index, window length)
        for k, (model, lengths) in enumerate(zip(self._models, self._lengths, strict=True)):
            for n in lengths:
                if n > len(self._buf):
                    continue
                score = model.distance(self._buf[-n:]) / self._thresholds[k]
                if best is None or score < best[0]:
                    best = (score, k, n)
        out: list[RecognisedAction] = []
        cand = self._candidate
        if cand is not None:
            cand.age += 1
        if best is not None and best[0] < 1.0:
            score, k, n = best
            name = self._classes[k]
            t_start = now - n / self.rate_hz
            recent = self._last.get("*" if self.exclusive else name)
            # One report per occurrence: ignore a match that mostly overlaps the last report.
            fresh = recent is None or t_start >= recent - 0.5 * n / self.rate_hz
            if fresh and (cand is None or score < cand.score):
                if cand is not None and cand.name != name and t_start >= cand.t_end:
                    out.extend(self._emit())  # a new action after the candidate: emit it
                self._candidate = _Candidate(name, score, t_start, now)
                return out
        if cand is not None and (cand.age >= self.patience or best is None or best[0] >= 1.0):
            out.extend(self._emit())
        return out

    def _emit(self) -> list[RecognisedAction]:
        cand = self._candidate
        self._candidate = None
        if cand is None:
            return []
        self._last[cand.name] = cand.t_end
        self._last["*"] = cand.t_end
        conf = float(np.clip(1.0 - cand.score, 0.0, 1.0))
        return [RecognisedAction(cand.name, cand.t_start, cand.t_end, conf)]
