"""Readers and writers of AND/OR graph files.

* ANDOR text (``.txt``) — the FlexHRC+ authors' format (:mod:`.andor_text`);
* YAML (``.yaml``/``.yml``) — flexhrc's native format: a whole hierarchy in one file, node
  formulas, processes, hyper-arc actions and explicit leaf mappings (:mod:`.yaml_format`);
* DOT (``.dot``) — export only, for graphviz (:mod:`.dot`).

:func:`load` picks the reader from the file extension and validates the result, so every
structural fault is reported with its file and line.
"""

from __future__ import annotations

import gc
import os
from collections.abc import Callable
from pathlib import Path

from flexhrc.errors import FormatError
from flexhrc.representation.hierarchy import HierarchicalGraph
from flexhrc.representation.online import GraphArgumentError

_READERS: dict[bool, Callable[[str | Path], HierarchicalGraph]] = {}  # is YAML -> reader


def reader_for(path: str | Path) -> Callable[[str | Path], HierarchicalGraph]:
    """The reader of a graph file, chosen by its extension (its module imported now)."""
    yaml = str(path).lower().endswith((".yaml", ".yml"))
    reader = _READERS.get(yaml)
    if reader is not None:
        return reader
    if yaml:
        from flexhrc.representation.formats.yaml_format import load_yaml

        reader = load_yaml
    else:
        from flexhrc.representation.formats.andor_text import load_andor_text

        reader = load_andor_text
    _READERS[yaml] = reader
    return reader


def load(path: str | Path, *, validate: bool = True) -> HierarchicalGraph:
    """Load a graph file (ANDOR text or YAML) with every lower graph it refers to.

    Every fault is one :class:`FormatError` naming the file (and line): a missing, unreadable,
    binary or non-UTF-8 file, a syntax or structure error, a lower graph that is missing or
    lies outside the top file's folder.
    """
    if type(path) is not str and not isinstance(path, str | os.PathLike):
        raise GraphArgumentError(
            f"load() needs a file path (str or Path), got {type(path).__name__}"
        )
    name = os.fspath(path)
    # a reader makes thousands of lists and tuples and no reference cycle: the cyclic garbage
    # collector's passes meanwhile would only scan them
    collecting = gc.isenabled()
    gc.disable()
    try:
        return _load(path, name, validate)
    finally:
        if collecting:
            gc.enable()


def _load(path: str | Path, name: str, validate: bool) -> HierarchicalGraph:
    try:
        # no stat or Path first: on the cold first call of a small graph those cost more than
        # parsing it; the reader's own open() says whether the file is there
        reader = _READERS.get(name.lower().endswith((".yaml", ".yml"))) or reader_for(name)
        hierarchy = reader(name)
    except FormatError:
        if not os.path.lexists(name):
            raise FormatError("no such file", path) from None
        if os.path.isdir(name):
            raise FormatError(
                "is a directory, expected a graph file (.txt or .yaml)", path
            ) from None
        raise
    if validate:
        hierarchy.validate()
    return hierarchy


def save(hierarchy: HierarchicalGraph, path: str | Path) -> Path:
    """Write a hierarchy; the format follows the extension (.yaml/.yml, .dot, or a folder for
    ANDOR text)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        from flexhrc.representation.formats.yaml_format import dump_yaml

        path.write_text(dump_yaml(hierarchy), encoding="utf-8")
        return path
    if suffix == ".dot":
        from flexhrc.representation.formats.dot import to_dot

        path.write_text(to_dot(hierarchy), encoding="utf-8")
        return path
    from flexhrc.representation.formats.andor_text import dump_andor_text

    return dump_andor_text(hierarchy, path)


__all__ = ["load", "reader_for", "save"]
