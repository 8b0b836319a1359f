"""flexhrc's native YAML format for (hierarchical, first-order) AND/OR graphs.

A whole hierarchy fits in one file; a graph may also live in another file (``file:``, a path
relative to this one, in YAML or ANDOR text)::

    flexhrc: 1                       # format version
    top: table                       # key of the top graph G0
    graphs:
      table:
        name: TableAssembly          # optional, defaults to the key
        root: Table_FinalPose        # optional: the one node that no hyper-arc consumes
        nodes:
          - Plate_initPose           # a bare name: weight 0, state = its name
          - name: Leg1_Plate_connected
            weight: 0
            state: connected(?leg, ?plate) & not held(?leg)   # S(n), eq. 2
            processes: ["hold(?plate)"]                        # P(n), eq. 5
        hyperarcs:
          - name: h1
            children: [Leg1_T, Plate_assemblyPose]
            parent: Leg1_Plate_connected
            weight: 1
            actions:                     # A(h), eq. 4 (quote them in [...] flow lists)
              - approach(?arm, ?leg)
              - screw(?arm, ?leg, ?plate)
            lower: connection                                 # transition T (eq. 14)
            leaves: {Leg1_T: [Leg_T], Plate_assemblyPose: [Plate]}   # M1 (eq. 15), optional
      connection: {file: basic_connection.txt}

Every error names the file and line.
"""

from __future__ import annotations

import os
import reprlib
from dataclasses import replace
from pathlib import Path
from typing import Any

import yaml

from flexhrc.errors import FormatError
from flexhrc.files import read_text
from flexhrc.logic import parse_conjunction, parse_literal
from flexhrc.representation.graph import AndOrGraph, Hyperarc, Node, check_weight, plain_number
from flexhrc.representation.hierarchy import HierarchicalGraph

FORMAT_VERSION = 1


class _LineDict(dict[Any, Any]):
    line: int = 0
    lines: dict[Any, int]


class _Loader(yaml.SafeLoader):
    pass


def _construct_mapping(loader: _Loader, node: yaml.MappingNode) -> _LineDict:
    loader.flatten_mapping(node)
    d = _LineDict()
    d.line = node.start_mark.line + 1
    d.lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            raise FormatError(
                "unhashable mapping key", None, key_node.start_mark.line + 1
            ) from None
        if key in d:
            raise FormatError(f"duplicate key {_shown(key)}", None, key_node.start_mark.line + 1)
        d[key] = loader.construct_object(value_node, deep=True)
        d.lines[key] = key_node.start_mark.line + 1
    return d


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


_SHOWN = reprlib.Repr()
_SHOWN.maxstring = _SHOWN.maxother = 80
_SHOWN.maxlevel = 3


def _shown(value: Any) -> str:
    """A value as a message quotes it: bounded, whatever its size (a YAML alias can make a
    few bytes stand for a structure of millions of elements; ``repr`` would expand it)."""
    return _SHOWN.repr(value)


def _code_point(c: Any) -> str:
    return f"U+{c:04X}" if isinstance(c, int) else repr(c)


def read_yaml(path: str | Path) -> Any:
    """Parse a YAML file; mappings remember their line numbers. Syntax errors name the line."""
    path = Path(path)
    text = read_text(path)  # missing, folder, unreadable, binary, not UTF-8: one clear error
    try:
        loader = _Loader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            _check_aliases(node, path)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except RecursionError:
        # PyYAML composes nested collections recursively; past Python's limit, say so
        raise FormatError(
            "YAML nested too deeply (thousands of levels of lists or mappings)", path
        ) from None
    except FormatError as exc:
        raise FormatError(exc.message, path, exc.line) from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        raise FormatError(f"YAML syntax error: {exc.problem or exc}", path, line) from None
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow (a control one)
        line = text.count("\n", 0, max(exc.position, 0)) + 1
        raise FormatError(
            f"YAML syntax error: character {_code_point(exc.character)} is not allowed in YAML",
            path,
            line,
        ) from None
    except yaml.YAMLError as exc:  # (any other: no position known)
        raise FormatError(f"YAML syntax error: {str(exc)[:200]}", path) from None


#: How many values a document may stand for once its aliases are expanded, beyond which it is
#: refused: PyYAML shares an aliased value rather than copying it, but every reader that walks,
#: prints or converts it pays for the expansion (nested aliases: a 400-byte file of 10**8 values)
MAX_EXPANDED = 1_000_000


