"""AND/OR graph definitions: :class:`Node`, :class:`Hyperarc`, :class:`AndOrGraph`.

An AND/OR graph G = <N, H> (paper 000, section IV-A) has nodes — cooperation states — and
hyper-arcs — transitions. A hyper-arc has an ordered tuple of child nodes (all needed: AND) and
one parent node; several hyper-arcs into the same parent are alternatives (OR). The root is the
goal state; nodes that no hyper-arc produces are leaves.

These classes are *definitions*: immutable descriptions loaded from a file or built in code.
The run-time statuses (met, solved, feasible) live in :class:`flexhrc.representation.OnlineGraph`,
which can instantiate one definition several times in a hierarchy.

Besides its name and weight w(n), a node may carry a state formula S(n) (a conjunction of
literals, eq. 2; by default the node's name alone) and an ordered tuple of processes P(n) (robot
behaviours kept up while in that state, eq. 5). A hyper-arc carries its weight w(h), an ordered
tuple of actions A(h) (eq. 4) and optionally the key of a lower graph it expands into (eq. 14),
with the leaf mapping M1 (eq. 15) when it is given explicitly.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from operator import attrgetter
from pathlib import Path

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.logic import Conjunction


@dataclass(slots=True)
class Node:
    """A cooperation state n with weight w(n), state formula S(n) and processes P(n).

    Treat it as immutable once it is part of a graph (it is not frozen only because frozen
    dataclasses are three times slower to create, which shows when loading large files).
    """

    name: str
    weight: float = 0.0
    formula: Conjunction | None = None
    processes: tuple[str, ...] = ()
    line: int | None = field(default=None, compare=False, repr=False)

    def __hash__(self) -> int:
        return hash(self.name)


@dataclass(slots=True)
class Hyperarc:
    """A transition h from its ordered children N_c(h) to its parent N_p(h).

    ``lower`` names the graph definition (key in the hierarchy) this hyper-arc expands into,
    ``leaf_map`` is the explicit M1 mapping child -> lower-graph leaves (eq. 15), or None when
    the file leaves it implicit (ANDOR text: all children together correspond to all leaves).
    """

    name: str
    children: tuple[str, ...]
    parent: str
    weight: float = 0.0
    actions: tuple[str, ...] = ()
    lower: str | None = None
    leaf_map: Mapping[str, tuple[str, ...]] | None = None
    line: int | None = field(default=None, compare=False, repr=False)

    def __hash__(self) -> int:
        return hash((self.name, self.children, self.parent))


_WEIGHT = attrgetter("weight")


class Indexed:
    """One definition as flat arrays over element ids: the nodes 0..n_nodes-1 in definition
    order, then the hyper-arcs in definition order. What the online engine and the checks
    read; a reader can build it straight from a file, without a :class:`Node` or
    :class:`Hyperarc` per element (those are made from it on first use of
    :attr:`AndOrGraph.nodes` / :attr:`AndOrGraph.hyperarcs`)."""

    __slots__ = (
        "_outgoing",
        "children",
        "incoming",
        "leaves",
        "lines",
        "lower",
        "n_nodes",
        "names",
        "parent",
        "root",
        "topo",
        "weights",
    )

    def __init__(
        self,
        names: list[str],
        n_nodes: int,
        weights: list[float],
        children: list[tuple[int, ...]],
        parent: list[int],
        incoming: list[tuple[int, ...]],
        outgoing: list[tuple[int, ...]] | None,
        lower: list[tuple[int, str]],
        root: int,
        topo: list[int],
        leaves: list[int],
        lines: Sequence[int | None],
    ):
        self.names = names  # nodes, then hyper-arcs
        self.n_nodes = n_nodes
        self.weights = weights
        self.children = children  # hyper-arcs: child node ids (nodes: ())
        self.parent = parent  # hyper-arcs: parent node id (nodes: -1)
        self.incoming = incoming  # nodes: hyper-arcs producing it (hyper-arcs: ())
        self._outgoing = outgoing  # see outgoing
        self.lower = lower  # (hyper-arc id, lower graph key), in hyper-arc order
        self.root = root  # -1: none (not validated)
        # every element after what it depends on (a hyper-arc after its children, a node after
        # the hyper-arcs into it): the order of the cost pass, children before parents
        self.topo = topo
        self.leaves = leaves  # the nodes no hyper-arc produces, in id order
        self.lines = lines  # source line of each element

    @property
    def outgoing(self) -> list[tuple[int, ...]]:
        """Nodes: the hyper-arcs consuming it (hyper-arcs: ()); made on first use (loading
        does not need it)."""
        out = self._outgoing
        if out is None:
            out = self._outgoing = consumers(self.n_nodes, self.children)
        return out


def dead_end(node: str, root: str, source: str | Path | None, line: int | None) -> FormatError:
    """The warning about a node some hyper-arc produces and none uses (:meth:`AndOrGraph.
    validate` and the readers that make its checks as they parse: one message)."""
    return FormatError(
        f"node {node!r} is produced by a hyper-arc but used by none: it cannot contribute to "
        f"the root {root!r}",
        source,
        line,
    )


def consumers(n_nodes: int, children: list[tuple[int, ...]]) -> list[tuple[int, ...]]:
    """Per element: the hyper-arcs that have it among their children (only nodes have any)."""
    out: list[tuple[int, ...]] = [()] * len(children)
    for j in range(n_nodes, len(children)):
        for c in children[j]:
            out[c] += (j,)
    return out


def dp_order(
    n_nodes: int,
    parent: list[int],
    children: list[tuple[int, ...]],
    incoming: list[tuple[int, ...]],
    outgoing: list[tuple[int, ...]],
) -> list[int]:
    """Every element after what it depends on — a hyper-arc once all of its children are
    placed, a node once every hyper-arc into it is — starting with the leaves in id order
    (Kahn's algorithm over elements; a cycle leaves elements out, so the list is short)."""
    wait = list(map(len, incoming[:n_nodes]))
    wait += map(len, children[n_nodes:])
    order = [i for i in range(n_nodes) if not wait[i]]
    for x in order:  # (grows while it is read)
        if x < n_nodes:
            for h in outgoing[x]:
                wait[h] -= 1
                if not wait[h]:
                    order.append(h)
        else:
            p = parent[x]
            wait[p] -= 1
            if not wait[p]:
                order.append(p)
    return order


def kahn_order(
    n_nodes: int,
    parent: list[int],
    children: list[tuple[int, ...]],
    outgoing: list[tuple[int, ...]],
) -> list[int]:
    """Node ids, children before parents (Kahn's algorithm; a cycle leaves nodes out), in the
    order :meth:`AndOrGraph.topological_order` gives over names: the nodes with no incoming
    hyper-arc in id order, then each node once every (hyper-arc, child) edge into it is
    placed."""
    indeg = [0] * n_nodes
    for j in range(n_nodes, len(parent)):
        indeg[parent[j]] += len(children[j])
    order = [i for i in range(n_nodes) if not indeg[i]]
    for n in order:  # (grows while it is read)
        for h in outgoing[n]:
            p = parent[h]
            indeg[p] -= 1
            if not indeg[p]:
                order.append(p)
    return order


class AndOrGraph:
    """One AND/OR graph definition: named nodes, named hyper-arcs and a root.

    Build it with :meth:`add_node` / :meth:`add_hyperarc` (or load it with
    :func:`flexhrc.representation.load`), then call :meth:`validate`. Errors name the source
    file and line of the offending element when known.
    """

    def __init__(self, name: str, root: str | None = None, source: str | Path | None = None):
        self.name = name
        self.root = root
        self.source = str(source) if source is not None else None
        self._nodes: dict[str, Node] | None = {}
        self._hyperarcs: dict[str, Hyperarc] | None = {}
        # the flat form a reader built (then _nodes/_hyperarcs are None until first asked for)
        self._ix: Indexed | None = None
        self.root_line: int | None = None
        self.load_warnings: list[FormatError] = []  # set by readers (e.g. renamed duplicates)
        self._topo: tuple[tuple[int, int], list[str]] | None = None  # cache, keyed by size
        # set by a reader that did validate()'s checks while parsing: (size, warnings)
        self._validated: tuple[tuple[int, int], list[FormatError]] | None = None

    @classmethod
    def from_indexed(
        cls,
        name: str,
        root: str,
        source: str | Path | None,
        ix: Indexed,
        *,
        root_line: int | None = None,
        validated: list[FormatError] | None = None,
    ) -> AndOrGraph:
        """A graph held in its flat form (a reader's fast path): the :class:`Node` and
        :class:`Hyperarc` objects are made on first use of :attr:`nodes` / :attr:`hyperarcs`.
        ``validated``: the warnings, when the reader has made every check of :meth:`validate`
        (as :meth:`mark_validated` records them)."""
        g = cls.__new__(cls)
        # the attributes of __init__, set once (one per file of a hierarchy: offline time)
        g.name = name
        g.root = root
        g.source = str(source) if source is not None else None
        g._nodes = g._hyperarcs = None
        g._ix = ix
        g.root_line = root_line
        g.load_warnings = []
        g._topo = None
        g._validated = (
            None if validated is None else ((ix.n_nodes, len(ix.names) - ix.n_nodes), validated)
        )
        return g

    @property
    def nodes(self) -> dict[str, Node]:
        """Node name -> :class:`Node`, in definition order."""
        d = self._nodes
        return d if d is not None else self._unpack()[0]

    @property
    def hyperarcs(self) -> dict[str, Hyperarc]:
        """Hyper-arc name -> :class:`Hyperarc`, in definition order."""
        d = self._hyperarcs
        return d if d is not None else self._unpack()[1]

    def _unpack(self) -> tuple[dict[str, Node], dict[str, Hyperarc]]:
        """The objects of the flat form; from now on the dicts are the graph (they may be
        changed in place), so the flat form is dropped."""
        ix = self._ix
        assert ix is not None
        names, weights, lines, nn = ix.names, ix.weights, ix.lines, ix.n_nodes
        nodes = {names[i]: Node(names[i], weights[i], None, (), lines[i]) for i in range(nn)}
        lower = dict(ix.lower)
        children, parent = ix.children, ix.parent
        arcs: dict[str, Hyperarc] = {}
        for j in range(nn, len(names)):
            arcs[names[j]] = Hyperarc(
                names[j],
                tuple([names[c] for c in children[j]]),
                names[parent[j]],
                weights[j],
                (),
                lower.get(j),
                None,
                lines[j],
            )
        self._nodes, self._hyperarcs, self._ix = nodes, arcs, None
        return nodes, arcs

    def _size(self) -> tuple[int, int]:
        ix = self._ix
        if ix is not None:
            return (ix.n_nodes, len(ix.names) - ix.n_nodes)
        return (len(self.nodes), len(self.hyperarcs))

    def indexed(self) -> Indexed:
        """The flat form: the reader's, or built now from :attr:`nodes` and
        :attr:`hyperarcs` (not kept: they may change). Call on a validated graph."""
        ix = self._ix
        if ix is not None:
            return ix
        nodes, arcs = self.nodes, self.hyperarcs
        node_names = list(nodes)
        nn = len(node_names)
        idx = dict(zip(node_names, range(nn), strict=True))
        get = idx.__getitem__
        names = node_names
        weights = list(map(float, map(_WEIGHT, nodes.values())))
        lines: list[int | None] = [n.line for n in nodes.values()]
        children: list[tuple[int, ...]] = [()] * nn
        parent = [-1] * nn
        incoming: list[list[int]] = [[] for _ in range(nn)]
        outgoing: list[list[int]] = [[] for _ in range(nn)]
        lower: list[tuple[int, str]] = []
        j = nn
        for h in arcs.values():
            names.append(h.name)
            weights.append(float(h.weight))
            lines.append(h.line)
            ch = tuple(map(get, h.children))
            children.append(ch)
            for c in ch:
                outgoing[c].append(j)
            p = idx[h.parent]
            parent.append(p)
            incoming[p].append(j)
            if h.lower is not None:
                lower.append((j, h.lower))
            j += 1
        # tuples: never changed once built, and the empty ones are all the same object
        inc = [tuple(x) if x else () for x in incoming] + [()] * (j - nn)
        out = [tuple(x) if x else () for x in outgoing] + [()] * (j - nn)
        root = idx.get(self.root, -1) if self.root is not None else -1
        topo: list[int] = []
        for name in self.topological_order():
            i = idx[name]
            topo.extend(inc[i])
            topo.append(i)
        leaves = [i for i in range(nn) if not inc[i]]
        return Indexed(
            names, nn, weights, children, parent, inc, out, lower, root, topo, leaves, lines
        )

    # -- building -------------------------------------------------------------------------
    def add_node(self, node: Node | str, weight: float = 0.0, **kw: object) -> Node:
        if isinstance(node, str):
            node = Node(node, weight, **kw)  # type: ignore[arg-type]
        self._check_new(self.nodes, node, "node")
        self.nodes[node.name] = node
        self._validated = None
        return node

    def add_hyperarc(
        self,
        hyperarc: Hyperarc | str,
        children: Iterable[str] = (),
        parent: str | None = None,
        weight: float = 0.0,
        **kw: object,
    ) -> Hyperarc:
        if isinstance(hyperarc, str):
            if parent is None:
                raise ValueError("parent is required")
            hyperarc = Hyperarc(hyperarc, tuple(children), parent, weight, **kw)  # type: ignore[arg-type]
        self._check_new(self.hyperarcs, hyperarc, "hyper-arc")
        if not hyperarc.children:
            raise FormatError(
                f"hyper-arc {hyperarc.name!r} has no child node", self.source, hyperarc.line
            )
        self.hyperarcs[hyperarc.name] = hyperarc
        self._validated = None
        return hyperarc

    def _check_new(
        self, known: Mapping[str, Node | Hyperarc], item: Node | Hyperarc, what: str
    ) -> None:
        """A new element's name is not taken yet and its weight is a finite number >= 0."""
        if item.name in known:
            first = known[item.name].line
            where = f" (first defined at line {first})" if first else ""
            raise FormatError(f"duplicate {what} name {item.name!r}{where}", self.source, item.line)
        check_weight(item.weight, f"{what} {item.name!r}", self.source, item.line)

    # -- queries --------------------------------------------------------------------------
    def node(self, name: str) -> Node:
        try:
            return self.nodes[name]
        except KeyError:
            raise UnknownNameError(f"graph {self.name!r} has no node {name!r}") from None

    def hyperarc(self, name: str) -> Hyperarc:
        try:
            return self.hyperarcs[name]
        except KeyError:
            raise UnknownNameError(f"graph {self.name!r} has no hyper-arc {name!r}") from None

    def incoming(self, node: str) -> list[Hyperarc]:
        """Hyper-arcs whose parent is ``node`` (its OR alternatives)."""
        return [h for h in self.hyperarcs.values() if h.parent == node]

    def leaves(self) -> list[str]:
        """Nodes that no hyper-arc produces, in definition order (N_L)."""
        ix = self._ix
        if ix is not None:
            return [ix.names[i] for i in ix.leaves]
        produced = {h.parent for h in self.hyperarcs.values()}
        return [n for n in self.nodes if n not in produced]

    def __len__(self) -> int:
        return self._size()[0]

    def __repr__(self) -> str:
        return (
            f"AndOrGraph({self.name!r}, root={self.root!r}, nodes={len(self.nodes)}, "
            f"hyperarcs={len(self.hyperarcs)})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, AndOrGraph):
            return NotImplemented
        return (
            self.name == other.name
            and self.root == other.root
            and list(self.nodes.values()) == list(other.nodes.values())
            and list(self.hyperarcs.values()) == list(other.hyperarcs.values())
        )

    __hash__ = None  # type: ignore[assignment]

    # -- validation -----------------------------------------------------------------------
    def validate(self) -> list[FormatError]:
        """Check the structure; raise :class:`FormatError` naming file and line on a fault.

        Checks: every hyper-arc names existing nodes and no child twice; a root exists — the
        declared one, or else the one node that no hyper-arc consumes (none: "missing root",
        several: "multiple roots"); the root is no hyper-arc's child; no cycle.

        Returns warnings that do not prevent use: nodes that some hyper-arc produces but none
        consumes ("dead ends": they can never contribute to the root). The authors' own
        ``PL_BallPlacement.txt`` has one.
        """
        done = self._validated
        if done is not None:
            if done[0] == self._size():
                return list(done[1])
            self._validated = None  # changed since: check again
        src = self.source
        consumed: set[str] = set()
        for h in self.hyperarcs.values():
            if h.parent not in self.nodes:
                raise FormatError(
                    f"hyper-arc {h.name!r}: unknown parent node {h.parent!r}", src, h.line
                )
            seen: set[str] = set()
            for c in h.children:
                if c not in self.nodes:
                    raise FormatError(
                        f"hyper-arc {h.name!r}: unknown child node {c!r}", src, h.line
                    )
                if c in seen:
                    raise FormatError(
                        f"hyper-arc {h.name!r}: child {c!r} listed twice", src, h.line
                    )
                seen.add(c)
            if h.parent in seen:
                raise FormatError(
                    f"hyper-arc {h.name!r}: node {h.parent!r} is both child and parent", src, h.line
                )
            consumed.update(h.children)
        tops = [n for n in self.nodes if n not in consumed]
        if not self.root:
            if not tops:
                raise FormatError(
                    f"graph {self.name!r} has no root: every node is a child of some hyper-arc",
                    src,
                    self.root_line,
                )
            if len(tops) > 1:
                raise FormatError(
                    f"graph {self.name!r} has multiple roots ({', '.join(tops)}): declare one "
                    "with 'root:' or connect the others",
                    src,
                    self.root_line,
                )
            self.root = tops[0]
        if self.root not in self.nodes:
            raise FormatError(
                f"root node {self.root!r} of graph {self.name!r} is not among its nodes",
                src,
                self.root_line,
            )
        if self.root in consumed:
            h = next(h for h in self.hyperarcs.values() if self.root in h.children)
            raise FormatError(
                f"root node {self.root!r} is a child of hyper-arc {h.name!r} (a root has no "
                "parent)",
                src,
                h.line,
            )
        # Kahn's order misses nodes only when there is a cycle: then find it for the message
        acyclic = len(self.topological_order()) == len(self.nodes)
        cycle = None if acyclic else self._find_cycle()
        if cycle:
            h = self.hyperarcs[cycle[1]]
            raise FormatError(f"cycle: {' -> '.join(cycle)}", src, h.line)
        produced = {h.parent for h in self.hyperarcs.values()}
        return [*self.load_warnings] + [
            dead_end(n, self.root, src, self.nodes[n].line)
            for n in tops
            if n != self.root and n in produced
        ]

    def mark_validated(self, warnings: list[FormatError]) -> None:
        """Record that a reader has made every check of :meth:`validate` while building the
        graph (with these warnings): validating it again, unchanged, returns them at once."""
        self._validated = (self._size(), warnings)

    def lint(self) -> list[FormatError]:
        """Oddities of a valid graph that usually mean a mistake (call after :meth:`validate`).

        * the root is a leaf although the graph has hyper-arcs: the graph is solved as soon as
          its root is met (a file cut short after its node lines looks like this);
        * nodes on no hyper-arc: they can never contribute to the root;
        * a node shared between the children of one hyper-arc (reachable from two of them):
          the dynamic-programming costs then count it once per branch, while the paper's
          cooperation path counts it once (``docs/andor.md``, "Costs").
        """
        src = self.source
        out: list[FormatError] = []
        if not self.hyperarcs:
            return out
        produced = {h.parent for h in self.hyperarcs.values()}
        used = set(produced)
        for h in self.hyperarcs.values():
            used.update(h.children)
        if self.root not in produced:
            out.append(
                FormatError(
                    f"the root {self.root!r} is a leaf (no hyper-arc produces it): the graph is "
                    "solved as soon as it is met — is the file cut short?",
                    src,
                    self.root_line,
                )
            )
        idle = [n for n in self.nodes if n not in used and n != self.root]
        for n in idle[:20]:
            out.append(
                FormatError(
                    f"node {n!r} is on no hyper-arc: it can never contribute to the root",
                    src,
                    self.nodes[n].line,
                )
            )
        if len(idle) > 20:
            out.append(FormatError(f"... and {len(idle) - 20} more nodes on no hyper-arc", src))
        out += self._shared_children()
        return out

    def _shared_children(self) -> list[FormatError]:
        # below(n): the nodes n depends on (n included), as a bit set over node positions;
        # computed bottom-up, so no recursion and one pass
        order = self.topological_order()
        pos = {n: i for i, n in enumerate(self.nodes)}
        names = list(self.nodes)
        incoming: dict[str, list[Hyperarc]] = {}
        for h in self.hyperarcs.values():
            incoming.setdefault(h.parent, []).append(h)
        below: dict[str, int] = {}
        out: list[FormatError] = []
        for n in order:
            bits = 1 << pos[n]
            for h in incoming.get(n, ()):
                acc = 0
                for c in h.children:
                    b = below[c]
                    common = acc & b
                    if common and len(out) < 20:
                        shared = names[(common & -common).bit_length() - 1]
                        out.append(
                            FormatError(
                                f"hyper-arc {h.name!r}: node {shared!r} is shared between its "
                                f"children (reachable from {c!r} and from an earlier child): "
                                "the costs count it once per branch, not once as the paper's "
                                "cooperation path does (see docs/andor.md)",
                                self.source,
                                h.line,
                            )
                        )
                    acc |= b
                bits |= acc
            below[n] = bits
        return out

    def _find_cycle(self) -> list[str] | None:
        """A cycle child -> hyper-arc -> parent -> ... as a list of names, or None."""
        out: dict[str, list[Hyperarc]] = {n: [] for n in self.nodes}
        for h in self.hyperarcs.values():
            for c in h.children:
                out[c].append(h)
        WHITE, GREY, BLACK = 0, 1, 2
        colour = dict.fromkeys(self.nodes, WHITE)
        for start in self.nodes:
            if colour[start] != WHITE:
                continue
            stack: list[tuple[str, int]] = [(start, 0)]
            trail: list[str] = [start]
            colour[start] = GREY
            while stack:
                node, i = stack[-1]
                if i < len(out[node]):
                    stack[-1] = (node, i + 1)
                    h = out[node][i]
                    nxt = h.parent
                    if colour[nxt] == GREY:
                        k = trail.index(nxt)
                        return _with_arcs([*trail[k:], nxt], out)
                    if colour[nxt] == WHITE:
                        colour[nxt] = GREY
                        stack.append((nxt, 0))
                        trail.append(nxt)
                else:
                    colour[node] = BLACK
                    stack.pop()
                    trail.pop()
        return None

    def topological_order(self) -> list[str]:
        """Nodes ordered children before parents (leaves first); cycles leave nodes out."""
        key = self._size()
        if self._topo is not None and self._topo[0] == key:
            return self._topo[1]
        ix = self._ix
        if ix is not None:
            names = ix.names
            order = [names[i] for i in kahn_order(ix.n_nodes, ix.parent, ix.children, ix.outgoing)]
            self._topo = (key, order)
            return order
        # Kahn's algorithm (one function: this runs on every load)
        indeg = dict.fromkeys(self.nodes, 0)
        consumers: dict[str, list[str]] = {n: [] for n in self.nodes}
        for h in self.hyperarcs.values():
            for c in h.children:
                consumers[c].append(h.parent)
                indeg[h.parent] += 1
        order = [n for n in self.nodes if indeg[n] == 0]
        i = 0
        while i < len(order):
            for p in consumers[order[i]]:
                indeg[p] -= 1
                if indeg[p] == 0:
                    order.append(p)
            i += 1
        self._topo = (key, order)
        return order


def _with_arcs(nodes: list[str], out: Mapping[str, list[Hyperarc]]) -> list[str]:
    trail: list[str] = []
    for a, b in itertools.pairwise(nodes):
        h = next(h for h in out[a] if h.parent == b)
        trail += [a, h.name]
    trail.append(nodes[-1])
    return trail


def plain_number(x: float) -> float | int:
    """A weight or cost as an integer when it is one (``3.0`` -> ``3``): files and JSON read
    it so."""
    return int(x) if float(x).is_integer() else x


def check_weight(weight: object, what: str, source: str | Path | None, line: int | None) -> None:
    """A weight is a finite number >= 0, or one :class:`FormatError` naming ``what``."""
    if type(weight) is float and 0.0 <= weight < math.inf:  # the common case, cheap
        return
    if isinstance(weight, bool) or not isinstance(weight, (int, float)):
        raise FormatError(f"{what}: weight {weight!r} is not a number", source, line)
    if weight != weight or weight < 0 or weight == float("inf"):
        raise FormatError(
            f"{what}: weight must be a finite number >= 0, got {weight}", source, line
        )
