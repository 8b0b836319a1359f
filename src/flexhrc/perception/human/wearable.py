"""A simulated wrist wearable that synthesises acceleration from a trained action model.

To drive the Task Manager from a *signal* rather than injected action names (and to test the
whole chain without a person), :class:`SimulatedWearable` turns an action's GMR template back
into raw acceleration: it samples a feature trajectory around the expected one with the GMR
covariance (the noise is low-pass filtered so it is smooth in time, as real deviations are),
then rebuilds the raw signal as gravity + body: the features are *filtered* quantities, so the
low-pass filters of the pre-processing are inverted first (else their lag would apply twice),
and the body part is a zero-mean oscillation whose envelope matches the modelled body energy.
Recognising the stream with the same model then works like recognising a real trial. Streams
are reproducible from ``seed``.
"""

from __future__ import annotations

import numpy as np

from flexhrc.perception._deps import require
from flexhrc.perception.human.models import GMMGMRRecognizer


def _invert_lowpass(
    target: np.ndarray, sos: np.ndarray, signal, cutoff: float, rate: float, iterations: int = 25
) -> np.ndarray:
    """Raw signal whose causal low-pass is ``target``: fixed point ``x ← x + C(target - F x)``.

    ``C`` is a zero-phase low-pass at half the filter's cutoff: the iteration converges where
    the filter's phase lag is small, and the faster content is attenuated by the filter anyway.
    """
    zi0 = signal.sosfilt_zi(sos)[:, :, None]
    corr = signal.butter(2, cutoff / 2, fs=rate, output="sos")
    x = target.copy()
    for _ in range(iterations):
        y, _ = signal.sosfilt(sos, x, axis=0, zi=zi0 * x[0][None, None, :])
        x = x + signal.sosfiltfilt(corr, target - y, axis=0, padlen=min(len(x) - 1, 30))
    return x


class SimulatedWearable:
    """Synthesises wrist-acceleration streams (``(n, 3)`` in g) for the actions of ``model``."""

    def __init__(self, model: GMMGMRRecognizer, seed: int = 0, deviation: float = 0.5):
        model._check_fitted()
        if deviation < 0:
            raise ValueError(f"deviation must be >= 0, got {deviation}")
        self.model = model
        self.rate_hz = model.preprocessor.rate_hz
        self.deviation = deviation
        self._rng = np.random.default_rng(seed)

    def stream(self, action_name: str, lead_s: float = 0.0, tail_s: float = 0.0) -> np.ndarray:
        """One execution of ``action_name`` (optionally framed by still periods), in g.

        ``deviation`` scales the sampled departure from the expected trajectory (in units of
        the GMR standard deviation; 1 reproduces the training spread).
        """
        signal = require("scipy.signal", "the simulated wearable")
        m = self.model.model(action_name)  # raises UnknownNameError with the known names
        mean, cov = m.expected()
        n, f = mean.shape
        # Temporally correlated standard normal noise (≈ 1 s correlation), rescaled to unit var.
        white = self._rng.standard_normal((n + 64, f))
        sos = signal.butter(1, 1.0, fs=self.rate_hz, output="sos")
        smooth = signal.sosfilt(sos, white, axis=0)[64:]
        smooth /= smooth.std(axis=0, keepdims=True) + 1e-12
        chol = np.linalg.cholesky(cov + 1e-9 * np.eye(f)[None])
        feats = mean + self.deviation * np.einsum("lij,lj->li", chol, smooth)
        pre = self.model.preprocessor
        # The templates hold *filtered* features; find the raw signal whose filtered version is
        # the sampled template (otherwise the filter lag is applied twice).
        rate = self.rate_hz
        gravity = _invert_lowpass(feats[:, :3], pre._sos(), signal, pre.cutoff_hz, rate)
        envelope = feats[:, 3:]
        smooth = pre._smooth_sos()
        if smooth is not None:
            envelope = _invert_lowpass(envelope, smooth, signal, 1.0 / pre.body_smoothing_s, rate)
        envelope = np.clip(envelope, 0.0, None)
        if pre.body_smoothing_s > 0:
            # The body features are the smoothed |body acceleration|. A sinusoidal carrier per
            # axis (2.5-4 Hz: arm motion, above the gravity cut-off) has a steady |.| average
            # of 2/π, so ``envelope × π/2 × carrier`` reproduces the modelled energy without
            # the fluctuations a noise carrier would add.
            t = np.arange(n) / self.rate_hz
            freq = self._rng.uniform(2.5, 4.0, 3)
            phase = self._rng.uniform(0.0, 2 * np.pi, 3)
            carrier = np.sin(2 * np.pi * freq[None, :] * t[:, None] + phase[None, :])
            body = envelope * (np.pi / 2) * carrier
        else:
            body = envelope  # signed body acceleration was modelled directly
        x = gravity + body
        lead = np.repeat(x[:1], round(lead_s * self.rate_hz), axis=0)
        tail = np.repeat(x[-1:], round(tail_s * self.rate_hz), axis=0)
        still = [seg + 0.005 * self._rng.standard_normal(seg.shape) for seg in (lead, tail)]
        return np.vstack([still[0], x, still[1]])

    def sequence(
        self, actions: list[str], gap_s: float = 2.0
    ) -> tuple[np.ndarray, list[tuple[str, float, float]]]:
        """Several actions one after another, with still gaps; returns samples and ground truth."""
        parts: list[np.ndarray] = []
        truth: list[tuple[str, float, float]] = []
        t = 0.0
        for name in actions:
            seg = self.stream(name, lead_s=gap_s)
            start = t + gap_s
            t += len(seg) / self.rate_hz
            truth.append((name, start, t))
            parts.append(seg)
        return np.vstack(parts), truth
