"""The ANDOR text format of the FlexHRC+ authors' C++ library (``anchors/andor-graphs``).

::

    <graph name> <number of nodes N> <root node name>
    <node name> <node weight>                       (N lines)
    <hyper-arc name> <k children> <parent> <weight> <lower graph file or ->
    <child 1>                                       (k lines)
    ...

A lower graph is named by its file name without ``.txt``. It is looked up relative to the folder
of the including file first, then relative to the folder of the top file (the kitchen files of
the reference corpus use the latter: ``BaseCabinet/DrawerAssembly.txt`` refers to
``BaseCabinet/RollerAssembly``). Blank lines and everything after a ``#`` are ignored, so the
``*Commented.txt`` files load too. A repeated node name is an error; a repeated hyper-arc name
(harmless for the C++ library, which addresses hyper-arcs by position) is renamed
``<name>@L<line>`` with a warning. Graph definitions are keyed by their path relative to the top
file's folder, without extension (``BaseCabinet/RailAssembly``); the top graph's key is its
file stem.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError
from flexhrc.files import read_text
from flexhrc.representation.graph import (
    AndOrGraph,
    Hyperarc,
    Indexed,
    Node,
    consumers,
    dead_end,
    dp_order,
    plain_number,
)
from flexhrc.representation.hierarchy import HierarchicalGraph

SUFFIX = ".txt"

# The common case compiled (``_andor_fast.c``, built on install when a C compiler is there):
# a file read and parsed into the same flat form as :func:`_parse_flat`; for anything else the
# bytes it read (None: it could not read them), which the Python reader then parses and judges.
# FLEXHRC_PURE_PYTHON=1 turns it off.
_parse_compiled: Callable[[str | Path], tuple[Any, ...] | bytes | None] | None
if os.environ.get("FLEXHRC_PURE_PYTHON", "") not in ("", "0"):
    _parse_compiled = None
else:
    try:
        from flexhrc.representation.formats._andor_fast import parse_file as _parse_compiled
    except ImportError:  # not built: the Python reader does it all
        _parse_compiled = None


def _read(path: str | Path) -> bytes | None:
    """The bytes of a file, or None when it cannot be read (the Python reader says why)."""
    try:
        # os-level reads: 4 system calls where open() makes 9 (fstat twice, a tty check,
        # seeks), which shows on the cold first call of a small graph
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
        try:
            chunks = []
            while chunk := os.read(fd, 1 << 16):
                chunks.append(chunk)
        finally:
            os.close(fd)
    except OSError:
        return None
    return chunks[0] if len(chunks) == 1 else b"".join(chunks)


def _rows(path: str | Path, data: bytes | None) -> tuple[list[list[str]], list[int] | range]:
    """The non-blank lines of a file (its ``data``, None if it could not be read) split into
    tokens (comments dropped), and their line numbers. Each file is read once and split once;
    a file without comments or blank lines (the common case) is tokenised by one
    comprehension, its line numbers a ``range``."""
    text = None
    if data is not None and b"\x00" not in data:
        with contextlib.suppress(UnicodeDecodeError):
            text = data.decode("utf-8").removeprefix("\ufeff")
    if text is None:
        # the shared reader says why (missing, folder, unreadable, binary, not UTF-8)
        text = read_text(path)
    if "#" not in text:
        rows = list(map(str.split, text.splitlines()))
        if all(rows):  # no blank line (an empty list is false: no comparison per row)
            return rows, range(1, len(rows) + 1)
    else:
        rows = [raw.split("#", 1)[0].split() for raw in text.splitlines()]
    nums = [i for i, toks in enumerate(rows, 1) if toks]
    return [toks for toks in rows if toks], nums


def _excerpt(text: str, limit: int = 120) -> str:
    """``text`` quoted, cut to its first ``limit`` characters: a message names the faulty
    line, it does not repeat a line of any length."""
    return repr(text) if len(text) <= limit else f"{text[:limit]!r}... ({len(text)} characters)"


def _weight(tok: str, kind: str, name: str, path: str | Path, line: int) -> float:
    if tok.isdigit() and tok.isascii():  # the common case, cheap ("²" is a digit too)
        return float(tok)
    what = f"{kind} {name!r}"
    try:
        w = float(tok)
    except ValueError:
        raise FormatError(f"{what}: weight {_excerpt(tok)} is not a number", path, line) from None
    if not (w >= 0) or w == float("inf"):
        raise FormatError(f"{what}: weight must be a finite number >= 0, got {tok}", path, line)
    return w


def _name(tok: str, what: str, path: str | Path, line: int) -> str:
    if "/" in tok:
        raise FormatError(f"{what} name {tok!r} must not contain '/'", path, line)
    return tok


def parse_graph(path: str | Path) -> tuple[AndOrGraph, list[tuple[str, int]]]:
    """Parse one file. Returns the graph and its lower-graph references (name, line).

    The graph is validated here (every fast path folds :meth:`AndOrGraph.validate`'s checks
    in, with its messages); a graph that passes is marked validated and is not checked again.
    """
    data = None
    if _parse_compiled is not None:
        compiled = _parse_compiled(path)
        if isinstance(compiled, tuple):
            return _from_compiled(path, compiled)
        data = compiled  # the bytes it read and left to the Python reader (None: unreadable)
    if data is None:
        data = _read(path)
    rows, nums = _rows(path, data)
    fast = _parse_flat(path, rows, nums)
    if fast is not None:
        return fast
    if not rows:
        raise FormatError("empty file: expected '<graph name> <number of nodes> <root>'", path, 1)
    head = rows[0]
    lineno = nums[0]
    if len(head) != 3:
        # the line is not quoted: this may be any file, not ours to show
        raise FormatError(
            "not an ANDOR graph file: the header must be '<graph name> <number of nodes> "
            f"<root node>' (3 fields), the first line has {len(head)}",
            path,
            lineno,
        )
    name, count_tok, root = head
    try:
        count = int(count_tok)
    except ValueError:
        raise FormatError(
            "not an ANDOR graph file: the second field of the first line (number of nodes) "
            "is not an integer",
            path,
            lineno,
        ) from None
    if count < 1:
        raise FormatError(f"number of nodes must be at least 1, got {count}", path, lineno)
    graph = AndOrGraph(name, root, source=path)
    graph.root_line = lineno
    n_rows = len(rows)
    if n_rows - 1 < count:
        raise FormatError(
            f"header announces {count} nodes but the file has only {n_rows - 1} more lines",
            path,
            lineno,
        )
    nodes = graph.nodes
    for i in range(1, count + 1):
        toks = rows[i]
        ln = nums[i]
        if len(toks) != 2:
            hint = " (the header announces more nodes than are listed?)" if len(toks) == 5 else ""
            raise FormatError(
                f"node line must be '<name> <weight>', got {_excerpt(' '.join(toks))}{hint}",
                path,
                ln,
            )
        n, w = toks
        if "/" in n or n in nodes:
            _name(n, "node", path, ln)
            graph.add_node(Node(n, line=ln))  # raises the duplicate-name error
        nodes[n] = Node(n, _weight(w, "node", n, path, ln), line=ln)
    refs: list[tuple[str, int]] = []
    renamed: list[FormatError] = []
    arcs = graph.hyperarcs
    i = count + 1
    while i < n_rows:
        toks = rows[i]
        ln = nums[i]
        if len(toks) != 5:
            extra = " (a node line after the announced number of nodes?)" if len(toks) == 2 else ""
            raise FormatError(
                "hyper-arc line must be '<name> <number of children> <parent> <weight> "
                f"<lower graph or ->', got {_excerpt(' '.join(toks))}{extra}",
                path,
                ln,
            )
        hname, k_tok, parent, w_tok, lower = toks
        if "/" in hname:
            _name(hname, "hyper-arc", path, ln)
        try:
            k = int(k_tok)
        except ValueError:
            raise FormatError(
                f"hyper-arc {hname!r}: number of children {_excerpt(k_tok)} is not an integer",
                path,
                ln,
            ) from None
        if k < 1:
            raise FormatError(f"hyper-arc {hname!r}: needs at least one child, got {k}", path, ln)
        block = rows[i + 1 : i + 1 + k]
        if len(block) < k or sum(map(len, block)) != k:  # (no row is empty)
            found = next((j for j, r in enumerate(block) if len(r) != 1), len(block))
            where = nums[i + 1 + found] if i + 1 + found < n_rows else ln
            raise FormatError(
                f"hyper-arc {hname!r} declares {k} children but {found} follow", path, where
            )
        children = (block[0][0],) if k == 1 else tuple([r[0] for r in block])
        weight = _weight(w_tok, "hyper-arc", hname, path, ln)
        lower_ref = None if lower == "-" else lower
        if lower_ref is not None:
            refs.append((lower_ref, ln))
        if hname in arcs:
            # The C++ library addresses hyper-arcs by position, so its files may repeat a name
            # (the authors' 3Leg/TableAssemblyPLCommented.txt does). Names are our addresses:
            # keep the file loadable, rename the repeat and say so.
            first = arcs[hname].line
            new_name = f"{hname}@L{ln}"
            renamed.append(
                FormatError(
                    f"hyper-arc name {hname!r} repeats the one at line {first}; "
                    f"this one is renamed {new_name!r}",
                    path,
                    ln,
                )
            )
            hname = new_name
        # add_hyperarc's checks are done above (name, weight, at least one child, repeats)
        arcs[hname] = Hyperarc(hname, children, parent, weight, (), lower_ref, None, ln)
        i += k + 1
    graph.load_warnings = renamed
    # (the rare file: the common case is _parse_flat's or the compiled reader's)
    graph.mark_validated(graph.validate())  # a fault: the precise error
    return graph, refs


def _from_compiled(
    path: str | Path, parsed: tuple[Any, ...]
) -> tuple[AndOrGraph, list[tuple[str, int]]]:
    """The graph of what the compiled reader returned (the flat form :func:`_parse_flat`
    builds, the same warnings)."""
    (name, root_name, nn, names, weights, children, parent, inc, lower, root, topo, leaves,
     lines, root_line, dead, refs) = parsed  # fmt: skip
    ix = Indexed(names, nn, weights, children, parent, inc, None, lower, root, topo, leaves, lines)
    return _flat_graph(path, name, root_name, ix, root_line, dead), refs


def _flat_graph(
    path: str | Path, name: str, root_name: str, ix: Indexed, root_line: int, dead: list[int]
) -> AndOrGraph:
    """A graph held in the flat form a fast path built, every check of ``validate()`` made:
    its warnings are the dead ends (``dead``: node ids, in id order)."""
    names, lines = ix.names, ix.lines
    warnings = [dead_end(names[n], root_name, path, lines[n]) for n in dead] if dead else []
    return AndOrGraph.from_indexed(
        name, root_name, path, ix, root_line=root_line, validated=warnings
    )


def _parse_flat(
    path: str | Path, rows: list[list[str]], nums: list[int] | range
) -> tuple[AndOrGraph, list[tuple[str, int]]] | None:
    """The common case — a well-formed file of plain names and integer weights, no repeated
    hyper-arc name — parsed straight into the flat form (:class:`Indexed`: no object per
    element), with every check of :meth:`AndOrGraph.validate` on the way. None at the first
    thing out of the ordinary: :func:`parse_graph` then parses the file again, element by
    element, and names the fault (or renames the repeat) exactly as it always has.

    Lean on purpose (few statements, few distinct operations): most files are small, and the
    offline time of a small graph is mostly the fixed cost of the code that runs once."""
    if not rows or len(rows[0]) != 3:
        return None
    name, count_tok, root_name = rows[0]
    if not (count_tok.isdigit() and count_tok.isascii()):
        return None
    nn = int(count_tok)
    n_rows = len(rows)
    if not 0 < nn < n_rows - 1:
        return None
    try:
        # rows of unequal lengths (strict) or not of two fields (the unpacking): ValueError
        names_t, weights_t = zip(*rows[1 : nn + 1], strict=True)
    except ValueError:
        return None
    digits = "".join(weights_t)
    if not (digits.isdigit() and digits.isascii()) or "/" in "".join(names_t):
        return None
    names = list(names_t)
    idx = dict(zip(names, range(nn), strict=True))
    root = idx.get(root_name, -1)
    if len(idx) != nn or root < 0:
        return None
    get = idx.__getitem__
    # every weight "0" (the authors' usual node weight): no conversion per node
    weights = (
        [0.0] * nn if len(digits) == nn and not digits.strip("0") else [*map(float, weights_t)]
    )
    lines = list(nums[1 : nn + 1])
    children: list[tuple[int, ...]] = [()] * nn
    parent = [-1] * nn
    inc: list[tuple[int, ...]] = [()] * nn
    last: dict[int, int] = {}  # produced node -> the last hyper-arc into it
    consumed: set[int] = set()
    w_toks: list[str] = []
    lower: list[tuple[int, str]] = []
    refs: list[tuple[str, int]] = []
    in_order = True  # every child a leaf or made by an earlier hyper-arc
    i = nn + 1
    j = nn
    try:
        while i < n_rows:
            # a row of the wrong length, a child line missing, a count that is not an
            # integer: ValueError, IndexError; an unknown node: KeyError
            hname, k_tok, p_name, w_tok, low = rows[i]
            k = int(k_tok)  # (int() is what parse_graph applies too)
            if k == 1:
                (c_name,) = rows[i + 1]
                ch: tuple[int, ...] = (get(c_name),)
            elif k > 1:
                ch = tuple([get(c) for (c,) in rows[i + 1 : i + 1 + k]])
                if len(ch) != k or len(set(ch)) != k:
                    return None
            else:
                return None
            p = get(p_name)
            if p in ch:
                return None
            if p in consumed:
                in_order = False
            consumed.update(ch)
            names.append(hname)
            w_toks.append(w_tok)
            ln = nums[i]
            lines.append(ln)
            children.append(ch)
            parent.append(p)
            inc[p] += (j,)
            last[p] = j
            if low != "-":
                lower.append((j, low))
                refs.append((low, ln))
            i += k + 1
            j += 1
    except (KeyError, IndexError, ValueError):
        return None
    digits = "".join(w_toks)
    hnames = names[nn:]
    if (
        not (digits.isdigit() and digits.isascii())
        or len(set(hnames)) != j - nn
        or "/" in "".join(hnames)
    ):
        return None  # a repeated hyper-arc name: parse_graph renames it (and warns)
    weights += map(float, w_toks)
    if root in consumed:
        return None  # the root is a child
    leaves = [x for x in range(nn) if x not in last]
    inc += [()] * (j - nn)
    if in_order:
        # the authors list hyper-arcs children first: that order is a topological one (no
        # cycle), and the cost pass follows it, each node right after its last hyper-arc
        topo = leaves[:]
        for h in range(nn, j):
            topo.append(h)
            p = parent[h]
            if last[p] == h:
                topo.append(p)
    else:
        topo = dp_order(nn, parent, children, inc, consumers(nn, children))
        if len(topo) != j:
            return None  # a cycle
    ix = Indexed(names, nn, weights, children, parent, inc, None, lower, root, topo, leaves, lines)
    # dead ends (produced, consumed by none, not the root): warnings, in node order
    dead = last.keys() - consumed
    dead.discard(root)
    return _flat_graph(path, name, root_name, ix, nums[0], sorted(dead)), refs


def _resolve(ref: str, including_dir: str, top_dir: str, is_dir: dict[str, bool]) -> str | None:
    """The file a reference names: next to the including file first, then in the top folder.
    ``is_dir`` remembers, for one load, which folders exist, so the candidates of every
    reference into a folder that is not there cost no ``stat`` (the kitchen's files name
    ``BaseCabinet/X`` from inside ``BaseCabinet/``)."""
    for base in (including_dir, top_dir):
        # references usually omit the extension: try that first (one stat instead of two)
        for cand in (os.path.join(base, ref + SUFFIX), os.path.join(base, ref)):
            folder = os.path.dirname(cand)
            there = is_dir.get(folder)
            if there is None:
                there = is_dir[folder] = os.path.isdir(folder)
            if there and os.path.isfile(cand):
                return os.path.normpath(cand)
    return None


_REGULAR, _FOLDER, _OTHER = 0, 1, 2


def _listing(folder: str, listings: dict[str, dict[str, int] | None]) -> dict[str, int] | None:
    """Entry name -> regular file / folder / anything else (a symbolic link, a device) of a
    folder, from one ``scandir`` (the kinds come with the names: no ``stat`` per entry);
    None if it cannot be listed. Remembered for one load."""
    if folder in listings:
        return listings[folder]
    entries: dict[str, int] | None
    try:
        with os.scandir(folder) as it:
            entries = {
                e.name: _OTHER
                if e.is_symlink()
                else _REGULAR
                if e.is_file()
                else _FOLDER
                if e.is_dir()
                else _OTHER
                for e in it
            }
    except OSError:
        entries = None
    listings[folder] = entries
    return entries


def _listed_folder(
    folder: str, top_dir: str, listings: dict[str, dict[str, int] | None]
) -> dict[str, int] | None:
    """The entries of ``folder`` (the top folder or below it) when it is reached from the top
    folder through real folders only; ``{}`` when it is not there (or is a file); None when
    that cannot be said from listings (a link on the way, a folder that cannot be listed)."""
    entries = _listing(top_dir, listings)
    cur = top_dir
    for part in folder[len(top_dir) + 1 :].split(os.sep) if folder != top_dir else ():
        if entries is None:
            return None
        kind = entries.get(part)
        if kind == _OTHER:
            return None
        cur = f"{cur}{os.sep}{part}"
        if kind != _FOLDER:
            listings[folder] = {}
            return {}
        entries = _listing(cur, listings)
    return entries


def _find_listed(
    ref: str, here: str, top_dir: str, listings: dict[str, dict[str, int] | None]
) -> str | None:
    """What :func:`_resolve` and :func:`_inside` find, from folder listings: the file a plain
    reference (no ``.``/``..``/empty component, not absolute) names, when it is a regular
    file reached from the top folder through real folders only (no link: then it is inside
    the top folder). None when the listings cannot say for sure (a link on the way, a
    reference that is not plain, nothing found): the ``stat``-based lookup decides then."""
    # (string tests first: a component "" / "." / ".." needs "/" twice, one at either end,
    # or a ".")
    if ref[0] == "/" or ref[-1] == "/" or "//" in ref:
        return None
    if "." in ref:
        parts = ref.split("/")
        if "." in parts or ".." in parts:
            return None
    sep = os.sep
    cut = ref.rfind("/")
    last = ref[cut + 1 :]
    sub = sep + ref[:cut].replace("/", sep) if cut >= 0 else ""
    with_suffix = last + SUFFIX
    for base in (here, top_dir) if here != top_dir else (top_dir,):
        folder = base + sub
        entries = listings.get(folder, _UNSEEN)
        if entries is _UNSEEN:
            entries = _listed_folder(folder, top_dir, listings)
        if entries is None:
            return None
        # references usually omit the extension; a link or a device: let stat and realpath
        # judge
        for name in (with_suffix, last):
            kind = entries.get(name)
            if kind == _REGULAR:
                return f"{folder}{sep}{name}"
            if kind == _OTHER:
                return None
    return None


_UNSEEN: dict[str, int] = {}


def _inside(path: str, folder: str, plain: set[str]) -> bool:
    """Whether ``path`` (normalised, lexically under ``folder``) stays under ``folder`` once
    symbolic links are resolved. Only the components below ``folder`` are looked at (a link
    there is resolved in full): a few ``lstat`` calls instead of ``realpath``'s one per
    component of the whole path; ``plain`` remembers, for one load, the folders found not to
    be links."""
    cur = folder
    parts = path[len(folder) :].strip(os.sep).split(os.sep)
    last = len(parts) - 1
    for i, part in enumerate(parts):
        cur = os.path.join(cur, part)
        if cur in plain:
            continue
        if os.path.islink(cur):
            real, top = os.path.realpath(path), os.path.realpath(folder)
            return real.startswith(top.rstrip(os.sep) + os.sep)
        if i < last:
            plain.add(cur)
    return True


def _is_normal(path: str) -> bool:
    """Whether an absolute path is already what ``os.path.abspath`` would make of it."""
    return not path.endswith(os.sep) and f"{os.sep}." not in path and 2 * os.sep not in path


def load_andor_text(path: str | Path) -> HierarchicalGraph:
    """Load a top file and every lower graph it refers to (iteratively: no depth limit).

    A lower graph must lie in the top file's folder or below it: a reference that resolves
    elsewhere (``../../etc/passwd``) is refused.
    """
    top_file = os.fspath(path)
    sep = os.sep
    if not (top_file.startswith(sep) and _is_normal(top_file)):
        top_file = os.path.abspath(top_file)  # normalised too
    # os.path.dirname of a normalised absolute path, without its Python-level calls
    top_dir = top_file[: top_file.rfind(sep)] or sep
    graphs: dict[str, AndOrGraph] = {}
    key_of: dict[str, str] = {}
    resolved: dict[str, dict[str, str | None]] = {}  # folder -> reference -> file
    is_dir: dict[str, bool] = {}
    plain: set[str] = set()
    listings: dict[str, dict[str, int] | None] = {}
    fast = top_dir != sep and sep == "/"  # (references are written with "/")

    prefix = top_dir + os.sep
    cut = len(prefix)

    def key_for(p: str) -> str:
        rel = p[cut:] if p.startswith(prefix) else os.path.basename(p)
        if sep != "/":
            rel = rel.replace(sep, "/")
        return rel[: -len(SUFFIX)] if rel.endswith(SUFFIX) else rel

    top = key_of[top_file] = key_for(top_file)
    todo = [top_file]
    while todo:
        p = todo.pop()
        graph, refs = parse_graph(p)
        graphs[key_of[p]] = graph
        if not refs:
            continue  # (most files: a leaf of the hierarchy)
        here = p[: p.rfind(sep)] or sep
        found = resolved.get(here)
        if found is None:
            found = resolved[here] = {}
        remap: dict[str, str] = {}
        for ref, ln in refs:
            if ref in remap:
                continue
            target = found.get(ref, "")
            if target == "":
                listed = _find_listed(ref, here, top_dir, listings) if fast else None
                if listed is not None:
                    # a regular file under the top folder, no link on the way: inside it
                    key = key_of.get(listed)
                    if key is None:
                        key = key_of[listed] = key_for(listed)
                        todo.append(listed)
                    found[ref] = listed
                    remap[ref] = key
                    continue
                target = found[ref] = _resolve(ref, here, top_dir, is_dir)
            if target is None:
                raise FormatError(
                    f"lower graph file {_excerpt(ref)} not found (looked for {ref}{SUFFIX} next "
                    f"to this file and in {top_dir})"
                    if len(ref) <= 120
                    else f"lower graph file {_excerpt(ref)} not found",
                    p,
                    ln,
                )
            if target not in key_of:
                if not target.startswith(prefix) or not _inside(target, top_dir, plain):
                    raise FormatError(
                        f"lower graph {_excerpt(ref)} resolves to a file outside the top "
                        f"graph's folder {top_dir}; lower graphs must lie in that folder or "
                        "below it",
                        p,
                        ln,
                    )
                key_of[target] = key_for(target)
                todo.append(target)
            remap[ref] = key_of[target]
        if list(remap) != list(remap.values()):  # a reference is not its key
            ix = graph._ix
            if ix is not None:  # the flat form: its references are keys from now on
                ix.lower[:] = [(j, remap[ref]) for j, ref in ix.lower]
                continue
            for h in list(graph.hyperarcs.values()):
                if h.lower is not None and remap[h.lower] != h.lower:
                    graph.hyperarcs[h.name] = replace(h, lower=remap[h.lower])
    return HierarchicalGraph(graphs, top)


def dump_andor_text(hierarchy: HierarchicalGraph, directory: str | Path) -> Path:
    """Write every definition as ANDOR text under ``directory``; returns the top file.

    Formulas, processes and actions have no place in this format and are dropped.
    """
    directory = Path(directory)
    for key, g in hierarchy.graphs.items():
        target = directory / (key + SUFFIX)
        target.parent.mkdir(parents=True, exist_ok=True)
        lines = [f"{g.name} {len(g.nodes)} {g.root}"]
        lines += [f"{n.name} {plain_number(n.weight)}" for n in g.nodes.values()]
        for h in g.hyperarcs.values():
            lines.append(
                f"{h.name} {len(h.children)} {h.parent} {plain_number(h.weight)} {h.lower or '-'}"
            )
            lines += list(h.children)
        target.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return directory / (hierarchy.top + SUFFIX)
