"""JSON-lines files (event histories and cooperation logs): one JSON object per line."""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError


def read_jsonl(path: str | Path, required: Iterable[str] = ()) -> list[dict[str, Any]]:
    """Every object of a JSON-lines file; blank lines are skipped. A line that is not a JSON
    object, or lacks one of the ``required`` keys, raises :class:`FormatError` with its line."""
    return [obj for _, obj in read_jsonl_lines(path, required)]


def read_jsonl_lines(
    path: str | Path, required: Iterable[str] = ()
) -> list[tuple[int, dict[str, Any]]]:
    """Like :func:`read_jsonl`, with the line number of every object."""
    path = Path(path)
    if not path.is_file():
        raise FormatError("no such file", path)
    need = tuple(required)
    out: list[tuple[int, dict[str, Any]]] = []
    with open(path, encoding="utf-8") as fh:
        for i, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                obj = json.loads(line)
            except json.JSONDecodeError as exc:
                raise FormatError(f"not a JSON line ({exc.msg})", path, i) from None
            if not isinstance(obj, dict):
                raise FormatError("each line must be a JSON object", path, i)
            missing = [k for k in need if k not in obj]
            if missing:
                raise FormatError(f"missing {', '.join(repr(k) for k in missing)}", path, i)
            out.append((i, obj))
    return out


def write_jsonl(path: str | Path, objects: Iterable[dict[str, Any]]) -> None:
    with open(path, "w", encoding="utf-8") as fh:
        for obj in objects:
            fh.write(json.dumps(obj) + "\n")