def _check_aliases(root: yaml.Node, path: Path) -> None:
    """Refuse a document whose aliases stand for more than :data:`MAX_EXPANDED` values (and
    more than ten times its own size): one pass over the distinct nodes, each counted once."""
    expanded: dict[int, int] = {}
    open_nodes: set[int] = set()  # entered, not yet counted: an alias to one is a cycle
    distinct = 0
    # iterative post-order walk: a deep document must not exhaust Python's stack here
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        if id(node) in expanded:
            continue
        children: list[yaml.Node] = []
        if isinstance(node, yaml.SequenceNode):
            children = list(node.value)
        elif isinstance(node, yaml.MappingNode):
            children = [n for kv in node.value for n in kv]
        if not done:
            if id(node) in open_nodes:  # an alias inside its own anchor
                raise FormatError(
                    "YAML alias refers to a value that contains it (a recursive '*' reference)",
                    path,
                    node.start_mark.line + 1,
                )
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in children if id(c) not in expanded)
            continue
        open_nodes.discard(id(node))
        distinct += 1
        size = 1 + sum(expanded.get(id(c), 0) for c in children)
        expanded[id(node)] = size
        if size > MAX_EXPANDED and size > 10 * distinct:
            raise FormatError(
                f"YAML aliases expand to more than {MAX_EXPANDED} values (nested '*' "
                "references); write the values out or use fewer levels of aliases",
                path,
                node.start_mark.line + 1,
            )


def _line(d: Any, key: Any = None) -> int | None:
    if isinstance(d, _LineDict):
        return d.lines.get(key, d.line) if key is not None else d.line
    return None


def _expect(d: Any, kind: type, what: str, path: Path, line: int | None) -> Any:
    if not isinstance(d, kind):
        names: dict[type, str] = {dict: "a mapping", list: "a list", str: "a string"}
        raise FormatError(f"{what} must be {names.get(kind, kind.__name__)}", path, line)
    return d


def _check_keys(d: _LineDict, allowed: set[str], what: str, path: Path) -> None:
    for k in d:
        if k not in allowed:
            raise FormatError(
                f"unknown key {_shown(k)} in {what} (allowed: {', '.join(sorted(allowed))})",
                path,
                _line(d, k),
            )


def _weight(v: Any, what: str, path: Path, line: int | None) -> float:
    check_weight(v, what, path, line)
    return float(v)


def _str_list(v: Any, what: str, path: Path, line: int | None) -> tuple[str, ...]:
    if isinstance(v, str):
        return (v,)
    if not isinstance(v, list) or not all(isinstance(x, str | int | float) for x in v):
        raise FormatError(f"{what} must be a list of names", path, line)
    return tuple(str(x) for x in v)


def _name(v: Any, what: str, path: Path, line: int | None) -> str:
    if not isinstance(v, str | int) or isinstance(v, bool) or str(v) == "":
        raise FormatError(f"{what} must be a non-empty name", path, line)
    s = str(v)
    if "/" in s or any(c.isspace() for c in s):
        raise FormatError(f"{what} {_shown(s)} must not contain '/' or spaces", path, line)
    return s


def _key(v: Any, path: Path, line: int | None) -> str:
    if not isinstance(v, str) or not v.strip() or any(c.isspace() for c in v):
        raise FormatError(
            f"lower graph key {_shown(v)} must be a non-empty name without spaces", path, line
        )
    return v


