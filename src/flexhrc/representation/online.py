"""The online phase of a hierarchical AND/OR graph (paper 000, Algorithms 1-6).

:class:`OnlineGraph` instantiates a :class:`HierarchicalGraph` — every use of a lower graph is
its own instance — and keeps the statuses of every node and hyper-arc:

* ``met(n)`` / ``solved(h)`` — reported by the caller (the Task Manager);
* ``feasible(n)``: n is not met and is a leaf or has a solved incoming hyper-arc (eq. 6);
  ``feasible(h)``: every child of h is met and h is not solved (eq. 7);
* solving h makes every other hyper-arc that shares a child with h infeasible for good
  (Algorithm 2, lines 8-13);
* a hyper-arc with a lower graph (transition T, eq. 14) is feasible iff its lower instance is
  (eq. 17): when its children are met the instance becomes active and its leaves feasible; when
  the lower root is met the upper hyper-arc is solved (eq. 18, Algorithm 5 lines 7-10);
* the graph is solved when the top root is met; it has failed when no feasible element is left
  on a way to the root — a distinct, explicit outcome.

Costs (eqs. 9-11, 19) are computed by dynamic programming instead of enumerating cooperation paths
(see ``docs/andor.md``): ``inside(x)`` is the cheapest remaining cost of achieving x from what is
already met, maintained incrementally (a change propagates to ancestors only while the value
changes, and only as far as an inside cost is read during a query: above that, in the top graph, it
is marked out of date and recomputed when asked for — a feasible element's cost, the optimal cost —
so a step up a deep chain does not recompute everything above it); ``outside(x)`` is the cheapest
remaining cost from x to the root of its graph instance, kept exact by a top-down pass over what
each query changed (a heap in top-down order, so every element is recomputed once, after everything
above it); each lower instance has one *offset*, its root's outside cost in the whole hierarchy (the
upper path through its hyper-arc, Algorithm 6 line 27), so a change above an instance moves one
number, not its every element. Met and solved elements weigh 0 (eq. 11); hyper-arcs that can no
longer be taken weigh infinity; the weight of a hyper-arc with a lower graph is the lower instance's
optimal remaining cost (eq. 19). The suggestion cost of a feasible element is ``inside + outside +
offset`` = the cheapest cooperation path through it (eq. 10). A query costs what it changes: there
is no whole-graph pass, and no recursion anywhere (explicit stacks and queues). The DP equals
exhaustive enumeration when no node is shared between AND branches; with sharing it counts the
shared part once per branch (``flexhrc.representation.paths`` has the exact, exponential reference).
"""

from __future__ import annotations

import gc
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from heapq import heapify, heappop, heappush
from itertools import groupby, islice
from operator import attrgetter
from pathlib import Path
from typing import Any, Literal

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.events import GRAPH_EVENTS
from flexhrc.representation.graph import AndOrGraph, plain_number
from flexhrc.representation.hierarchy import SEP, HierarchicalGraph

INF = math.inf

Kind = Literal["node", "hyperarc"]


class InfeasibleUpdateError(FlexhrcError):
    """An update reported an element that is not feasible; nothing was changed."""


class GraphArgumentError(FlexhrcError, TypeError):
    """An argument of the graph API has the wrong type (a ``TypeError`` too)."""


@dataclass(frozen=True, slots=True)
class Suggestion:
    """A feasible element with the cost of the cheapest cooperation path through it."""

    element: str
    kind: Kind
    cost: float
    graph: str  # instance path ("" = top graph)
    graph_name: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "element": self.element,
            "kind": self.kind,
            "cost": _num(self.cost),
            "graph": self.graph,
            "graph_name": self.graph_name,
        }


@dataclass(frozen=True, slots=True)
class Event:
    """One reported status change: ``met`` node, ``solved`` hyper-arc or ``infeasible``."""

    query: int
    type: Literal["met", "solved", "infeasible"]
    element: str

    def to_dict(self) -> dict[str, Any]:
        return {"query": self.query, "type": self.type, "element": self.element}


@dataclass
class QueryResult:
    """The answer to one query: solved, failed, or the feasible elements with their costs."""

    query: int
    solved: bool
    failed: bool
    reason: str | None
    _costs: dict[int, float] = field(repr=False)
    _graph: OnlineGraph = field(repr=False)
    ignored: list[str] = field(default_factory=list)

    @property
    def outcome(self) -> str:
        return "solved" if self.solved else "failed" if self.failed else "running"

    @property
    def feasible(self) -> dict[str, float]:
        """Qualified name -> cost of every feasible element on a way to the root."""
        names = self._graph._names
        return {names[e]: c for e, c in self._costs.items()}

    @property
    def element_ids(self) -> dict[int, float]:
        """Element id -> cost (the raw form of :attr:`feasible`; ids are stable)."""
        return self._costs

    @property
    def suggestions(self) -> list[Suggestion]:
        """Feasible elements, cheapest first (ties: definition order, deterministic)."""
        g = self._graph
        order = sorted(self._costs.items(), key=lambda ec: (ec[1], ec[0]))
        return [g._suggestion(e, c) for e, c in order]

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"query": self.query, "outcome": self.outcome}
        if self.reason:
            out["reason"] = self.reason
        out["suggestions"] = [s.to_dict() for s in self.suggestions]
        if self.ignored:
            out["ignored"] = self.ignored
        return out


