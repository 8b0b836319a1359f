"""Reading wrist-acceleration trials: the HMP dataset layout and a simple user format.

The *Public Dataset of Accelerometer Data for Human Motion Primitives Detection* (Bruno et al.,
ICRA 2013) keeps one folder per action (``Climb_stairs/``, ...) holding one text file per trial
named ``Accelerometer-YYYY-MM-DD-HH-MM-SS-<action>-<volunteer>.txt``. Each line has three
integers 0..63 coding -1.5 g..+1.5 g (x toward the hand, y to the left, z out of the hand's
back), sampled at 32 Hz.

User data follow the same folder-per-action layout with either

* ``.csv`` files: three float columns ``ax,ay,az`` in g (a header line is allowed, and an
  optional leading ``t`` column in seconds is ignored apart from its header), or
* ``.npy`` files: a float array of shape ``(n, 3)`` in g.

The volunteer of a user trial is the last ``-``-separated token of its file stem (``walk-01-m2``
→ ``m2``), so evaluation by volunteer works the same way. Action names are the folder names
lower-cased. All readers return accelerations in g.
"""

from __future__ import annotations

import csv
import re
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from flexhrc.errors import FlexhrcError, FormatError, UnknownNameError
from flexhrc.perception._io import load_npy

#: Sampling rate of the HMP dataset (Hz).
HMP_RATE_HZ = 32.0
#: Fewer samples than this cannot be resampled into a template: an error.
MIN_TRIAL_SAMPLES = 4
#: Trials shorter than this (seconds) are suspicious: a warning.
MIN_TRIAL_S = 0.5

#: The seven HMP actions with at least 20 trials (the evaluation set of the issue).
HMP_SEVEN: tuple[str, ...] = (
    "climb_stairs",
    "drink_glass",
    "getup_bed",
    "pour_water",
    "sitdown_chair",
    "standup_chair",
    "walk",
)

_HMP_NAME = re.compile(r"^Accelerometer-\d{4}(?:-\d{2}){5}-(?P<action>[a-z_]+)-(?P<vol>[mf]\d+)$")
_TRIAL_SUFFIXES = (".txt", ".csv", ".npy")


