"""Synthetic wrist-acceleration trials, for examples and tests without the HMP dataset.

Each toy action is a motion of the forearm (a rotation of the gravity direction in the wrist
frame) with a characteristic body-acceleration energy; every "volunteer" performs it at their
own speed and amplitude, with sensor noise, so a split by volunteer is meaningful. Files are
written in the user CSV format (``t,ax,ay,az`` in s and g), one folder per action.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexhrc.perception.human.dataset import HMP_RATE_HZ, Trial, save_csv

#: Toy actions: (start gravity direction, end gravity direction, body shaking (g), duration s).
_Vec = tuple[float, float, float]
TOY_ACTIONS: dict[str, tuple[_Vec, _Vec, float, float]] = {
    "pick_up": ((0.0, 0.0, -1.0), (-0.7, 0.0, -0.7), 0.05, 3.0),
    "put_down": ((-0.7, 0.0, -0.7), (0.0, 0.0, -1.0), 0.05, 3.0),
    "screw": ((-1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), 0.35, 4.0),
    "wave": ((0.0, 1.0, 0.0), (0.0, -1.0, 0.0), 0.15, 2.5),
}  # fmt: skip


def _slerp(a: np.ndarray, b: np.ndarray, s: np.ndarray) -> np.ndarray:
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    omega = np.arccos(np.clip(a @ b, -1.0, 1.0))
    if omega < 1e-6:
        return np.repeat(a[None], len(s), axis=0)
    return (np.sin((1 - s) * omega)[:, None] * a + np.sin(s * omega)[:, None] * b) / np.sin(omega)


def toy_trial(
    action: str, rng: np.random.Generator, speed: float = 1.0, volunteer: str = "v1"
) -> Trial:
    """One execution of a toy action (``speed`` > 1 is faster)."""
    g0, g1, shake, duration = TOY_ACTIONS[action]
    n = max(16, round(duration / speed * HMP_RATE_HZ * rng.uniform(0.9, 1.1)))
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, n))  # smooth start and stop
    gravity = _slerp(np.asarray(g0, float), np.asarray(g1, float), s)
    if action == "wave":  # a back-and-forth swing: the gravity path goes out and back
        gravity = _slerp(np.asarray(g0, float), np.asarray(g1, float), np.sin(np.pi * s))
    t = np.arange(n) / HMP_RATE_HZ
    freq = rng.uniform(2.0, 3.0)
    body = (
        shake
        * np.sin(2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi))[:, None]
        * rng.normal(1.0, 0.2, 3)
    )
    x = gravity + body + rng.normal(0.0, 0.02, (n, 3))
    return Trial(action, np.clip(x, -1.5, 1.5), volunteer)


def toy_dataset(seed: int = 0, n_volunteers: int = 4, trials_per_volunteer: int = 3) -> list[Trial]:
    """Trials of every toy action by ``n_volunteers`` volunteers (``v1``, ``v2``...)."""
    rng = np.random.default_rng(seed)
    out = []
    for v in range(1, n_volunteers + 1):
        speed = rng.uniform(0.85, 1.15)
        for action in TOY_ACTIONS:
            for _ in range(trials_per_volunteer):
                out.append(toy_trial(action, rng, speed, f"v{v}"))
    return out


def write_toy_dataset(root: str | Path, seed: int = 0, **kwargs: int) -> Path:
    """Write :func:`toy_dataset` as ``root/<action>/<action>-<k>-<volunteer>.csv``."""
    root = Path(root)
    counters: dict[str, int] = {}
    for trial in toy_dataset(seed, **kwargs):
        folder = root / trial.action
        folder.mkdir(parents=True, exist_ok=True)
        k = counters.get(trial.action, 0) + 1
        counters[trial.action] = k
        save_csv(folder / f"{trial.action}-{k:03d}-{trial.volunteer}.csv", trial.samples)
    return root