class OnlineGraph:
    """Run-time state of a (hierarchical) AND/OR graph: statuses, costs, suggestions, history.

    >>> from flexhrc.representation import AndOrGraph, OnlineGraph
    >>> g = AndOrGraph("demo", root="done")
    >>> for n in ("a", "b", "done"):
    ...     _ = g.add_node(n)
    >>> _ = g.add_hyperarc("h", ["a", "b"], "done", weight=1)
    >>> online = OnlineGraph(g)
    >>> sorted(online.query().feasible)
    ['a', 'b']
    >>> online.update(met_nodes=["a", "b"]).feasible
    {'h': 1.0}
    >>> online.update(solved_hyperarcs=["h"]).feasible
    {'done': 0.0}
    >>> online.update(met_nodes=["done"]).solved
    True
    """

    # slots: no per-instance dict to grow while ~50 attributes are set (offline time)
    __slots__ = (
        "__weakref__",
        "_active",
        "_blocked",
        "_children",
        "_closed",
        "_costs",
        "_dead",
        "_done",
        "_events",
        "_feasible",
        "_heap",
        "_i_depth",
        "_i_down",
        "_i_feas",
        "_i_key",
        "_i_leaves",
        "_i_lowers",
        "_i_mat",
        "_i_name",
        "_i_off",
        "_i_parent",
        "_i_path",
        "_i_pristine",
        "_i_root",
        "_i_span",
        "_i_tmpl",
        "_i_upper",
        "_in",
        "_index_cache",
        "_inside",
        "_inst",
        "_kind",
        "_lazy",
        "_live_below",
        "_log",
        "_lower",
        "_lrank",
        "_names",
        "_off_dirty",
        "_out",
        "_out_val",
        "_outcome",
        "_parent",
        "_query",
        "_queued",
        "_rank_span",
        "_reason",
        "_root_of",
        "_spent",
        "_stale",
        "_touched",
        "_unmet",
        "_w",
        "hierarchy",
    )

    # the fewest elements above which inside costs are left out of date (see _build)
    _LAZY_MIN = 64

    def __init__(self, graph: HierarchicalGraph | AndOrGraph, *, validate: bool = True):
        if isinstance(graph, AndOrGraph):
            graph = HierarchicalGraph.single(graph)
        elif not isinstance(graph, HierarchicalGraph):
            hint = (
                ": load the file first, OnlineGraph(flexhrc.representation.load(path))"
                if isinstance(graph, str | Path)
                else ""
            )
            raise GraphArgumentError(
                f"OnlineGraph needs an AndOrGraph or a HierarchicalGraph, got "
                f"{type(graph).__name__}{hint}"
            )
        if validate:
            graph.validate()
        self.hierarchy = graph
        self._query = 0
        self._log: list[tuple[int, str, int]] = []  # (query, type, element id)
        self._events: list[Event] = []  # Event objects of _log, made on demand
        self._costs: dict[int, float] = {}
        self._outcome: str = "running"
        self._reason: str | None = None
        # the build makes thousands of lists and tuples and no reference cycle: the cyclic
        # garbage collector's passes meanwhile would only scan them
        collecting = gc.isenabled()
        gc.disable()
        try:
            self._build()
            self._activate(0)  # the top instance (the only one without an upper hyper-arc)
            self._settle()
            self._finish()
        finally:
            if collecting:
                gc.enable()

    # ------------------------------------------------------------------ construction ----
    def _build(self) -> None:
        """Lay out every instance (ids, weights, kinds: cheap copies of its template) and
        *materialise* only the top one: the index structures of a lower instance (qualified
        names, child/parent/incoming/outgoing ids) are shifted copies of its template's, built
        when the instance above it becomes active (one level ahead: see :meth:`_activate`) or
        one of its elements is named (:meth:`_materialise`). Most instances of a deep
        hierarchy are not needed before the cooperation reaches them, and many never are (an
        OR branch not taken)."""
        H = self.hierarchy
        graphs = H.graphs
        templates: dict[str, _Template] = {}
        kinds: list[int] = []
        weight: list[float] = []
        inst_of: list[int] = []
        # one record per instance: (path, key, root, upper hyper-arc, parent instance, depth,
        # span, template), split into columns below
        recs: list[tuple[str, str, int, int, int, int, tuple[int, int], _Template]] = []
        i_lowers: list[list[int]] = []  # hyper-arcs of the instance that have a lower graph
        lower: list[int] = []  # hyper-arcs: lower instance id or -1
        root_of: list[int] = []  # nodes: instance id if this node is an instance root
        unmet: list[int] = []

        # depth-first, in hyper-arc order, with an explicit stack (no recursion limit)
        stack: list[tuple[str, str, int, int, int]] = [(H.top, "", 0, -1, -1)]
        pop, push = stack.pop, stack.append
        while stack:
            key, path, depth, upper, parent_inst = pop()
            t = templates.get(key)
            if t is None:
                t = templates[key] = _Template(graphs[key])
            k = len(recs)
            base = len(kinds)
            size = t.size
            recs.append(
                (path, key, base + t.root, upper, parent_inst, depth, (base, base + size), t)
            )
            kinds += t.kinds
            weight += t.weights
            inst_of += [k] * size
            unmet += t.n_children  # hyper-arcs: children not yet met (none is yet)
            minus = [-1] * size
            lower += minus
            root_of += minus
            root_of[base + t.root] = k
            if upper >= 0:
                lower[upper] = k
            if t.lower:
                i_lowers.append(list(map(base.__add__, t.lower_ids)))
                prefix = f"{path}{SEP}" if path else ""
                names_t = t.names
                for x, sub_key in reversed(t.lower):
                    push((sub_key, prefix + names_t[x], depth + 1, base + x, k))
            else:
                i_lowers.append([])
        i_path: list[str]
        i_key: list[str]
        i_root: list[int]
        i_upper: list[int]
        i_parent: list[int]
        i_depth: list[int]
        i_span: list[tuple[int, int]]
        i_tmpl: list[_Template]
        i_path, i_key, i_root, i_upper, i_parent, i_depth, i_span, i_tmpl = map(
            list, zip(*recs, strict=True)
        )

        n = len(kinds)
        # the top instance's structures are its template's; the others' are placeholders
        # until _materialise (None names: a premature read fails loudly)
        t0 = i_tmpl[0]
        t0.complete()
        rest = n - t0.size
        names: list[str] = t0.names + [None] * rest  # type: ignore[list-item]
        lrank = t0.lrank + [0] * rest  # position in the instance's top-down order
        children = t0.children + [()] * rest  # hyper-arcs: child node ids
        parent = t0.parent + [-1] * rest  # hyper-arcs: parent node id
        incoming = t0.incoming + [()] * rest  # nodes: hyper-arcs producing it
        outgoing = t0.outgoing + [()] * rest  # nodes: hyper-arcs consuming it
        n_inst = len(i_key)
        self._names = names
        self._kind = kinds
        self._index_cache: dict[str, int] | None = None
        self._w = weight
        self._inst = inst_of
        self._lrank = lrank
        self._rank_span = max([t.size for t in templates.values()]) + 1
        self._children = children
        self._parent = parent
        self._lower = lower
        self._in = incoming
        self._out = outgoing
        self._root_of = root_of
        self._i_path = i_path
        self._i_key = i_key
        self._i_root = i_root
        self._i_upper = i_upper
        self._i_parent = i_parent
        # element ids of each instance's leaves / top-down order: set by _materialise
        self._i_leaves: list[list[int]] = [t0.leaves] + [[] for _ in range(n_inst - 1)]
        self._i_down: list[list[int]] = [t0.down] + [[] for _ in range(n_inst - 1)]
        self._i_mat = [True] + [False] * (n_inst - 1)
        self._i_lowers = i_lowers
        self._i_depth = i_depth
        self._i_span = i_span
        self._i_tmpl = i_tmpl
        # an instance is pristine until one of its elements (or of the instances below it) is
        # marked infeasible: then its costs at activation are not its definition's any more
        self._i_pristine = [True] * n_inst
        self._i_name = [H.graphs[k].name for k in i_key]
        # mutable state
        self._done = [False] * n  # met (nodes) / solved (hyper-arcs)
        self._blocked = [False] * n  # can no longer be taken (infeasible for good)
        # spent: met, solved or blocked, and so is everything below it (the incoming arcs of a
        # node, the children of an arc): no live element reads its outside cost any more, so
        # the top-down pass stops there instead of walking down everything already done (a
        # deep chain: each query would walk the whole done part of it, R12)
        self._spent = [False] * n
        # of an element met, solved or blocked: how many of the elements below it are not
        # spent yet (-1 before: counted when it is retired, :meth:`_retire`)
        self._live_below = [-1] * n
        self._unmet = unmet
        self._active = [False] * n_inst
        self._closed = [False] * n_inst
        self._feasible: dict[int, None] = {}
        # outside costs relative to the element's instance root, kept exact for the elements
        # of active instances; the instance's own offset (its root's outside cost in the whole
        # hierarchy) is separate, so a change above an instance does not touch its elements
        self._out_val = [0.0] * n
        self._i_off = [0.0] * n_inst
        self._i_feas: list[dict[int, None]] = [{} for _ in i_key]  # feasible, per instance
        self._off_dirty: set[int] = set()
        # work lists of one query: outside costs to recompute (a heap in top-down order),
        # elements whose cost may have changed, lower instances whose root became unreachable
        self._heap: list[int] = []
        self._queued: set[int] = set()
        self._touched: set[int] = set()
        self._dead: list[int] = []
        # initial inside costs: every instance of one definition starts with the same values,
        # its template's, computed once in the template's own ids. Instances are numbered
        # depth-first (each after the one above it), so in reverse order every definition is
        # met after all the definitions below its first instance.
        for k in range(n_inst - 1, -1, -1):
            t = i_tmpl[k]
            if t.inside is None:
                t.pristine_inside([i_tmpl[lower[base]].root_inside() for base in i_lowers[k]])
        ins: list[float] = []
        for t in i_tmpl:
            ins.extend(t.inside)  # type: ignore[arg-type]
        self._inside = ins
        # inside costs nothing reads during a query (see _Template.unread_inside) are brought
        # up to date only when read (_pull): stale ones are marked, never recomputed on the way
        # up. A deep chain: each solved hyper-arc changes the inside cost of everything above
        # it, O(depth) per query if every one were recomputed (R12). Where there are only a
        # few such elements (the authors' graphs: at most 33), recomputing them costs a query
        # less than the marks and the later reads would
        unread = t0.unread_inside()
        if sum(unread) < self._LAZY_MIN:
            unread = [False] * t0.size
        self._lazy = unread + [False] * rest
        self._stale = [False] * n

    def _materialise(self, k: int) -> None:
        """Build the index structures of instance k (and of the instances above it) from its
        template: qualified names and shifted child/parent/incoming/outgoing ids."""
        chain = []
        mat, up = self._i_mat, self._i_parent
        while k >= 0 and not mat[k]:
            chain.append(k)
            k = up[k]
        names, children, parent = self._names, self._children, self._parent
        incoming, outgoing, index = self._in, self._out, self._index_cache
        for k in reversed(chain):
            mat[k] = True
            t = self._i_tmpl[k]
            t.complete()
            lo, hi = self._i_span[k]
            self._lrank[lo:hi] = t.lrank
            # (comprehensions with "+": a call of int.__add__ per id costs twice as much; most
            # nodes have one incoming and one outgoing hyper-arc: a tuple of one made directly)
            shift = lo.__add__
            prefix = self._i_path[k] + SEP
            qualified = [prefix + x for x in t.names]
            names[lo:hi] = qualified
            # nodes have no children and no parent, hyper-arcs no incoming or outgoing arcs:
            # their placeholders (the empty tuple, -1) are already right
            mid = lo + t.n_nodes
            children[mid:hi] = [
                (ch[0] + lo,) if len(ch) == 1 else tuple(map(shift, ch)) for ch in t.arc_children
            ]
            parent[mid:hi] = [p + lo for p in t.arc_parent]
            incoming[lo:mid] = [
                () if not hs else (hs[0] + lo,) if len(hs) == 1 else tuple(map(shift, hs))
                for hs in t.node_incoming
            ]
            outgoing[lo:mid] = [
                () if not hs else (hs[0] + lo,) if len(hs) == 1 else tuple(map(shift, hs))
                for hs in t.node_outgoing
            ]
            self._i_leaves[k] = [x + lo for x in t.leaves]
            self._i_down[k] = [x + lo for x in t.down]
            if index is not None:
                index.update(zip(qualified, range(lo, hi), strict=True))

    def _materialise_all(self) -> None:
        mat = self._i_mat
        for k in range(len(mat)):
            if not mat[k]:
                self._materialise(k)

    def _resolve(self, name: str) -> int:
        """Element id of a qualified name in any instance, materialising its instance (the
        index knows only materialised ones); -1 if there is no such element."""
        parts = name.split(SEP)
        k = 0
        for part in parts[:-1]:
            x = self._i_tmpl[k].local_index().get(part, -1)
            if x < 0:
                return -1
            k = self._lower[self._i_span[k][0] + x]
            if k < 0:
                return -1
        x = self._i_tmpl[k].local_index().get(parts[-1], -1)
        if x < 0:
            return -1
        self._materialise(k)
        e = self._i_span[k][0] + x
        return e if self._names[e] == name else -1

    @property
    def _index(self) -> dict[str, int]:
        # qualified name -> element id, built on the first lookup by name (offline time matters)
        # (of the materialised instances; _materialise adds the others as they come)
        idx = self._index_cache
        if idx is None:
            names, span = self._names, self._i_span
            idx = {}
            for k, m in enumerate(self._i_mat):
                if m:
                    lo, hi = span[k]
                    idx.update(zip(names[lo:hi], range(lo, hi), strict=True))
            self._index_cache = idx
        return idx

    # ------------------------------------------------------------------ cost helpers ----
    def _calc_offset(self, k: int) -> float:
        """Outside cost of the root of instance k in the whole hierarchy: the lower path
        replaces w(u) in the upper path through its hyper-arc u (Algorithm 6, line 27)."""
        u = self._i_upper[k]
        if u < 0:
            return 0.0
        if self._blocked[u]:
            return INF
        val = self._out_val[u] + self._i_off[self._inst[u]]
        ins = self._inside
        for c in self._children[u]:
            val += ins[c]
        return val

    def _push(self, e: int) -> None:
        """Queue the outside cost of e for the top-down pass of this query."""
        if e not in self._queued and not self._spent[e]:
            self._queued.add(e)
            rank = self._i_depth[self._inst[e]] * self._rank_span + self._lrank[e]
            heappush(self._heap, (rank << 32) | e)

    def _status_changed(self, e: int) -> None:
        """Outside costs that read the status (met/solved/blocked) of e."""
        push = self._push
        self._touched.add(e)
        if self._kind[e]:
            for c in self._children[e]:
                push(c)
            if self._lower[e] >= 0:
                self._off_dirty.add(self._lower[e])
        else:
            for h in self._in[e]:
                push(h)

    def _settle(self) -> None:
        """The top-down pass: recompute queued outside costs, parents before children, and
        queue the elements below each one that changed. Touches only what the query changed.

        The outside cost of a hyper-arc is its parent's plus the parent's own weight; of a node,
        the cheapest over the hyper-arcs that consume it of (their weight, their other
        children's inside costs, their outside cost); of an instance root, 0 (relative to the
        root: see _calc_offset). Infinite through anything that can no longer be taken.
        """
        heap = self._heap
        if not heap:
            if self._off_dirty:
                self._settle_offsets()
            return
        out, kind, inst, active = self._out_val, self._kind, self._inst, self._active
        touched, queued = self._touched, self._queued
        idepth, lrank, span = self._i_depth, self._lrank, self._rank_span
        lower, children, incoming, outgoing = self._lower, self._children, self._in, self._out
        parent, done, blocked, w = self._parent, self._done, self._blocked, self._w
        ins, roots, root_of, spent = self._inside, self._i_root, self._root_of, self._spent
        dirty = self._off_dirty
        mask = (1 << 32) - 1
        while heap:
            e = heappop(heap) & mask
            queued.discard(e)
            if not active[inst[e]]:
                continue  # computed in full when the instance becomes active
            if kind[e]:
                p = parent[e]
                v = INF if blocked[p] else (0.0 if done[p] else w[p]) + out[p]
                if v == out[e]:
                    continue
                out[e] = v
                touched.add(e)
                for c in children[e]:
                    if c not in queued and not spent[c]:
                        queued.add(c)
                        heappush(heap, (((idepth[inst[c]] * span + lrank[c]) << 32) | c))
                if lower[e] >= 0:
                    dirty.add(lower[e])
                continue
            if root_of[e] >= 0:
                continue  # 0, relative to the instance root
            v = INF
            for h in outgoing[e]:
                if blocked[h]:
                    continue
                if done[h]:
                    own = 0.0
                elif lower[h] >= 0:
                    own = ins[roots[lower[h]]]
                else:
                    own = w[h]
                for c in children[h]:
                    if c != e:
                        own += ins[c]
                own += out[h]
                if own < v:
                    v = own
            if v == out[e]:
                continue
            out[e] = v
            touched.add(e)
            for h in incoming[e]:
                if h not in queued and not blocked[h] and not spent[h]:
                    queued.add(h)
                    heappush(heap, (((idepth[inst[h]] * span + lrank[h]) << 32) | h))
        self._settle_offsets()

    def _settle_offsets(self) -> None:
        """Recompute the dirty instance offsets, upper instances first; an offset that
        changes moves the costs of its instance's feasible elements and the offsets below."""
        dirty = self._off_dirty
        if not dirty:
            return
        depth, active, off = self._i_depth, self._active, self._i_off
        if len(dirty) == 1:
            k = dirty.pop()
            if not self._i_lowers[k]:  # the common case: one instance, nothing below it
                if active[k]:
                    v = self._calc_offset(k)
                    if v != off[k]:
                        self._move_offset(k, v)
                return
            dirty.add(k)
        heap = [(depth[k], k) for k in dirty]
        dirty.clear()
        heapify(heap)
        seen: set[int] = set()
        while heap:
            _, k = heappop(heap)
            if k in seen or not active[k]:
                continue
            seen.add(k)
            v = self._calc_offset(k)
            if v == off[k]:
                continue
            self._move_offset(k, v)
            for h in self._i_lowers[k]:
                heappush(heap, (depth[k] + 1, self._lower[h]))

    def _move_offset(self, k: int, v: float) -> None:
        """Instance k's offset is now v: so moves the cost of each of its feasible elements."""
        self._i_off[k] = v
        costs, ins, out = self._costs, self._inside, self._out_val
        for e in self._i_feas[k]:
            c = ins[e] + out[e] + v
            if c < INF:
                costs[e] = c
            else:
                costs.pop(e, None)

    def _propagate(self, start: int) -> None:
        """Recompute inside(start) and push changes to its ancestors (and upper arcs).

        The hot path of every query: what a changed inside(x) re-queues (the outside costs of
        x's AND siblings, lower-instance offsets) is inlined here.
        """
        ins = self._inside
        kind, parent, outgoing = self._kind, self._parent, self._out
        root_of, upper = self._root_of, self._i_upper
        done, blocked, lower, w = self._done, self._blocked, self._lower, self._w
        children, incoming, roots = self._children, self._in, self._i_root
        touched, dirty = self._touched, self._off_dirty
        heap, queued, inst = self._heap, self._queued, self._inst
        idepth, lrank, span = self._i_depth, self._lrank, self._rank_span
        spent, lazy = self._spent, self._lazy
        stack = [start]
        while stack:
            e = stack.pop()
            if kind[e]:  # hyper-arc
                if blocked[e]:
                    v = INF
                else:
                    if done[e]:
                        v = 0.0
                    elif lower[e] >= 0:
                        v = ins[roots[lower[e]]]  # eq. 19
                    else:
                        v = w[e]
                    for c in children[e]:
                        v += ins[c]
                if v == ins[e]:
                    continue
                ins[e] = v
                touched.add(e)
                stack.append(parent[e])
                continue
            if blocked[e]:
                v = INF
            else:
                v = 0.0 if done[e] else w[e]
                arcs = incoming[e]
                if arcs:
                    best = INF
                    for h in arcs:
                        x = ins[h]
                        if x < best:
                            best = x
                    v += best
            if v == ins[e]:
                continue
            if lazy[e]:
                # nothing reads it during a query (nor what is above it): marked out of date
                # with everything above it, computed when asked for (_pull). A hyper-arc below
                # it may be computed from out-of-date children meanwhile: then it is out of
                # date itself, so its value is never read before _pull recomputes it
                if not self._stale[e]:
                    self._stale_up(e)
                continue
            ins[e] = v
            # outside costs that read inside(e): its AND siblings, lower-instance offsets
            touched.add(e)
            for h in outgoing[e]:
                for s in children[h]:
                    # a spent element's outside cost is never read again (statuses are for good)
                    if s != e and s not in queued and not spent[s]:
                        queued.add(s)
                        heappush(heap, (((idepth[inst[s]] * span + lrank[s]) << 32) | s))
                if lower[h] >= 0:
                    dirty.add(lower[h])
            stack.extend(outgoing[e])
            k = root_of[e]
            if k >= 0:
                u = upper[k]
                if u >= 0:
                    for s in children[u]:  # inside(e) is the weight of u (eq. 19)
                        if s not in queued and not spent[s]:
                            queued.add(s)
                            heappush(heap, (((idepth[inst[s]] * span + lrank[s]) << 32) | s))
                    if v == INF and self._active[k]:
                        self._dead.append(k)
                    stack.append(u)

    def _stale_up(self, x: int) -> None:
        """inside(x) is out of date, and so is everything that reads it, in turn: marked stale
        up to the first element that already is (whatever is above a stale element is)."""
        stale = self._stale
        if stale[x]:
            return
        kind, parent, outgoing, touched = self._kind, self._parent, self._out, self._touched
        todo = [x]
        while todo:
            e = todo.pop()
            if stale[e]:
                continue
            stale[e] = True
            touched.add(e)  # a feasible one's cost is read (_pull) at the end of the query
            if kind[e]:
                todo.append(parent[e])
            else:
                todo.extend(outgoing[e])

    def _pull(self, x: int) -> float:
        """inside(x), brought up to date with whatever stale element is below it (children
        before parents, each once; everything below x is up to date afterwards)."""
        stale, ins = self._stale, self._inside
        if not stale[x]:
            return ins[x]
        kind, children, incoming, roots = self._kind, self._children, self._in, self._i_root
        done, blocked, lower, w = self._done, self._blocked, self._lower, self._w
        stack = [x]
        while stack:
            e = stack[-1]
            if not stale[e]:  # reached twice (a node shared by two hyper-arcs)
                stack.pop()
                continue
            n_waiting = len(stack)
            for c in children[e] if kind[e] else incoming[e]:
                if stale[c]:
                    stack.append(c)
            if len(stack) > n_waiting:
                continue
            stack.pop()
            # the formulas of _propagate, in its order (the same floats)
            if blocked[e]:
                v = INF
            elif kind[e]:
                if done[e]:
                    v = 0.0
                elif lower[e] >= 0:
                    v = ins[roots[lower[e]]]
                else:
                    v = w[e]
                for c in children[e]:
                    v += ins[c]
            else:
                v = 0.0 if done[e] else w[e]
                arcs = incoming[e]
                if arcs:
                    best = INF
                    for h in arcs:
                        y = ins[h]
                        if y < best:
                            best = y
                    v += best
            ins[e] = v
            stale[e] = False
        return ins[x]

    # -------------------------------------------------------------- feasibility rules ----
    def _add_feasible(self, e: int) -> None:
        self._feasible[e] = None
        self._i_feas[self._inst[e]][e] = None
        self._touched.add(e)

    def _retire(self, e: int) -> None:
        """e is now met, solved or blocked: count what below it is still live; when nothing
        is, e is spent, and so, in turn, may be the elements above it."""
        live, spent, kind = self._live_below, self._spent, self._kind
        if live[e] >= 0:
            return  # retired already (blocked after met)
        below = self._children[e] if kind[e] else self._in[e]
        live[e] = sum(1 for c in below if not spent[c])
        if live[e]:
            return
        todo = [e]
        parent, outgoing = self._parent, self._out
        while todo:
            x = todo.pop()
            if spent[x]:
                continue
            spent[x] = True
            # above x: the arcs a node feeds, the node an arc reaches (within its instance)
            for p in outgoing[x] if not kind[x] else (parent[x],):
                if live[p] > 0:  # retired, waiting for what is below it
                    live[p] -= 1
                    if not live[p]:
                        todo.append(p)

    def _drop_feasible(self, e: int) -> None:
        self._feasible.pop(e, None)
        self._i_feas[self._inst[e]].pop(e, None)
        self._costs.pop(e, None)

    def _node_feasible(self, n: int) -> bool:
        if self._done[n] or self._blocked[n] or not self._active[self._inst[n]]:
            return False
        arcs = self._in[n]
        if not arcs:
            return True
        done = self._done
        return any(done[h] for h in arcs)

    def _arc_enabled(self, h: int) -> bool:
        return (
            not self._done[h]
            and not self._blocked[h]
            and self._unmet[h] == 0
            and self._active[self._inst[h]]
        )

    def _activate(self, k: int) -> None:
        """Instance k becomes active: its outside costs are computed, its feasible leaves join
        the feasible set."""
        if self._active[k] or self._closed[k]:
            return
        mat = self._i_mat
        if not mat[k]:
            self._materialise(k)
        # one level ahead: the instances just below k can become active from now on, and the
        # query that activates one should not pay for building it
        for h in self._i_lowers[k]:
            if not mat[self._lower[h]]:
                self._materialise(self._lower[h])
        self._active[k] = True
        if k:
            # its offset now; a later change this query above it re-dirties it (_settle and
            # _propagate do), and its elements' costs are computed from _touched at the end
            self._i_off[k] = self._calc_offset(k)
        if self._i_pristine[k]:
            # as its definition left it: the outside costs every pristine instance of this
            # definition starts with, computed once; every leaf is feasible
            lo, hi = self._i_span[k]
            self._out_val[lo:hi] = self._i_tmpl[k].pristine_outside()
            leaves = self._i_leaves[k]
            fresh = dict.fromkeys(leaves)
            self._feasible.update(fresh)
            self._i_feas[k].update(fresh)
            self._touched.update(leaves)
        else:
            push = self._push
            for e in self._i_down[k]:  # every outside cost, in this query's top-down pass
                push(e)
            for n in self._i_leaves[k]:
                if self._node_feasible(n):
                    self._add_feasible(n)
        if k and self._inside[self._i_root[k]] == INF:
            self._dead.append(k)

    def _close(self, k: int) -> None:
        """Instance k will never be used again (solved, or its upper arc is infeasible); so
        are the instances below it."""
        todo = [k]
        feasible = self._feasible
        while todo:
            k = todo.pop()
            if self._closed[k]:
                continue
            self._closed[k] = True
            self._active[k] = False
            if feasible:
                lo, hi = self._i_span[k]
                for e in [e for e in range(lo, hi) if e in feasible]:
                    self._drop_feasible(e)
            for h in self._i_lowers[k]:
                todo.append(self._lower[h])

    def _meet(self, n: int) -> None:
        # hot path: _drop_feasible, _status_changed, _arc_enabled, _add_feasible inlined
        done = self._done
        done[n] = True
        self._retire(n)
        k = self._inst[n]
        self._feasible.pop(n, None)
        self._i_feas[k].pop(n, None)
        self._costs.pop(n, None)
        touched = self._touched  # (n itself is not feasible any more: no cost to refresh)
        if self._w[n]:
            for h in self._in[n]:  # their outside costs read w(n), which met(n) zeroes
                self._push(h)
        # a met node's inside cost is 0: nothing moves if it was already (or if it is out of date:
        # so is everything above it, and _pull will read the new status)
        if self._inside[n]:
            self._propagate(n)
        unmet, blocked, lower = self._unmet, self._blocked, self._lower
        for h in self._out[n]:  # n was feasible: its instance (h's) is active
            unmet[h] -= 1
            if unmet[h] == 0 and not done[h] and not blocked[h]:
                if lower[h] >= 0:
                    self._activate(lower[h])
                else:
                    self._feasible[h] = None
                    self._i_feas[k][h] = None
                    touched.add(h)
        r = self._root_of[n]
        if r >= 0:
            u = self._i_upper[r]
            if u >= 0 and not done[u] and not blocked[u]:
                self._solve(u)  # eq. 18: the lower graph is solved, so is its upper arc

    def _solve(self, h: int) -> None:
        lower = self._lower[h]
        # the outside costs of h's children read its own weight, which solved(h) zeroes: the
        # weight, or for a lower graph its root's inside cost (0 when eq. 18 solves h)
        own = self._inside[self._i_root[lower]] if lower >= 0 else self._w[h]
        self._done[h] = True
        self._retire(h)
        self._drop_feasible(h)
        self._touched.add(h)
        if own:
            for c in self._children[h]:
                self._push(c)
        if lower >= 0:
            self._close(lower)
        p = self._parent[h]
        if self._node_feasible(p):
            self._add_feasible(p)
        # h's cost first: its inside cost drops to 0, so do the costs above it, up to the
        # root. The alternatives blocked next (their inside cost INF) then stop where they meet
        # h's way up (an OR node keeps its cheapest arc: h), instead of each walking the whole
        # way up and h undoing it; the final costs are the same in either order.
        if self._inside[h]:  # a solved hyper-arc's inside cost is 0 (as in _meet)
            self._propagate(h)
        # Algorithm 2, lines 8-13: alternatives sharing a child with h become infeasible
        for c in self._children[h]:
            for other in self._out[c]:
                if other != h and not self._blocked[other] and not self._done[other]:
                    self._block(other)

    def _block(self, e: int) -> None:
        # a blocked node blocks the hyper-arcs that consume it (one level: arcs block nothing)
        todo = [e]
        while todo:
            e = todo.pop()
            if self._blocked[e]:
                continue
            self._blocked[e] = True
            self._retire(e)
            k = self._inst[e]
            while k >= 0 and self._i_pristine[k]:
                self._i_pristine[k] = False
                k = self._i_parent[k]
            self._drop_feasible(e)
            self._status_changed(e)
            if self._kind[e]:
                if self._lower[e] >= 0:
                    self._close(self._lower[e])
            else:
                for h in self._out[e]:
                    if not self._blocked[h] and not self._done[h]:
                        todo.append(h)
            self._propagate(e)

    # ------------------------------------------------------------------ public API ------
    @property
    def solved(self) -> bool:
        return self._outcome == "solved"

    @property
    def failed(self) -> bool:
        return self._outcome == "failed"

    @property
    def outcome(self) -> str:
        """``running``, ``solved`` or ``failed``."""
        return self._outcome

    @property
    def queries(self) -> int:
        """Number of answered queries (a rejected update is not counted)."""
        return self._query

    @property
    def events(self) -> list[Event]:
        """The event history: every accepted status change, in order."""
        evs, log = self._events, self._log
        if len(evs) != len(log):
            names = self._names
            del evs[len(log) :]
            evs.extend(Event(q, t, names[e]) for q, t, e in log[len(evs) :])  # type: ignore[arg-type]
        return evs

    def element_id(self, name: str) -> int:
        if not isinstance(name, str):
            raise GraphArgumentError(
                f"an element name must be a string, got {type(name).__name__} {name!r}"
            )
        e = self._index.get(name, -1)
        if e < 0:
            e = self._resolve(name)  # an element of an instance not materialised yet
        if e < 0:
            self._materialise_all()  # every name, for the message's suggestions
            e = self._index.get(name, -1)
            if e < 0:
                raise UnknownNameError(_unknown(name, self._index))
        return e

    def element_name(self, e: int) -> str:
        if isinstance(e, bool) or not isinstance(e, int):
            raise GraphArgumentError(f"an element id must be an int, got {type(e).__name__}")
        if not 0 <= e < len(self._names):
            raise UnknownNameError(f"no element with id {e} (0..{len(self._names) - 1})")
        self._materialise(self._inst[e])
        return self._names[e]

    def kind(self, name: str) -> Kind:
        return "hyperarc" if self._kind[self.element_id(name)] else "node"

    def weight(self, name: str) -> float:
        return self._w[self.element_id(name)]

    def is_met(self, node: str) -> bool:
        """Whether node ``node`` is met; a hyper-arc name raises :class:`UnknownNameError`."""
        e = self.element_id(node)
        if self._kind[e]:
            raise UnknownNameError(f"{node!r} is a hyper-arc, not a node: ask is_solved()")
        return self._done[e]

    def is_solved(self, hyperarc: str) -> bool:
        """Whether hyper-arc ``hyperarc`` is solved; a node name raises
        :class:`UnknownNameError`."""
        e = self.element_id(hyperarc)
        if not self._kind[e]:
            raise UnknownNameError(f"{hyperarc!r} is a node, not a hyper-arc: ask is_met()")
        return self._done[e]

    def is_feasible(self, name: str) -> bool:
        return self.element_id(name) in self._feasible

    def is_blocked(self, name: str) -> bool:
        return self._blocked[self.element_id(name)]

    def graph_of(self, name: str) -> str:
        """Instance path of the graph instance an element belongs to ("" = top graph)."""
        return self._i_path[self._inst[self.element_id(name)]]

    def definition_of(self, name: str) -> AndOrGraph:
        return self.hierarchy.graphs[self._i_key[self._inst[self.element_id(name)]]]

    def local_name(self, name: str) -> str:
        e = self.element_id(name)
        k = self._inst[e]
        return self._i_tmpl[k].names[e - self._i_span[k][0]]

    def elements(self) -> list[str]:
        self._materialise_all()
        return list(self._names)

    def optimal_cost(self) -> float:
        """Remaining cost of the cheapest cooperation path of the whole task (eq. 9/11)."""
        return self._pull(self._i_root[0])

    def query(self) -> QueryResult:
        """The current answer without reporting anything (query 0 of the protocol)."""
        return self.update()

    def _ids(self, names: Iterable[str], what: str) -> list[int]:
        if type(names) is tuple or type(names) is list:  # the common case, cheap
            index = self._index
            try:
                return [index[name] for name in names]
            except (KeyError, TypeError):
                pass  # the checks below name the culprit
        if isinstance(names, str | bytes) or not isinstance(names, Iterable):
            raise GraphArgumentError(
                f"{what} must be a list of element names, got {type(names).__name__}"
                + (f" {names!r}: wrap it in a list" if isinstance(names, str) else "")
            )
        return [self.element_id(name) for name in names]

    def update(
        self,
        met_nodes: Iterable[str] = (),
        solved_hyperarcs: Iterable[str] = (),
        infeasible: Iterable[str] = (),
    ) -> QueryResult:
        """Report met nodes and solved hyper-arcs (any instance); answer with the new state.

        Items are applied as soon as they are feasible, so one query may report a chain (e.g.
        a hyper-arc and then its parent). An item that is unknown, or never becomes feasible,
        raises an error and leaves the state unchanged (and the query is not counted).
        Reporting an element that is already met/solved is ignored (listed in
        :attr:`QueryResult.ignored`). ``infeasible`` marks elements as impossible (e.g. a robot
        action failed): hyper-arcs can no longer be solved, nodes no longer met, and every path
        through them is dropped. Wrong argument types raise :class:`GraphArgumentError` (a
        ``TypeError``).
        """
        # the common query (the Task Manager's, the test client's): one element, nothing else
        query = 0
        ignored: list[str] = []
        if (
            not infeasible
            and self._outcome == "running"
            and (type(met_nodes) is tuple or type(met_nodes) is list)
            and (type(solved_hyperarcs) is tuple or type(solved_hyperarcs) is list)
            and len(met_nodes) + len(solved_hyperarcs) == 1
        ):
            name = met_nodes[0] if met_nodes else solved_hyperarcs[0]
            index = self._index_cache or self._index
            e = index.get(name, -1) if type(name) is str else -1
            if e in self._feasible and bool(self._kind[e]) != bool(met_nodes):
                query = self._query + 1
                # _apply, inlined
                if met_nodes:
                    self._log.append((query, "met", e))
                    self._meet(e)
                else:
                    self._log.append((query, "solved", e))
                    self._solve(e)
                if self._dead:
                    self._apply_dead()
                if self._heap or self._off_dirty:
                    self._settle()
        if not query:
            query, ignored = self._update_many(met_nodes, solved_hyperarcs, infeasible)
        self._query = query
        self._finish()
        outcome = self._outcome
        return QueryResult(
            query,
            outcome == "solved",
            outcome == "failed",
            self._reason,
            dict(self._costs),
            self,
            ignored,
        )

    def _update_many(
        self,
        met_nodes: Iterable[str],
        solved_hyperarcs: Iterable[str],
        infeasible: Iterable[str],
    ) -> tuple[int, list[str]]:
        """:meth:`update` of anything but one feasible element: the query's number and the
        elements it ignored (already met or solved)."""
        if met_nodes is None or solved_hyperarcs is None or infeasible is None:
            what = (
                "met_nodes"
                if met_nodes is None
                else ("solved_hyperarcs" if solved_hyperarcs is None else "infeasible")
            )
            raise GraphArgumentError(f"{what} must be a list of element names, got None")
        kinds = self._kind
        items: list[tuple[str, int]] = []
        if met_nodes:
            for e in self._ids(met_nodes, "met_nodes"):
                if kinds[e]:
                    raise UnknownNameError(
                        f"{self._names[e]!r} is a hyper-arc, not a node: report it as solved"
                    )
                items.append(("met", e))
        if solved_hyperarcs:
            for e in self._ids(solved_hyperarcs, "solved_hyperarcs"):
                if not kinds[e]:
                    raise UnknownNameError(
                        f"{self._names[e]!r} is a node, not a hyper-arc: report it as met"
                    )
                items.append(("solved", e))
        blocks = self._ids(infeasible, "infeasible") if infeasible else []
        if self._outcome != "running" and (items or blocks):
            raise FlexhrcError(f"the cooperation is already {self._outcome}; nothing to update")
        query = self._query + 1
        return query, self._apply_many(query, items, blocks) if items or blocks else []

    def mark_infeasible(self, *names: str) -> QueryResult:
        """Mark elements infeasible (for good) and answer with the new state."""
        return self.update(infeasible=names)

    def _apply(self, query: int, kind: str, e: int) -> None:
        self._log.append((query, kind, e))
        if kind == "met":
            self._meet(e)
        elif kind == "solved":
            self._solve(e)
        else:
            self._block(e)
        if self._dead:
            self._apply_dead()

    def _apply_many(self, query: int, items: list[tuple[str, int]], blocks: list[int]) -> list[str]:
        snapshot = self._snapshot()
        n_events = len(self._log)
        ignored: list[str] = []
        names = self._names
        try:
            for e in blocks:
                if not self._blocked[e] and not (self._done[e]):
                    self._apply(query, "infeasible", e)
                else:
                    ignored.append(names[e])
            pending = []
            for kind, e in items:
                if self._done[e]:
                    ignored.append(names[e])
                else:
                    pending.append((kind, e))
            while pending:
                rest = []
                for kind, e in pending:
                    if self._done[e]:  # solved as a consequence (eq. 18)
                        continue
                    if e in self._feasible or (kind == "solved" and self._arc_enabled(e)):
                        self._apply(query, kind, e)
                    else:
                        rest.append((kind, e))
                if len(rest) == len(pending):
                    bad = ", ".join(f"{names[e]} ({self._why_not(e)})" for _, e in rest)
                    raise InfeasibleUpdateError(f"not feasible, nothing changed: {bad}")
                pending = rest
            self._settle()
        except BaseException:
            self._restore(snapshot)
            del self._log[n_events:]
            raise
        return ignored

    def _why_not(self, e: int) -> str:
        if self._blocked[e]:
            return "infeasible: an alternative was taken or it was marked infeasible"
        k = self._inst[e]
        if not self._active[k]:
            if self._closed[k]:
                return f"its graph instance {self._i_path[k]!r} is closed"
            up = self._names[self._i_upper[k]]
            return f"its graph instance waits for the children of {up!r} to be met"
        if self._kind[e]:
            missing = [self._names[c] for c in self._children[e] if not self._done[c]]
            return f"children not met: {', '.join(missing)}"
        return "no incoming hyper-arc is solved"

    def _apply_dead(self) -> None:
        """A lower instance whose root can no longer be reached makes its upper hyper-arc
        infeasible (eq. 17)."""
        dead = self._dead
        while dead:
            k = dead.pop()
            if self._active[k]:
                u = self._i_upper[k]
                if not self._blocked[u] and not self._done[u]:
                    self._block(u)

    def _finish(self) -> None:
        """Costs of the elements this query touched; the outcome."""
        touched = self._touched
        if self._done[self._i_root[0]]:
            self._outcome, self._reason = "solved", None
            self._costs = {}
            touched.clear()
            return
        if touched:
            costs, feasible = self._costs, self._feasible
            ins, out, off, inst = self._inside, self._out_val, self._i_off, self._inst
            stale = self._stale
            for e in touched:
                if e in feasible:
                    c = (self._pull(e) if stale[e] else ins[e]) + out[e] + off[inst[e]]
                    if c < INF:
                        costs[e] = c
                    else:
                        costs.pop(e, None)
            touched.clear()
        if not self._costs:
            self._outcome = "failed"
            self._reason = (
                "no feasible node or hyper-arc is left"
                if not self._feasible
                else "no feasible element is on a cooperation path that can still reach the root"
            )

    # ---------------------------------------------------------------- snapshot/state ----
    _STATE = (
        "_done",
        "_blocked",
        "_spent",
        "_live_below",
        "_unmet",
        "_active",
        "_closed",
        "_inside",
        "_stale",
        "_out_val",
        "_i_off",
    )

    def _snapshot(self) -> tuple[Any, ...]:
        return (
            *(list(getattr(self, a)) for a in self._STATE),
            dict(self._feasible),
            dict(self._costs),
            [dict(d) for d in self._i_feas],
            self._outcome,
            self._reason,
        )

    def _restore(self, snap: tuple[Any, ...]) -> None:
        for a, v in zip(self._STATE, snap, strict=False):
            setattr(self, a, v)
        rest = snap[len(self._STATE) :]
        (self._feasible, self._costs, self._i_feas, self._outcome, self._reason) = rest
        self._heap.clear()
        self._queued.clear()
        self._touched.clear()
        self._dead.clear()
        self._off_dirty.clear()

    def state(self) -> dict[str, Any]:
        """A plain, comparable description of the whole state (for tests and debugging)."""
        names = self._names
        return {
            "outcome": self._outcome,
            "met": sorted(names[e] for e, d in enumerate(self._done) if d and not self._kind[e]),
            "solved": sorted(names[e] for e, d in enumerate(self._done) if d and self._kind[e]),
            "blocked": sorted(names[e] for e, b in enumerate(self._blocked) if b),
            "feasible": sorted(names[e] for e in self._feasible),
            "active_graphs": sorted(self._i_path[k] for k, a in enumerate(self._active) if a),
            "costs": {names[e]: c for e, c in sorted(self._costs.items())},
        }

    def _suggestion(self, e: int, cost: float) -> Suggestion:
        k = self._inst[e]
        return Suggestion(
            self._names[e],
            "hyperarc" if self._kind[e] else "node",
            cost,
            self._i_path[k],
            self._i_name[k],
        )

    def suggestions(self) -> list[Suggestion]:
        """The current suggestions, cheapest first."""
        return QueryResult(
            self._query, self.solved, self.failed, None, self._costs, self
        ).suggestions

    # ------------------------------------------------------------------ history ---------
    def save_events(self, path: str | Path) -> None:
        """Write the event history as JSON lines (one event per line), atomically."""
        from flexhrc.files import atomic_write_text

        atomic_write_text(path, "".join(json.dumps(ev.to_dict()) + "\n" for ev in self.events))

    @staticmethod
    def load_events(path: str | Path) -> list[Event]:
        from flexhrc.errors import FormatError
        from flexhrc.jsonl import read_jsonl_lines

        events = []
        for line, d in read_jsonl_lines(path, required=("query", "type", "element")):
            try:
                ev = _event(d)
            except (ValueError, TypeError) as exc:
                raise FormatError(f"malformed event: {exc}", path, line) from None
            events.append(ev)
        return events

    @classmethod
    def replay(
        cls, graph: HierarchicalGraph | AndOrGraph, events: Iterable[Event | Mapping[str, Any]]
    ) -> OnlineGraph:
        """Rebuild the state reached by a recorded event history.

        Every event is checked first (a mapping with ``query``, ``type`` and ``element``; a
        known type): a bad one raises :class:`GraphArgumentError` naming its position.
        """
        if isinstance(events, str | bytes | Mapping) or not isinstance(events, Iterable):
            raise GraphArgumentError(
                f"events must be a list of events, got {type(events).__name__}"
            )
        checked: list[Event] = []
        for i, raw in enumerate(events):
            try:
                checked.append(_event(raw))
            except (ValueError, TypeError) as exc:
                raise GraphArgumentError(f"event {i}: {exc}") from None
        online = cls(graph)
        for _, same_query in groupby(checked, key=attrgetter("query")):
            batch = list(same_query)
            online.update(
                met_nodes=[ev.element for ev in batch if ev.type == "met"],
                solved_hyperarcs=[ev.element for ev in batch if ev.type == "solved"],
                infeasible=[ev.element for ev in batch if ev.type == "infeasible"],
            )
        return online


