"""The operator's wrist signal replayed from real HMP trials (``--human-sensing har-real``).

:class:`~flexhrc.perception.human.sensing.WearableHumanSensor` synthesises the wrist signal from
the recogniser's own model, which flatters it. :class:`HmpReplaySensor` plays real recordings
instead: when the simulated operator completes an action, one recorded trial of the HMP action
that stands for it (:data:`HMP_PROXIES`: HMP has no assembly motions, so each domain action is
played by the HMP motion closest in kind — reaching for and lifting a glass for ``pick_up``,
the wrist turn of pouring for ``screw``; none stands for ``put_down`` or ``check``: those are
taken as reported, and the trace says so) is streamed through the online recogniser. The model
that runs is trained on other volunteers than those whose trials are replayed, so every
recognition is an out-of-sample one; a miss is a miss, a confusion is a false report.

The dataset is read in place (research use; never copied). Nothing here runs without it.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from flexhrc.errors import FlexhrcError
from flexhrc.perception.human.dataset import Trial, load_dataset
from flexhrc.perception.human.mapping import ActionMapping
from flexhrc.perception.human.models import GMMGMRRecognizer
from flexhrc.perception.human.online import OnlineRecognizer
from flexhrc.perception.human.sensing import Sensed, not_sensed

#: Domain action -> the HMP action whose recordings play it.
HMP_PROXIES: dict[str, str] = {"pick_up": "drink_glass", "screw": "pour_water"}
#: The volunteers the model is trained on by default (the most trials of both proxies); the
#: others' trials are replayed.
TRAIN_VOLUNTEERS: tuple[str, ...] = ("f1", "m1")


class HmpReplaySensor:
    """Replays held-out HMP trials of the action performed; recognises them online."""

    def __init__(
        self,
        hmp_dir: str | Path,
        *,
        proxies: Mapping[str, str] | None = None,
        train_volunteers: Iterable[str] = TRAIN_VOLUNTEERS,
        seed: int = 0,
        still_s: float = 0.5,
        min_confidence: float = 0.0,
    ):
        root = Path(hmp_dir)
        if not root.is_dir():
            raise FlexhrcError(f"--hmp {hmp_dir}: not a directory (the HMP dataset folder)")
        self.proxies = dict(proxies or HMP_PROXIES)
        motions = sorted(set(self.proxies.values()))
        trials = load_dataset(root, actions=motions)
        train_set = set(train_volunteers)
        train = [t for t in trials if t.volunteer in train_set]
        held = [t for t in trials if t.volunteer not in train_set]
        for m in motions:
            if not any(t.action == m for t in train):
                raise FlexhrcError(
                    f"--hmp {hmp_dir}: no {m} trial of the training volunteers "
                    f"{', '.join(sorted(train_set))}"
                )
            if not any(t.action == m for t in held):
                raise FlexhrcError(
                    f"--hmp {hmp_dir}: every {m} trial is of a training volunteer; "
                    "nothing held out to replay"
                )
        self.model = GMMGMRRecognizer(random_state=seed).fit(train)
        self.mapping = ActionMapping({m: a for a, m in self.proxies.items()}, min_confidence)
        self.train_volunteers = sorted(train_set)
        self.replay_volunteers = sorted({t.volunteer for t in held})
        rng = np.random.default_rng(seed)
        self._pool: dict[str, list[Trial]] = {}
        for m in motions:
            pool = [t for t in held if t.action == m]
            order = rng.permutation(len(pool))
            self._pool[m] = [pool[int(i)] for i in order]
        self._next: dict[str, int] = {m: 0 for m in motions}
        self.still_s = still_s
        self._rng = rng
        self.replayed: list[dict[str, Any]] = []

    def _trial(self, motion: str) -> Trial:
        k = self._next[motion]
        self._next[motion] = k + 1
        pool = self._pool[motion]
        return pool[k % len(pool)]

    def sense(self, action: str) -> Sensed:
        """The operator just did ``action``: what does its replayed wrist signal tell?"""
        motion = self.proxies.get(action)
        if motion is None:
            return not_sensed(action, "no HMP motion stands for it")
        trial = self._trial(motion)
        rate = trial.rate_hz
        n_still = round(self.still_s * rate)
        x = trial.samples
        still = [
            np.repeat(x[:1], n_still, axis=0) + 0.005 * self._rng.standard_normal((n_still, 3)),
            np.repeat(x[-1:], n_still, axis=0) + 0.005 * self._rng.standard_normal((n_still, 3)),
        ]
        samples = np.vstack([still[0], x, still[1]])
        found = [
            r
            for r in OnlineRecognizer(self.model).replay(samples)
            if self.mapping.map(r) is not None
        ]
        self.replayed.append({"action": action, "trial": Path(trial.source).name})
        if not found:
            return Sensed(action, None, None, 0.0, len(samples), 0.0)
        best = max(found, key=lambda r: r.confidence)
        end = (len(samples) - n_still) / rate
        return Sensed(
            action,
            self.mapping.map(best),
            best.name,
            float(best.confidence),
            len(samples),
            max(0.0, float(best.t_end) - end),
        )


__all__ = ["HMP_PROXIES", "TRAIN_VOLUNTEERS", "HmpReplaySensor"]