def _graph_from_dict(key: str, d: _LineDict, path: Path, key_line: int | None) -> AndOrGraph:
    _check_keys(d, {"name", "root", "nodes", "hyperarcs", "description"}, f"graph {key!r}", path)
    name = _name(d.get("name", key), f"graph {key!r}: name", path, _line(d, "name"))
    root = _name(d["root"], "root", path, _line(d, "root")) if "root" in d else None
    g = AndOrGraph(name, root, source=path)
    g.root_line = _line(d, "root") if "root" in d else key_line
    nodes = _expect(d.get("nodes"), list, f"graph {key!r}: nodes", path, _line(d, "nodes"))
    for i, nd in enumerate(nodes):
        if isinstance(nd, str | int) and not isinstance(nd, bool):
            g.add_node(Node(_name(nd, "node", path, _line(d, "nodes")), line=_line(d, "nodes")))
            continue
        what = f"graph {key!r}: node #{i + 1}"
        _expect(nd, dict, what, path, _line(d, "nodes"))
        _check_keys(nd, {"name", "weight", "state", "processes", "description"}, what, path)
        ln = _line(nd)
        if "name" not in nd:
            raise FormatError(f"{what} has no name", path, ln)
        n = _name(nd["name"], "node", path, ln)
        formula = None
        if "state" in nd:
            state = nd["state"]
            if not isinstance(state, str) and not (
                isinstance(state, list) and all(isinstance(x, str) for x in state)
            ):
                raise FormatError(
                    f"{what}: state must be a formula such as 'on(?a, ?b) & not held(?a)' (or "
                    f"a list of literals), got {type(state).__name__}",
                    path,
                    _line(nd, "state"),
                )
            formula = parse_conjunction(state, str(path), _line(nd, "state"))
        g.add_node(
            Node(
                n,
                _weight(nd.get("weight", 0), f"node {n!r}", path, _line(nd, "weight")),
                formula,
                _str_list(nd.get("processes", []), f"node {n!r}: processes", path, ln),
                line=ln,
            )
        )
    arcs = _expect(d.get("hyperarcs", []), list, f"graph {key!r}: hyperarcs", path, _line(d))
    for i, hd in enumerate(arcs):
        what = f"graph {key!r}: hyper-arc #{i + 1}"
        _expect(hd, dict, what, path, _line(d, "hyperarcs"))
        _check_keys(
            hd,
            {"name", "children", "parent", "weight", "actions", "lower", "leaves", "description"},
            what,
            path,
        )
        ln = _line(hd)
        for req in ("name", "children", "parent"):
            if req not in hd:
                raise FormatError(f"{what} has no {req!r}", path, ln)
        hname = _name(hd["name"], "hyper-arc", path, ln)
        children = _str_list(hd["children"], f"hyper-arc {hname!r}: children", path, ln)
        leaf_map = None
        if "leaves" in hd:
            lm = _expect(hd["leaves"], dict, f"hyper-arc {hname!r}: leaves", path, ln)
            leaf_map = {
                str(c): _str_list(v, f"hyper-arc {hname!r}: leaves of {c}", path, ln)
                for c, v in lm.items()
            }
        lower = hd.get("lower")
        actions = _str_list(hd.get("actions", []), f"hyper-arc {hname!r}: actions", path, ln)
        for a in actions:  # A(h), eq. 4: each action is a literal, checked like S(n)
            parse_literal(a, str(path), _line(hd, "actions"))
        g.add_hyperarc(
            Hyperarc(
                hname,
                children,
                _name(hd["parent"], "parent", path, _line(hd, "parent")),
                _weight(hd.get("weight", 0), f"hyper-arc {hname!r}", path, _line(hd, "weight")),
                actions,
                None if lower in (None, "-") else _key(lower, path, _line(hd, "lower")),
                leaf_map,
                line=ln,
            )
        )
    return g


