"""Readers and writers of AND/OR graph files.

* ANDOR text (``.txt``) — the FlexHRC+ authors' format (:mod:`.andor_text`);
* YAML (``.yaml``/``.yml``) — flexhrc's native format: a whole hierarchy in one file, node
  formulas, processes, hyper-arc actions and explicit leaf mappings (:mod:`.yaml_format`);
* DOT (``.dot``) — export only, for graphviz (:mod:`.dot`).

:func:`load` picks the reader from the file extension and validates the result, so every
structural fault is reported with its file and line.
"""

from __future__ import annotations

from pathlib import Path

from flexhrc.errors import FormatError
from flexhrc.representation.hierarchy import HierarchicalGraph


def load(path: str | Path, *, validate: bool = True) -> HierarchicalGraph:
    """Load a graph file (ANDOR text or YAML) with every lower graph it refers to."""
    path = Path(path)
    if not path.exists():
        raise FormatError("no such file", path)
    if path.is_dir():
        raise FormatError("is a directory, expected a graph file (.txt or .yaml)", path)
    suffix = path.suffix.lower()
    if suffix in (".yaml", ".yml"):
        from flexhrc.representation.formats.yaml_format import load_yaml

        hierarchy = load_yaml(path)
    else:
        from flexhrc.representation.formats.andor_text import load_andor_text

        hierarchy = load_andor_text(path)
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


__all__ = ["load", "save"]
