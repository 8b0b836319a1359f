"""JSON-lines files (event histories and cooperation logs): one JSON object per line."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def read_jsonl_lines(
    path: str | Path, required: Iterable[str] = ()
) -> list[tuple[int, dict[str, Any]]]:
    """Every object of a JSON-lines file with its line number; blank lines are skipped. A line
    that is not a JSON object, or lacks one of the ``required`` keys, raises
    :class:`FormatError` with its line.

    The file is read with :func:`flexhrc.files.read_text` (missing, a folder, unreadable,
    binary and non-UTF-8 files are one clear error); ``NaN`` and ``Infinity``, which Python's
    ``json`` would accept, are refused, and so is nesting too deep to parse.
    """
    from flexhrc.files import read_text

    path = Path(path)
    text = read_text(path)
    need = tuple(required)
    out: list[tuple[int, dict[str, Any]]] = []
    for i, line in enumerate(text.split("\n"), 1):
        if not line.strip():
            continue
        try:
            obj = json.loads(line, parse_constant=_no_constant)
        except json.JSONDecodeError as exc:
            raise FormatError(f"not a JSON line ({exc.msg})", path, i) from None
        except ValueError as exc:
            raise FormatError(f"not a JSON line ({exc})", path, i) from None
        except RecursionError:
            raise FormatError("not a JSON line (nested too deeply)", path, i) from None
        if not isinstance(obj, dict):
            raise FormatError("each line must be a JSON object", path, i)
        missing = [k for k in need if k not in obj]
        if missing:
            raise FormatError(f"missing {', '.join(repr(k) for k in missing)}", path, i)
        out.append((i, obj))
    return out