@dataclass(frozen=True)
class Trial:
    """One recorded execution of an action: wrist acceleration in g, shape ``(n, 3)``."""

    action: str
    samples: np.ndarray
    volunteer: str = "unknown"
    rate_hz: float = HMP_RATE_HZ
    source: str = field(default="<memory>", compare=False)

    def __post_init__(self) -> None:
        arr = np.asarray(self.samples, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 3:
            raise FormatError(
                f"expected an (n, 3) acceleration array, got {arr.shape}", self.source
            )
        object.__setattr__(self, "samples", arr)

    @property
    def duration_s(self) -> float:
        return len(self.samples) / self.rate_hz


def decode_hmp(coded: np.ndarray) -> np.ndarray:
    """HMP coding → g: ``real = -1.5 g + coded / 63 * 3 g`` (MANUAL.txt, 4.2)."""
    return -1.5 + np.asarray(coded, dtype=float) / 63.0 * 3.0


def _read_hmp_txt(path: Path) -> np.ndarray:
    from flexhrc.files import read_text

    rows: list[list[int]] = []
    for lineno, line in enumerate(read_text(path).split("\n"), start=1):
        text = line.strip()
        if not text:
            continue
        parts = text.split()
        if len(parts) != 3:
            raise FormatError(f"expected 3 integers, got {len(parts)} fields", path, lineno)
        try:
            values = [int(p) for p in parts]
        except ValueError:
            raise FormatError(f"not an integer in {text!r}", path, lineno) from None
        if any(v < 0 or v > 63 for v in values):
            raise FormatError(f"HMP codes must be in 0..63, got {text!r}", path, lineno)
        rows.append(values)
    if not rows:
        raise FormatError("no samples", path)
    return decode_hmp(np.asarray(rows))


def _read_csv(path: Path) -> np.ndarray:
    from flexhrc.files import read_text

    rows: list[list[float]] = []
    columns: slice = slice(0, 3)
    text = read_text(path)
    for lineno, row in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in row]
        if not cells or all(not c for c in cells) or cells[0].startswith("#"):
            continue
        if lineno == 1 and not _is_number(cells[0]):
            header = [c.lower() for c in cells]
            if header[:1] == ["t"]:
                columns = slice(1, 4)
            if len(header[columns]) != 3:
                raise FormatError("header must name three acceleration columns", path, lineno)
            continue
        values = cells[columns]
        if len(values) != 3:
            raise FormatError(f"expected 3 acceleration values, got {len(values)}", path, lineno)
        try:
            rows.append([float(v) for v in values])
        except ValueError:
            raise FormatError(f"not a number in {','.join(cells)!r}", path, lineno) from None
    if not rows:
        raise FormatError("no samples", path)
    arr = np.asarray(rows)
    if not np.all(np.isfinite(arr)):
        raise FormatError("non-finite acceleration value", path)
    return arr


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_trial_file(path: str | Path) -> np.ndarray:
    """Read one trial file (HMP ``.txt``, ``.csv`` or ``.npy``) as an ``(n, 3)`` array in g."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".txt":
        return _read_hmp_txt(path)
    if suffix == ".csv":
        return _read_csv(path)
    if suffix == ".npy":
        arr = load_npy(path)
        if arr.ndim != 2 or arr.shape[1] != 3 or not np.issubdtype(arr.dtype, np.number):
            raise FormatError(f"expected a numeric (n, 3) array, got {arr.shape}", path)
        if len(arr) == 0:
            raise FormatError("no samples", path)
        arr = arr.astype(float)
        if not np.all(np.isfinite(arr)):
            bad = int(np.argmax(~np.all(np.isfinite(arr), axis=1)))
            raise FormatError(f"non-finite acceleration value (sample {bad})", path)
        return arr
    if not path.exists():
        raise FlexhrcError(f"{path}: no such file")
    raise FormatError(f"unknown trial format {suffix!r} (use .txt, .csv or .npy)", path)


def volunteer_of(path: str | Path) -> str:
    """The volunteer code of a trial file (HMP naming, else the stem's last ``-`` token)."""
    stem = Path(path).stem
    match = _HMP_NAME.match(stem)
    if match:
        return match.group("vol")
    return stem.rsplit("-", 1)[-1] if "-" in stem else "unknown"


def load_dataset(
    root: str | Path,
    actions: Sequence[str] | None = None,
    min_trials: int = 1,
    rate_hz: float = HMP_RATE_HZ,
    warn: Callable[[str], None] | None = None,
) -> list[Trial]:
    """Load every trial under ``root`` (one sub-folder per action, names lower-cased).

    ``actions`` restricts (and checks) the action names; ``min_trials`` drops actions with fewer
    trials (the issue's seven HMP actions are those with ``min_trials=20``). ``warn`` hears of
    what is dropped or suspicious (an empty action folder, an action below ``min_trials``, one
    with a single trial, a trial shorter than :data:`MIN_TRIAL_S`); trials too short to
    recognise anything (fewer than :data:`MIN_TRIAL_SAMPLES`) are an error.
    """
    if isinstance(min_trials, bool) or not isinstance(min_trials, int) or min_trials < 1:
        raise FlexhrcError(f"min_trials must be a whole number >= 1, got {min_trials!r}")
    root = Path(root)
    if not root.is_dir():
        raise FlexhrcError(f"{root}: not a directory")
    folders = {p.name.lower(): p for p in sorted(root.iterdir()) if p.is_dir()}
    folders = {k: v for k, v in folders.items() if not k.endswith("_model")}
    if actions is not None:
        wanted = [a.strip().lower() for a in actions if a.strip()]
        unknown = [a for a in wanted if a not in folders]
        if unknown:
            raise UnknownNameError(
                f"{root}: no action folder for {', '.join(unknown)} "
                f"(available: {', '.join(sorted(folders)) or 'none'})"
            )
        folders = {a: folders[a] for a in wanted}
    trials: list[Trial] = []
    say = warn or (lambda _message: None)
    for action, folder in folders.items():
        files = sorted(p for p in folder.iterdir() if p.suffix.lower() in _TRIAL_SUFFIXES)
        batch = []
        for f in files:
            samples = read_trial_file(f)
            if len(samples) < MIN_TRIAL_SAMPLES:
                raise FormatError(
                    f"too short: {len(samples)} sample(s); a trial needs at least "
                    f"{MIN_TRIAL_SAMPLES}",
                    f,
                )
            if len(samples) < MIN_TRIAL_S * rate_hz:
                say(f"warning: {f}: only {len(samples) / rate_hz:.2f} s of signal")
            batch.append(Trial(action, samples, volunteer_of(f), rate_hz, str(f)))
        if not batch:
            say(f"warning: {folder}: no trial files (.txt, .csv, .npy); action {action} skipped")
        elif len(batch) < min_trials:
            say(
                f"warning: {folder}: {len(batch)} trial(s), fewer than the {min_trials} asked "
                f"for; action {action} skipped"
            )
        else:
            if len(batch) == 1:
                say(f"warning: {folder}: a single trial; its template is that one recording")
            trials.extend(batch)
    if not trials:
        raise FlexhrcError(
            f"{root}: no trials found (expected one folder per action holding .txt, .csv or .npy)"
        )
    return trials


def summarise(trials: Iterable[Trial]) -> dict[str, int]:
    """Number of trials per action."""
    return dict(sorted(Counter(t.action for t in trials).items()))


def save_csv(path: str | Path, samples: np.ndarray, rate_hz: float = HMP_RATE_HZ) -> None:
    """Write a trial in the user CSV format (``t,ax,ay,az`` in s and g)."""
    from flexhrc.files import atomic_output

    samples = np.asarray(samples, dtype=float)
    t = np.arange(len(samples)) / rate_hz
    data = np.column_stack([t, samples])
    with atomic_output(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header="t,ax,ay,az", comments="", fmt="%.6f")
