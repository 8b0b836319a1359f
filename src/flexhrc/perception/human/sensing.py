"""The operator's actions, sensed from a wrist-worn inertial sensor (paper 000, III and VI-D).

In the FlexHRC+ experiments the operator wears a smartwatch; the Task Manager learns what the
operator did from the recognised motion primitive, not from a button. :class:`WearableHumanSensor`
closes that loop in simulation: when the simulated operator completes an action (``pick_up``,
``screw`` ...), the sensor

1. synthesises the wrist signal of that motion from a trained GMM/GMR model
   (:class:`SimulatedWearable`: the GMR trajectory sampled with its covariance),
2. replays it through the :class:`OnlineRecognizer` (sliding windows, Mahalanobis distances),
3. maps the recognised primitive to the Task Manager's human action (:class:`ActionMapping`).

The object the action was about (which leg) is not in a wrist signal: it comes from scene
perception — here, from the simulated world. Without a model, one is trained on the packaged
synthetic motions (``pick_up``, ``put_down``, ``screw``, ``wave``; no dataset needed).

An action no motion of the model plays (the operator's visual ``check`` of a connection) is not
sensed: :class:`Sensed` says why (:func:`not_sensed`, e.g. ``check: no wrist model, taken as
reported``) and the report goes to the Task Manager as the operator made it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

from flexhrc.perception.human.mapping import ActionMapping
from flexhrc.perception.human.models import GMMGMRRecognizer
from flexhrc.perception.human.online import OnlineRecognizer
from flexhrc.perception.human.wearable import SimulatedWearable

TABLE_ACTIONS = ("pick_up", "put_down", "screw")


@dataclass
class Sensed:
    """What the sensor made of one performed action."""

    performed: str
    recognised: str | None  # Task-Manager action name, None when nothing was recognised
    motion: str | None  # recognised motion primitive
    confidence: float
    samples: int
    latency_s: float  # from the end of the motion to the recognition
    why: str | None = None  # why the action was not sensed at all (no motion plays it)

    def to_dict(self) -> dict[str, Any]:
        rounded = {"confidence": round(self.confidence, 4), "latency_s": round(self.latency_s, 4)}
        out = {**asdict(self), **rounded}
        if out["why"] is None:  # (the figures of a sensed action keep their shape)
            del out["why"]
        return out


def not_sensed(action: str, detail: str = "") -> Sensed:
    """What a sensor says of an action no motion of its model plays: nothing recognised, no
    sample, and why — the report is taken as the operator made it (an ``uncovered`` action)."""
    why = f"{action}: no wrist model, taken as reported{f' ({detail})' if detail else ''}"
    return Sensed(action, None, None, 0.0, 0, 0.0, why)


def train_toy_model(seed: int = 0) -> GMMGMRRecognizer:
    """A recogniser of the packaged synthetic assembly motions."""
    from flexhrc.perception.human.synthetic import toy_dataset

    return GMMGMRRecognizer(random_state=seed).fit(toy_dataset(seed=seed))


class WearableHumanSensor:
    """Turns performed human actions into recognised ones through a synthesised wrist signal."""

    def __init__(
        self,
        model: GMMGMRRecognizer | None = None,
        mapping: ActionMapping | Mapping[str, str] | None = None,
        *,
        seed: int = 0,
        still_s: float = 0.5,
    ):
        self.model = model if model is not None else train_toy_model(seed)
        if mapping is None:
            known = [a for a in TABLE_ACTIONS if a in self.model.classes_]
            mapping = ActionMapping.identity(known)
        elif not isinstance(mapping, ActionMapping):
            mapping = ActionMapping.from_dict(dict(mapping))
        self.mapping = mapping
        # which motion to synthesise for a Task-Manager action (the inverse mapping)
        self._motion_of = {task: motion for motion, task in mapping.mapping.items()}
        self.wearable = SimulatedWearable(self.model, seed=seed)
        self.still_s = still_s

    def sense(self, action: str) -> Sensed:
        """The operator just did ``action``: what does the wrist sensor tell?"""
        motion = self._motion_of.get(action)
        if motion is None:
            return not_sensed(action)
        samples = self.wearable.stream(motion, lead_s=self.still_s, tail_s=self.still_s)
        online = OnlineRecognizer(self.model)
        found = [r for r in online.replay(samples) if r.name in self.mapping.mapping]
        found = [r for r in found if r.confidence >= self.mapping.min_confidence]
        if not found:
            return Sensed(action, None, None, 0.0, len(samples), 0.0)
        best = max(found, key=lambda r: r.confidence)
        end_of_motion = len(samples) / self.wearable.rate_hz - self.still_s
        return Sensed(
            action,
            self.mapping.mapping[best.name],
            best.name,
            float(best.confidence),
            len(samples),
            max(0.0, float(best.t_end) - end_of_motion),
        )
