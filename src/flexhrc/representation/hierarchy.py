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
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

from flexhrc.errors import FormatError, UnknownNameError
from flexhrc.representation.graph import AndOrGraph, Hyperarc

SEP = "/"


@dataclass(frozen=True)
class InstanceInfo:
    """One use of a graph definition in the instantiated hierarchy."""

    path: str  # "" for the top graph, else "h4/h3"
    key: str  # definition key
    depth: int
    upper: str | None  # qualified name of the hyper-arc that created it


class HierarchicalGraph:
    """Graph definitions plus the key of the top graph G0."""

    def __init__(self, graphs: dict[str, AndOrGraph], top: str):
        if top not in graphs:
            raise UnknownNameError(f"top graph {top!r} is not among the graph definitions")
        self.graphs = graphs
        self.top = top
        self.warnings: list[FormatError] = []  # filled by validate(): harmless oddities

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
        for key in used:
            g = self.graphs[key]
            for h in g.hyperarcs.values():
                if h.lower is not None:
                    if h.lower not in leaves:
                        leaves[h.lower] = self.graphs[h.lower].leaves()
                    self._check_transition(g, h, leaves[h.lower])
        self.warnings = warnings
        return warnings

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


def qualify(instance_path: str, name: str) -> str:
    """Qualified element name: ``name`` in the top graph, ``path/name`` in an instance."""
    return f"{instance_path}{SEP}{name}" if instance_path else name


def split_qualified(qualified: str) -> tuple[str, str]:
    """``"h4/h3/Node"`` -> ``("h4/h3", "Node")``; ``"Node"`` -> ``("", "Node")``."""
    path, _, name = qualified.rpartition(SEP)
    return path, name