def _event(raw: object) -> Event:
    """An :class:`Event` checked, or made from a mapping; ValueError/TypeError saying what is
    wrong."""
    d = raw.to_dict() if isinstance(raw, Event) else raw
    if not isinstance(d, Mapping):
        raise TypeError(
            f"expected a mapping with query, type and element, got {type(raw).__name__}"
        )
    missing = [k for k in ("query", "type", "element") if k not in d]
    if missing:
        raise ValueError(f"missing {', '.join(missing)}")
    q, t, el = d["query"], d["type"], d["element"]
    if isinstance(q, bool) or not isinstance(q, int) or q < 0:
        raise ValueError(f"query must be a non-negative integer, got {q!r}")
    if t not in GRAPH_EVENTS:
        raise ValueError(f"unknown event type {t!r} (expected one of {', '.join(GRAPH_EVENTS)})")
    if not isinstance(el, str) or not el:
        raise ValueError(f"element must be a non-empty name, got {el!r}")
    return raw if isinstance(raw, Event) else Event(q, t, el)


class _Template:
    """Index structure of one graph definition, shared by all of its instances."""

    __slots__ = (
        "arc_children",
        "arc_parent",
        "children",
        "down",
        "idx",
        "incoming",
        "inside",
        "ix",
        "kinds",
        "leaves",
        "lower",
        "lower_ids",
        "lrank",
        "n_children",
        "n_nodes",
        "names",
        "node_incoming",
        "node_outgoing",
        "outgoing",
        "own",
        "parent",
        "pristine_out",
        "root",
        "size",
        "topo",
        "weights",
    )

    def __init__(self, g: AndOrGraph):
        # the flat form of the definition: the reader's (no object per element), or made now
        ix = g.indexed()
        nn = self.n_nodes = ix.n_nodes
        size = len(ix.names)
        self.names = ix.names
        self.size = size
        self.kinds = [0] * nn + [1] * (size - nn)
        self.weights = ix.weights
        self.children = ix.children
        self.parent = ix.parent
        self.incoming = ix.incoming
        self.root = ix.root
        self.leaves = ix.leaves
        self.topo = ix.topo  # the order of the inside pass: children before parents
        self.ix = ix
        # what only a materialised instance needs: set by complete()
        self.outgoing: list[tuple[int, ...]] = []
        self.down: list[int] = []
        self.lrank: list[int] = []
        self.pristine_out: list[float] | None = None  # set by pristine_outside
        self.own: list[float] = []  # set by pristine_inside
        self.lower = ix.lower
        self.lower_ids = [x for x, _ in ix.lower] if ix.lower else []
        self.n_children = list(map(len, ix.children))
        self.inside: list[float] | None = None  # set by pristine_inside
        self.idx: dict[str, int] | None = None  # set by local_index

    def pristine_inside(self, lower_roots: list[float]) -> None:
        """Inside costs of an instance nothing of which is met yet (eqs. 9, 19), children
        before parents; ``lower_roots``: the inside cost of each lower graph's root, in the
        order of :attr:`lower`."""
        children, incoming = self.children, self.incoming
        own = list(self.weights)
        for (j, _), v in zip(self.lower, lower_roots, strict=True):
            own[j] = v  # eq. 19: a hyper-arc with a lower graph weighs its optimal cost
        self.own = own
        # a leaf's inside cost is its weight; the order starts with the leaves
        ins = own[:]
        for e in islice(self.topo, len(self.leaves), None):
            ch = children[e]
            if ch:  # a hyper-arc (a node has no children)
                v = own[e]
                for c in ch:  # (in order, as _calc_inside adds them: the same float)
                    v += ins[c]
                ins[e] = v
            else:
                arcs = incoming[e]
                if len(arcs) == 1:
                    ins[e] = own[e] + ins[arcs[0]]
                else:
                    ins[e] = own[e] + min([ins[h] for h in arcs])
        self.inside = ins

    def complete(self) -> None:
        """The parts an instance needs once it is materialised: the consumers of every node,
        the top-down order (parents before children: the outside pass) and its ranks."""
        if self.down or not self.size:
            return
        self.outgoing = self.ix.outgoing
        nn = self.n_nodes
        self.arc_children = self.children[nn:]
        self.arc_parent = self.parent[nn:]
        self.node_incoming = self.incoming[:nn]
        self.node_outgoing = self.outgoing[:nn]
        self.down = self.topo[::-1]
        lrank = [0] * self.size
        for r, x in enumerate(self.down):
            lrank[x] = r
        self.lrank = lrank

    def pristine_outside(self) -> list[float]:
        """Outside costs (to the instance root) of an instance nothing of which is met yet,
        parents before children: the values ``OnlineGraph._settle`` computes then."""
        out = self.pristine_out
        if out is None:
            self.complete()
            kinds, parent, w, own = self.kinds, self.parent, self.weights, self.own
            children, outgoing, ins, root = self.children, self.outgoing, self.inside, self.root
            assert ins is not None
            out = [0.0] * self.size
            for e in self.down:
                if kinds[e]:
                    p = parent[e]
                    out[e] = w[p] + out[p]
                elif e != root:
                    v = INF
                    for h in outgoing[e]:
                        x = own[h]
                        for c in children[h]:
                            if c != e:
                                x += ins[c]
                        x += out[h]
                        if x < v:
                            v = x
                    out[e] = v
            self.pristine_out = out
        return out

    def unread_inside(self) -> list[bool]:
        """Of each element of the top graph: whether its inside cost, and that of everything
        above it, is read by nothing but the element above it during a query, so may be left
        stale until asked for (``OnlineGraph._pull``: a feasible element's cost, the optimal
        cost). A node's is read also by the other children of a hyper-arc it feeds (their
        outside costs) and by the offset of a hyper-arc's lower graph; the root of a lower graph
        is read by its upper hyper-arc's children and offsets (only the top graph is asked)."""
        self.complete()
        kinds, parent, outgoing, children = self.kinds, self.parent, self.outgoing, self.children
        with_lower = set(self.lower_ids)
        unread = [False] * self.size
        for e in self.down:  # parents before children
            if kinds[e]:
                unread[e] = unread[parent[e]]
            else:
                unread[e] = all(
                    unread[h] and len(children[h]) == 1 and h not in with_lower for h in outgoing[e]
                )
        return unread

    def root_inside(self) -> float:
        assert self.inside is not None
        return self.inside[self.root]

    def local_index(self) -> dict[str, int]:
        """Local name -> template id (a name used by a node and a hyper-arc: the hyper-arc)."""
        if self.idx is None:
            self.idx = dict(zip(self.names, range(self.size), strict=True))
        return self.idx


def _num(x: float) -> float | int | None:
    return None if x == INF else plain_number(x)


def _unknown(name: str, index: Mapping[str, int]) -> str:
    import difflib

    close = difflib.get_close_matches(name, list(index), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return f"unknown element {name!r}{hint}"
