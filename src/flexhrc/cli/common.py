"""Helpers shared by the sub-command modules."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="print one machine-readable JSON document on stdout"
    )


def emit(args: argparse.Namespace, data: Any, text: Callable[[], str] | str | None = None) -> None:
    """Print ``data`` as JSON when ``--json`` was given, else the human-readable ``text``."""
    if getattr(args, "json", False):
        json.dump(data, sys.stdout, indent=2, default=_json_default)
        sys.stdout.write("\n")
        return
    if text is None:
        json.dump(data, sys.stdout, indent=2, default=_json_default)
        sys.stdout.write("\n")
        return
    sys.stdout.write((text() if callable(text) else text).rstrip("\n") + "\n")


def log(args: argparse.Namespace, message: str) -> None:
    """A progress/trace line: stderr under ``--json`` (stdout stays pure JSON), else stdout."""
    stream = sys.stderr if getattr(args, "json", False) else sys.stdout
    print(message, file=stream, flush=True)


def existing_file(value: str) -> Path:
    path = Path(value)
    if not path.exists():
        raise FlexhrcError(f"{value}: no such file")
    return path


def _json_default(obj: Any) -> Any:
    if hasattr(obj, "to_dict"):
        return obj.to_dict()
    if isinstance(obj, Path):
        return str(obj)
    try:
        import numpy as np

        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
    except ImportError:  # pragma: no cover
        pass
    if isinstance(obj, set | frozenset):
        return sorted(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
