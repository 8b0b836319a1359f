"""Reading the array files perception takes in, with the errors every flexhrc command gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexhrc.errors import FormatError


def load_npy(path: str | Path) -> np.ndarray:
    """A ``.npy`` array, or one :class:`FormatError` (missing, unreadable, not NumPy, objects)."""
    import io

    from flexhrc.files import read_bytes

    path = Path(path)
    raw = read_bytes(path)
    try:
        arr = np.load(io.BytesIO(raw), allow_pickle=False)
    except (ValueError, EOFError, OSError) as exc:
        raise FormatError(f"not a NumPy array file ({type(exc).__name__})", path) from None
    if not isinstance(arr, np.ndarray):
        raise FormatError("not a NumPy array file (an archive of several arrays?)", path)
    return arr
