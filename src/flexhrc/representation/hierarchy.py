"""Hierarchical AND/OR graphs H = <Γ, Θ> (paper 000, section IV-B, eqs. 12-16).

A :class:`HierarchicalGraph` holds graph *definitions* keyed by a reference (for ANDOR text
files: the file path relative to the top file's folder, without ``.txt``) and the key of the top
graph G0. A transition T: h -> G(l+1) (eq. 14) is a hyper-arc whose ``lower`` names another
definition; its children map to the lower graph's leaves (M1, eq. 15) and its parent to the lower
root (M2, eq. 16).

The same definition may be used by several hyper-arcs; at run time every use is its own
*instance*, named by the path of hyper-arc names from the top graph, e.g. ``h4/h3`` is the
instance created by hyper-arc ``h3`` inside the instance created by top-level hyper-arc ``h4``.
Elements inside an instance are named ``<instance path>/<element>``; a bare name is an element
of the top graph. This is the one naming syntax used by the CLI, JSON and the event history.

First-order transitions: when the state formulas on both sides of a transition speak of the same
things, a grounding passes through it (:class:`Transfer`, :meth:`HierarchicalGraph.transfer`): a
variable the upper hyper-arc binds is bound in the lower instance it creates (M1), and the
lower root's result grounds the upper hyper-arc's parent (M2). Literals that correspond (same
predicate, sign and arity) must be the same literal up to renaming — a lower variable may stand
for an upper variable or an object the upper layer names; :meth:`HierarchicalGraph.validate`
says where they are not, with file and line (``docs/andor.md``, "Groundings through the
hierarchy").
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.logic import Literal, is_variable
from flexhrc.representation.graph import AndOrGraph, Hyperarc, Node

SEP = "/"


@dataclass(frozen=True)
class InstanceInfo:
    """One use of a graph definition in the instantiated hierarchy."""

    path: str  # "" for the top graph, else "h4/h3"
    key: str  # definition key
    depth: int
    upper: str | None  # qualified name of the hyper-arc that created it


@dataclass(frozen=True)
class Transfer:
    """How a grounding passes through one transition T: h -> G(l+1) (paper 000, eqs. 15-16).

    ``down`` (M1, eq. 15): each variable of the lower graph's leaves that corresponds to a
    literal of h's children -> the term of that literal there (a variable of the upper graph,
    or an object the upper layer names). ``up`` (M2, eq. 16): each variable of the lower root
    that corresponds to a literal of h's parent -> that literal's term. Both are empty when the
    formulas on the two sides say nothing of each other (the authors' ANDOR files have none):
    then nothing passes and the lower instance grounds its variables on its own.

    >>> from flexhrc.logic import parse_conjunction as f
    >>> up = AndOrGraph("up", root="on")
    >>> _ = up.add_node("free", formula=f("loose(?s) & spare(?s)"))
    >>> _ = up.add_node("on", formula=f("mounted(?s)"))
    >>> _ = up.add_hyperarc("fit", ["free"], "on", lower="roller")
    >>> low = AndOrGraph("roller", root="done")
    >>> _ = low.add_node("slide", formula=f("loose(?slide)"))
    >>> _ = low.add_node("done", formula=f("mounted(?slide)"))
    >>> _ = low.add_hyperarc("mount", ["slide"], "done", actions=("mount(?who, ?slide)",))
    >>> HierarchicalGraph({"up": up, "roller": low}, "up").transfer("up", "fit")
    Transfer(down={'?slide': '?s'}, up={'?slide': '?s'})
    """

    down: Mapping[str, str] = field(default_factory=dict)
    up: Mapping[str, str] = field(default_factory=dict)

    def __bool__(self) -> bool:
        return bool(self.down or self.up)


_NOTHING = Transfer()


class HierarchicalGraph:
    """Graph definitions plus the key of the top graph G0."""

    def __init__(self, graphs: dict[str, AndOrGraph], top: str):
        if top not in graphs:
            raise UnknownNameError(f"top graph {top!r} is not among the graph definitions")
        self.graphs = graphs
        self.top = top
        self.warnings: list[FormatError] = []  # filled by validate(): harmless oddities
        self._transfers: dict[tuple[str, str], Transfer] = {}  # (graph key, hyper-arc) -> it

    @classmethod
    def single(cls, graph: AndOrGraph) -> HierarchicalGraph:
        return cls({graph.name: graph}, graph.name)

    @property
    def top_graph(self) -> AndOrGraph:
        return self.graphs[self.top]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, HierarchicalGraph):
            return NotImplemented
        return self.top == other.top and self.graphs == other.graphs

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"HierarchicalGraph(top={self.top!r}, graphs={len(self.graphs)})"

    # -- structure ------------------------------------------------------------------------
    def used_keys(self) -> list[str]:
        """Definition keys reachable from the top graph, top first, in discovery order."""
        seen: dict[str, None] = {self.top: None}
        stack = deque([self.top])
        while stack:
            g = self.graphs[stack.popleft()]
            ix = g._ix
            if ix is not None:  # flat: no objects made to read its references
                for _, low in ix.lower:
                    if low not in seen:
                        seen[low] = None
                        stack.append(low)
                continue
            for h in g.hyperarcs.values():
                if h.lower is not None and h.lower not in seen:
                    seen[h.lower] = None
                    stack.append(h.lower)
        return list(seen)

    def instances(self) -> Iterator[InstanceInfo]:
        """Every graph instance, depth-first from the top, in hyper-arc order."""

        # an explicit stack, not recursion: hierarchies may be nested arbitrarily deep
        stack: list[InstanceInfo] = [InstanceInfo("", self.top, 0, None)]
        while stack:
            info = stack.pop()
            yield info
            path = info.path
            subs = [
                InstanceInfo(qualify(path, h.name), h.lower, info.depth + 1, qualify(path, h.name))
                for h in self.graphs[info.key].hyperarcs.values()
                if h.lower is not None
            ]
            stack.extend(reversed(subs))

    def validate(self) -> list[FormatError]:
        """Validate every definition and every transition (M1/M2 mappings, recursion).

        Raises :class:`FormatError` on the first fault; returns the warnings.
        """
        fast = self._validate_flat()
        if fast is not None:
            self.warnings = fast
            return fast
        if (
            len(self.graphs) == 1
            and self.top_graph.hyperarcs
            and not any([h.lower is not None for h in self.top_graph.hyperarcs.values()])
        ):
            # one graph, no transition: nothing to check beyond the graph itself
            self.warnings = self.top_graph.validate()
            return self.warnings
        self._check_recursion()
        warnings: list[FormatError] = []
        used = self.used_keys()
        for key in used:
            warnings += self.graphs[key].validate()
        leaves: dict[str, list[str]] = {}  # of each lower definition, computed once
        self._transfers.clear()  # the definitions may have changed since the last call
        for key in used:
            g = self.graphs[key]
            for h in g.hyperarcs.values():
                if h.lower is not None:
                    if h.lower not in leaves:
                        leaves[h.lower] = self.graphs[h.lower].leaves()
                    self._check_transition(g, h, leaves[h.lower])
                    self.transfer(key, h.name)  # the literals of M1/M2 (raises on a mismatch)
        self.warnings = warnings
        return warnings

    def transfer(self, key: str, hyperarc: str) -> Transfer:
        """How groundings pass through the transition of hyper-arc ``hyperarc`` of graph
        ``key`` (M1/M2, eqs. 15-16); made once. Raises :class:`FormatError`, naming the
        upper file and line of the hyper-arc, when literals that correspond are not the same
        literal up to renaming (see :class:`Transfer` and ``docs/andor.md``)."""
        found = self._transfers.get((key, hyperarc))
        if found is None:
            upper = self.graphs[key]
            h = upper.hyperarc(hyperarc)
            if h.lower is None:
                raise UnknownNameError(f"hyper-arc {hyperarc!r} of {key!r} has no lower graph")
            found = self._transfers[(key, hyperarc)] = _transfer(upper, h, self.graphs[h.lower])
        return found

    def _validate_flat(self) -> list[FormatError] | None:
        """:meth:`validate` over the flat forms of graphs a reader left flat (no object per
        element is made): the same checks, the same warnings in the same order. None when a
        graph is not flat or anything is wrong: the element-wise checks then name it."""
        graphs = self.graphs
        top = graphs[self.top]._ix
        if top is None:
            return None
        # used_keys(): breadth-first discovery order (the order of the warnings)
        used = {self.top: top}
        queue = [top]
        for ix in queue:  # (grows while it is read)
            for _, low in ix.lower:
                if low not in used:
                    g = graphs.get(low)
                    sub = g._ix if g is not None else None
                    if sub is None:
                        return None
                    used[low] = sub
                    queue.append(sub)
        leaves: dict[str, int] = {}
        if len(used) > 1 or top.lower:
            self._check_recursion({key: ix.lower for key, ix in used.items()})
            # implicit M1: no fewer lower leaves than children (_check_transition)
            for ix in used.values():
                for j, low in ix.lower:
                    n = leaves.get(low)
                    if n is None:
                        n = leaves[low] = len(used[low].leaves)
                    if n < len(ix.children[j]):
                        return None
        warnings: list[FormatError] = []
        for key in used:
            g = graphs[key]
            done = g._validated  # a flat graph cannot change: the reader's checks hold
            warnings += done[1] if done is not None and g._ix is not None else g.validate()
        return warnings

    def _check_recursion(
        self, lowers: Mapping[str, Sequence[tuple[object, str]]] | None = None
    ) -> None:
        """Every lower graph is known and none refers back to one above it. ``lowers``: the
        (hyper-arc, lower graph key) pairs of every graph, in hyper-arc order (by default
        read from the objects; a reader's flat form has them as ``Indexed.lower``)."""
        if lowers is None:
            lowers = {
                key: [(h, h.lower) for h in g.hyperarcs.values() if h.lower is not None]
                for key, g in self.graphs.items()
            }
        # depth-first with an explicit stack: 1 = on the current trail, 2 = finished
        state: dict[str, int] = {self.top: 1}
        trail: list[str] = [self.top]
        stack = [iter(lowers[self.top])]
        while stack:
            nxt = next(stack[-1], None)
            if nxt is None:
                state[trail.pop()] = 2
                stack.pop()
                continue
            low = nxt[1]
            st = state.get(low)
            if st == 1 or low not in lowers:
                # the first hyper-arc of the graph on top of the trail that refers to it (an
                # earlier one would have been the fault)
                g = self.graphs[trail[-1]]
                h = next(h for h in g.hyperarcs.values() if h.lower == low)
                what = (
                    f": lower graphs refer to each other in a cycle ({' -> '.join([*trail, low])})"
                    if st == 1
                    else f" refers to unknown lower graph {low!r}"
                )
                raise FormatError(f"hyper-arc {h.name!r}{what}", g.source, h.line)
            if st is None:
                state[low] = 1
                trail.append(low)
                stack.append(iter(lowers[low]))

    def _check_transition(self, upper: AndOrGraph, h: Hyperarc, leaves: list[str]) -> None:
        assert h.lower is not None
        src, line = upper.source, h.line
        if h.leaf_map is None:
            # Implicit M1 (ANDOR text): the children of h as a whole correspond to the leaves
            # of the lower graph; each child stands for one or more leaves (eq. 15), so there
            # cannot be fewer leaves than children.
            if len(leaves) < len(h.children):
                raise FormatError(
                    f"hyper-arc {h.name!r} has {len(h.children)} children but its lower graph "
                    f"{h.lower!r} has only {len(leaves)} leaves: the mapping M1 of children to "
                    "leaves cannot hold",
                    src,
                    line,
                )
            return
        leaf_set = set(leaves)
        covered: set[str] = set()
        for child, mapped in h.leaf_map.items():
            if child not in h.children:
                raise FormatError(
                    f"hyper-arc {h.name!r}: leaf mapping names {child!r}, which is not one of its "
                    f"children {list(h.children)}",
                    src,
                    line,
                )
            for leaf in mapped:
                if leaf not in leaf_set:
                    raise FormatError(
                        f"hyper-arc {h.name!r}: leaf mapping sends {child!r} to {leaf!r}, which is "
                        f"not a leaf of lower graph {h.lower!r} (leaves: {leaves})",
                        src,
                        line,
                    )
                covered.add(leaf)
        missing_children = [c for c in h.children if c not in h.leaf_map]
        if missing_children:
            raise FormatError(
                f"hyper-arc {h.name!r}: leaf mapping does not map children {missing_children}",
                src,
                line,
            )
        missing_leaves = [leaf for leaf in leaves if leaf not in covered]
        if missing_leaves:
            raise FormatError(
                f"hyper-arc {h.name!r}: leaves {missing_leaves} of lower graph {h.lower!r} are "
                "mapped from no child",
                src,
                line,
            )

    def lint(self) -> list[FormatError]:
        """Structural oddities that loading accepts but a user wants to hear about (run by
        ``flexhrc graph validate``, not by :func:`load`): see :meth:`AndOrGraph.lint`."""
        out: list[FormatError] = []
        for key in self.used_keys():
            out += self.graphs[key].lint()
        return out

    # -- statistics -----------------------------------------------------------------------
    def stats(self) -> dict[str, object]:
        """Counts as in the paper: distinct definitions vs instantiated (every use counted)."""
        used = self.used_keys()
        inst = list(self.instances())
        return {
            "graphs": len(used),
            "nodes": sum(len(self.graphs[k].nodes) for k in used),
            "hyperarcs": sum(len(self.graphs[k].hyperarcs) for k in used),
            "layers": 1 + max(i.depth for i in inst),
            "instances": len(inst),
            "instantiated_nodes": sum(len(self.graphs[i.key].nodes) for i in inst),
            "instantiated_hyperarcs": sum(len(self.graphs[i.key].hyperarcs) for i in inst),
            "leaves": sum(len(self.graphs[i.key].leaves()) for i in inst),
            "top": self.top,
        }


# -- groundings through a transition (M1/M2) ----------------------------------------------
#: (lower literal, lower node, corresponding upper literals with their nodes)
_Item = tuple[Literal, Node, list[tuple[Literal, Node]]]


def _transfer(upper: AndOrGraph, h: Hyperarc, lower: AndOrGraph) -> Transfer:
    """:meth:`HierarchicalGraph.transfer`, made: the literals of h's children against those of
    the lower leaves M1 sends them to, then the literals of h's parent against the lower
    root's (M2), one substitution of lower variables by upper terms each."""
    if upper._ix is not None or lower._ix is not None:
        return _NOTHING  # a flat graph (as ANDOR text is read) states no formula
    nodes = upper.nodes
    children = [nodes[c] for c in h.children]
    parent = nodes[h.parent]
    if not (parent.formula or any(c.formula for c in children)):
        return _NOTHING
    low = lower.nodes
    # M1: a lower leaf's literals against those of the children mapped to it
    items: list[_Item] = []
    related: list[tuple[list[Node], list[Node]]] = []  # (children, their leaves) checked
    if h.leaf_map is None:
        # all children stand for all leaves: a child may describe what no leaf does (and a
        # leaf what no child does), so only corresponding literals are checked
        leaves = [low[n] for n in lower.leaves()]
        for leaf in leaves:
            for lit in leaf.formula or ():
                items.append((lit, leaf, _like(lit, children)))
    else:
        by_leaf: dict[str, list[Node]] = {}
        for c, mapped in h.leaf_map.items():
            related.append(([nodes[c]], [low[x] for x in mapped]))
            for x in mapped:
                by_leaf.setdefault(x, []).append(nodes[c])
        for x, cs in by_leaf.items():
            for lit in low[x].formula or ():
                items.append((lit, low[x], _like(lit, cs)))
    down = _solve(items, {}, lambda lv, term: None, upper, h, lower, "M1, eq. 15")
    _related(related, items, upper, h, lower, "its children", "leaves", "M1, eq. 15")
    # M2: the lower root's literals against the parent's; a lower variable M1 binds to a term
    # the children fix stays that term (a variable only the parent has is grounded from below)
    root = low[lower.root] if lower.root is not None else None
    if root is None or not root.formula or not parent.formula:
        return Transfer(down, {})
    fixed = {a for c in children for lit in c.formula or () for a in lit.args}

    def against_m1(lv: str, term: str) -> str | None:
        was = down.get(lv)
        if was is None or was == term or (is_variable(term) and term not in fixed):
            return None
        return f"{lv} is {was} through M1, not {term}"

    items = [(lit, root, _like(lit, [parent])) for lit in root.formula]
    up = _solve(items, {}, against_m1, upper, h, lower, "M2, eq. 16")
    _related([([parent], [root])], items, upper, h, lower, "its parent", "root", "M2, eq. 16")
    return Transfer(down, up)


def _like(lit: Literal, nodes: Sequence[Node]) -> list[tuple[Literal, Node]]:
    """The literals of ``nodes`` that correspond to ``lit``: same predicate, sign and arity."""
    return [
        (u, n)
        for n in nodes
        for u in n.formula or ()
        if u.predicate == lit.predicate
        and u.negated == lit.negated
        and len(u.args) == len(lit.args)
    ]


#: why a lower variable cannot stand for an upper term (None: it can)
_Veto = Callable[[str, str], str | None]


def _extend(theta: dict[str, str], low: Literal, up: Literal, veto: _Veto) -> dict[str, str] | str:
    """``theta`` extended so that ``low`` under it is ``up``, or why it cannot be."""
    out = dict(theta)
    for lt, ut in zip(low.args, up.args, strict=True):
        if is_variable(lt):
            was = out.get(lt)
            if was is None:
                why = veto(lt, ut)
                if why is not None:
                    return why
                out[lt] = ut
            elif was != ut:
                return f"{lt} would be both {was} and {ut}"
        elif lt != ut:
            what = "a variable" if is_variable(ut) else "the object " + ut
            return f"the lower graph names the object {lt} where {up} has {what}"
    return out


def _solve(
    items: list[_Item],
    theta: dict[str, str],
    veto: _Veto,
    upper: AndOrGraph,
    h: Hyperarc,
    lower: AndOrGraph,
    eq: str,
) -> dict[str, str]:
    """One substitution of lower variables by upper terms under which each lower literal with
    corresponding upper literals is one of them (the first, in definition order: backtracking
    with an explicit stack). Raises :class:`FormatError` at the hyper-arc's line when none
    exists, naming the lower literal that could not be matched."""
    todo = [it for it in items if it[2]]
    if not todo:
        return theta
    stack: list[tuple[int, dict[str, str]]] = [(0, theta)]  # (next candidate, theta before)
    worst = (-1, "")  # (deepest item that failed, why)
    steps = 0
    while stack:
        steps += 1
        depth = len(stack) - 1
        start, before = stack[-1]
        low, _, cands = todo[depth]
        for k in range(start, len(cands)):
            got = _extend(before, low, cands[k][0], veto)
            if isinstance(got, dict):
                stack[-1] = (k + 1, before)
                if depth + 1 == len(todo):
                    return got
                stack.append((0, got))
                break
            if depth >= worst[0] and (depth > worst[0] or not worst[1]):
                worst = (depth, got)
        else:
            stack.pop()
        if steps > 100_000:  # every choice tried is a different reading of the same file
            break
    low, node, cands = todo[max(worst[0], 0)]
    where = f"{lower.source}:{node.line}" if lower.source and node.line else lower.name
    raise FormatError(
        f"hyper-arc {h.name!r}: {node.name!r} of lower graph {h.lower!r} ({where}) states "
        f"{low}, and no corresponding literal above is the same literal up to renaming "
        f"({', '.join(f'{n.name!r}: {u}' for u, n in cands)}; {worst[1]}) — the mapping "
        f"({eq}) cannot carry a grounding",
        upper.source,
        h.line,
    )


def _related(
    related: list[tuple[list[Node], list[Node]]],
    items: list[_Item],
    upper: AndOrGraph,
    h: Hyperarc,
    lower: AndOrGraph,
    ours: str,
    theirs: str,
    eq: str,
) -> None:
    """Upper nodes and the lower nodes a mapping relates them to one by one (an explicit M1
    entry, M2), both stating formulas, must share at least one corresponding literal: else
    the two describe different things."""
    matched = {id(n) for _, _, cands in items for _, n in cands}
    for ups, lows in related:
        if not any(n.formula for n in lows):
            continue  # the lower side is propositional: nothing to relate
        stated = [n for n in ups if n.formula]
        if stated and not any(id(n) in matched for n in stated):
            said = "; ".join(f"{n.name!r}: {' & '.join(map(str, n.formula or ()))}" for n in stated)
            below = "; ".join(
                f"{n.name!r}: {' & '.join(map(str, n.formula))}" for n in lows if n.formula
            )
            raise FormatError(
                f"hyper-arc {h.name!r}: no literal of {ours} ({said}) corresponds to one of the "
                f"{theirs} of lower graph {h.lower!r} ({below}): the mapping ({eq}) relates "
                "states that share nothing",
                upper.source,
                h.line,
            )


def qualify(instance_path: str, name: str) -> str:
    """Qualified element name: ``name`` in the top graph, ``path/name`` in an instance."""
    return f"{instance_path}{SEP}{name}" if instance_path else name


def split_qualified(qualified: str) -> tuple[str, str]:
    """``"h4/h3/Node"`` -> ``("h4/h3", "Node")``; ``"Node"`` -> ``("", "Node")``."""
    path, _, name = qualified.rpartition(SEP)
    return path, name