def load_yaml(path: str | Path, _including: tuple[str, ...] = ()) -> HierarchicalGraph:
    """Load a YAML graph file (and the files it refers to).

    ``file:`` references must stay in the top file's folder (or below it) and must not
    include a file that is already being loaded (a file including itself, directly or not).
    """
    path = Path(path)
    _including = (*_including, os.path.realpath(path))
    doc = read_yaml(path)
    _expect(doc, dict, "the document", path, 1)
    _check_keys(doc, {"flexhrc", "top", "graphs", "description"}, "the document", path)
    version = doc.get("flexhrc", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise FormatError(
            f"unsupported format version {_shown(version)} (this flexhrc reads {FORMAT_VERSION})",
            path,
            _line(doc, "flexhrc"),
        )
    graphs_d = _expect(doc.get("graphs"), dict, "'graphs'", path, _line(doc, "graphs"))
    if not graphs_d:
        raise FormatError("'graphs' is empty", path, _line(doc, "graphs"))
    top = str(doc.get("top", next(iter(graphs_d))))
    graphs: dict[str, AndOrGraph] = {}
    for key, gd in graphs_d.items():
        key = str(key)
        _expect(gd, dict, f"graph {key!r}", path, _line(graphs_d, key))
        if "file" in gd:
            _check_keys(gd, {"file"}, f"graph {key!r}", path)
            graphs.update(_load_external(key, path, gd, _including))
        else:
            graphs[key] = _graph_from_dict(key, gd, path, _line(graphs_d, key))
    if top not in graphs:
        raise FormatError(
            f"top graph {top!r} is not defined under 'graphs'", path, _line(doc, "top")
        )
    for g in graphs.values():
        for h in g.hyperarcs.values():
            if h.lower is not None and h.lower not in graphs:
                raise FormatError(
                    f"hyper-arc {h.name!r} refers to lower graph {h.lower!r}, which is not defined "
                    f"(graphs: {', '.join(graphs)})",
                    g.source,
                    h.line,
                )
    return HierarchicalGraph(graphs, top)


MAX_INCLUDE_DEPTH = 100


def _load_external(
    key: str, path: Path, gd: _LineDict, including: tuple[str, ...]
) -> dict[str, AndOrGraph]:
    line = _line(gd, "file")
    target = path.parent / str(gd["file"])
    real = os.path.realpath(target)
    top_dir = os.path.dirname(including[0])
    if not (real.startswith(top_dir.rstrip(os.sep) + os.sep)):
        raise FormatError(
            f"graph {key!r}: file {gd['file']!r} lies outside the top graph's folder {top_dir}; "
            "graph files must lie in that folder or below it",
            path,
            line,
        )
    if real in including:
        chain = " -> ".join(os.path.basename(p) for p in (*including, real))
        raise FormatError(
            f"graph {key!r}: file {gd['file']!r} includes itself ({chain})", path, line
        )
    if len(including) > MAX_INCLUDE_DEPTH:
        raise FormatError(
            f"graph {key!r}: files include each other more than {MAX_INCLUDE_DEPTH} levels deep",
            path,
            line,
        )
    if not target.is_file():
        raise FormatError(f"graph {key!r}: file {gd['file']!r} not found", path, line)
    if str(target).lower().endswith((".yaml", ".yml")):
        sub = load_yaml(target, including)
    else:
        # the ANDOR text reader itself, not formats.load: formats imports this module
        from flexhrc.representation.formats.andor_text import load_andor_text

        sub = load_andor_text(target)
    out: dict[str, AndOrGraph] = {}
    # the external top graph takes this key; its own lower graphs keep theirs, prefixed
    for k, g in sub.graphs.items():
        out[key if k == sub.top else f"{key}/{k}"] = g
    for g in out.values():
        for h in list(g.hyperarcs.values()):
            if h.lower is not None:
                new = key if h.lower == sub.top else f"{key}/{h.lower}"
                g.hyperarcs[h.name] = replace(h, lower=new)
    return out


def to_dict(hierarchy: HierarchicalGraph) -> dict[str, Any]:
    """The hierarchy as plain data in the YAML schema (every graph inline)."""
    graphs: dict[str, Any] = {}
    for key in [hierarchy.top, *[k for k in hierarchy.graphs if k != hierarchy.top]]:
        g = hierarchy.graphs[key]
        nodes: list[Any] = []
        for n in g.nodes.values():
            if n.weight == 0 and n.formula is None and not n.processes:
                nodes.append(n.name)
                continue
            nd: dict[str, Any] = {"name": n.name, "weight": plain_number(n.weight)}
            if n.formula is not None:
                nd["state"] = " & ".join(str(lit) for lit in n.formula)
            if n.processes:
                nd["processes"] = list(n.processes)
            nodes.append(nd)
        arcs: list[Any] = []
        for h in g.hyperarcs.values():
            hd: dict[str, Any] = {
                "name": h.name,
                "children": list(h.children),
                "parent": h.parent,
                "weight": plain_number(h.weight),
            }
            if h.actions:
                hd["actions"] = list(h.actions)
            if h.lower is not None:
                hd["lower"] = h.lower
            if h.leaf_map is not None:
                hd["leaves"] = {c: list(v) for c, v in h.leaf_map.items()}
            arcs.append(hd)
        gd: dict[str, Any] = {"name": g.name, "root": g.root, "nodes": nodes, "hyperarcs": arcs}
        graphs[key] = gd
    return {"flexhrc": FORMAT_VERSION, "top": hierarchy.top, "graphs": graphs}


def dump_yaml(hierarchy: HierarchicalGraph) -> str:
    return yaml.safe_dump(to_dict(hierarchy), sort_keys=False, default_flow_style=None, width=100)
