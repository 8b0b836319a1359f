"""Pre-processing of wrist acceleration: gravity and body components.

Following Bruno et al. (ICRA 2013, "Analysis of human behavior recognition algorithms based on
acceleration data"), the raw tri-axial signal is first median-filtered (the 6-bit sensor has
spikes) and then split by a low-pass filter into

* the **gravity** component — the slowly varying direction of gravity in the wrist frame, i.e.
  the orientation of the forearm (drinking raises it, lying down turns it), and
* the **body** component — raw minus gravity, the acceleration the person imparts.

The filters are *causal* (``sosfilt`` with the state initialised on the first sample) so the
exact same features are computed offline on a whole trial and online on a stream, one chunk at a
time: a model trained on batch features sees the same numbers when it is used live.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexhrc.perception._deps import require


@dataclass(frozen=True)
class Preprocessor:
    """Median filter + Butterworth low-pass split into gravity and body acceleration.

    ``features(x)`` returns ``(n, 6)``: gravity xyz then body xyz, in g. ``body_smoothing_s``
    > 0 replaces the signed body acceleration with its smoothed magnitude per axis (an energy
    envelope), which does not depend on the phase of periodic motions such as walking.
    """

    rate_hz: float = 32.0
    cutoff_hz: float = 1.0
    order: int = 2
    median: int = 3
    body_smoothing_s: float = 2.0

    def __post_init__(self) -> None:
        if not 0 < self.cutoff_hz < self.rate_hz / 2:
            raise ValueError(f"cutoff_hz must be in (0, {self.rate_hz / 2}), got {self.cutoff_hz}")
        if self.median < 1 or self.median % 2 == 0:
            raise ValueError(f"median must be a positive odd integer, got {self.median}")

    def _sos(self) -> np.ndarray:
        signal = require("scipy.signal", "human action recognition")
        return signal.butter(self.order, self.cutoff_hz, fs=self.rate_hz, output="sos")

    def _smooth_sos(self) -> np.ndarray | None:
        if self.body_smoothing_s <= 0:
            return None
        signal = require("scipy.signal", "human action recognition")
        return signal.butter(1, 1.0 / self.body_smoothing_s, fs=self.rate_hz, output="sos")

    def features(self, samples: np.ndarray) -> np.ndarray:
        """Features of a whole trial (the same as streaming it through :meth:`stream`)."""
        state = self.stream()
        return state.push(samples)

    def stream(self) -> StreamingPreprocessor:
        """A stateful pre-processor for online use."""
        return StreamingPreprocessor(self)


class StreamingPreprocessor:
    """Causal, chunk-by-chunk version of :class:`Preprocessor` (identical output)."""

    def __init__(self, pre: Preprocessor):
        self.pre = pre
        self._signal = require("scipy.signal", "human action recognition")
        self._sos = pre._sos()
        self._smooth = pre._smooth_sos()
        self._zi: np.ndarray | None = None
        self._zs: np.ndarray | None = None
        self._tail = np.empty((0, 3))

    def push(self, samples: np.ndarray) -> np.ndarray:
        x = np.asarray(samples, dtype=float).reshape(-1, 3)
        if len(x) == 0:
            return np.empty((0, 6))
        k = self.pre.median // 2
        if k:
            # Causal running median over the last `median` samples (edge-padded at the start).
            if self._tail.shape[0] == 0:
                self._tail = np.repeat(x[:1], 2 * k, axis=0)
            ext = np.vstack([self._tail, x])
            win = np.lib.stride_tricks.sliding_window_view(ext, 2 * k + 1, axis=0)
            filtered = np.median(win, axis=-1)
            self._tail = ext[-2 * k :]
        else:
            filtered = x
        if self._zi is None:
            zi = self._signal.sosfilt_zi(self._sos)  # (sections, 2), unit step steady state
            self._zi = zi[:, :, None] * filtered[0][None, None, :]
        gravity, self._zi = self._signal.sosfilt(self._sos, filtered, axis=0, zi=self._zi)
        body = filtered - gravity
        if self._smooth is not None:
            mag = np.abs(body)
            if self._zs is None:
                zs = self._signal.sosfilt_zi(self._smooth)
                self._zs = zs[:, :, None] * mag[0][None, None, :]
            body, self._zs = self._signal.sosfilt(self._smooth, mag, axis=0, zi=self._zs)
        return np.hstack([gravity, body])


def resample(x: np.ndarray, length: int) -> np.ndarray:
    """Linear time normalisation of ``x`` (n, d) to ``length`` samples."""
    x = np.asarray(x, dtype=float)
    if len(x) == length:
        return x
    if len(x) == 1:
        return np.repeat(x, length, axis=0)
    src = np.linspace(0.0, 1.0, len(x))
    dst = np.linspace(0.0, 1.0, length)
    return np.column_stack([np.interp(dst, src, x[:, j]) for j in range(x.shape[1])])
