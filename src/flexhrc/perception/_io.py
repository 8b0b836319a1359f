"""Reading the array and YAML files perception takes in, with the errors every flexhrc command
gives."""

from __future__ import annotations

from pathlib import Path
from typing import Any

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


def load_yaml(path: str | Path) -> Any:
    """The data of a YAML (or JSON) file, or one :class:`FormatError` naming the file and, for
    a syntax error, the line (missing, a folder, unreadable, binary, not UTF-8, too deep)."""
    import yaml

    from flexhrc.files import read_text

    path = Path(path)
    text = read_text(path)
    try:
        return yaml.safe_load(text)
    except RecursionError:
        raise FormatError("nested too deeply to be read", path) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise FormatError(
            f"invalid YAML: {getattr(exc, 'problem', exc)}",
            path,
            None if mark is None else mark.line + 1,
        ) from None
