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

Costs (eqs. 9-11, 19) are computed by dynamic programming instead of enumerating cooperation
paths (see ``docs/andor.md``): ``inside(x)`` is the cheapest remaining cost of achieving x from
what is already met, maintained incrementally (a change propagates to ancestors only while the
value changes); ``outside(x)`` is the cheapest remaining cost from x to the root, computed on
demand for the ancestors of feasible elements and memoised until the next cost change. Met and
solved elements weigh 0 (eq. 11); hyper-arcs that can no longer be taken weigh infinity; the
weight of a hyper-arc with a lower graph is the lower instance's optimal remaining cost (eq. 19).
The suggestion cost of a feasible element is ``inside + outside`` = the cheapest cooperation path
through it (eq. 10); for elements of a lower instance the upper path is added (Algorithm 6,
line 27). The DP equals exhaustive enumeration when no node is shared between AND branches; with
sharing it counts the shared part once per branch (``flexhrc.representation.paths`` has the exact,
exponential reference).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from flexhrc.errors import FlexhrcError, UnknownNameError
from flexhrc.representation.graph import AndOrGraph
from flexhrc.representation.hierarchy import SEP, HierarchicalGraph

INF = math.inf

Kind = Literal["node", "hyperarc"]


class InfeasibleUpdateError(FlexhrcError):
    """An update reported an element that is not feasible; nothing was changed."""


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

    def __init__(self, graph: HierarchicalGraph | AndOrGraph, *, validate: bool = True):
        if isinstance(graph, AndOrGraph):
            graph = HierarchicalGraph.single(graph)
        if validate:
            graph.validate()
        self.hierarchy = graph
        self._build()
        self._query = 0
        self.events: list[Event] = []
        self._gen = 1
        self._costs_gen = 0
        self._costs: dict[int, float] = {}
        self._outcome: str = "running"
        self._reason: str | None = None
        for k in range(len(self._i_key)):
            if self._i_upper[k] < 0:
                self._activate(k)
        self._finish()

    # ------------------------------------------------------------------ construction ----
    def _build(self) -> None:
        H = self.hierarchy
        templates: dict[str, _Template] = {}
        names: list[str] = []
        local: list[str] = []
        kinds: list[int] = []
        weight: list[float] = []
        inst_of: list[int] = []
        children: list[tuple[int, ...]] = []  # hyper-arcs: child node ids
        parent: list[int] = []  # hyper-arcs: parent node id
        lower: list[int] = []  # hyper-arcs: lower instance id or -1
        incoming: list[list[int]] = []  # nodes: hyper-arcs producing it
        outgoing: list[list[int]] = []  # nodes: hyper-arcs consuming it
        root_of: list[int] = []  # nodes: instance id if this node is an instance root
        i_path: list[str] = []
        i_key: list[str] = []
        i_root: list[int] = []
        i_upper: list[int] = []
        i_parent: list[int] = []
        i_leaves: list[list[int]] = []
        i_topo: list[list[int]] = []  # element ids, children before parents
        i_depth: list[int] = []
        i_span: list[tuple[int, int]] = []

        def instantiate(key: str, path: str, depth: int, upper: int, parent_inst: int) -> int:
            t = templates.get(key)
            if t is None:
                t = templates[key] = _Template(H.graphs[key])
            k = len(i_key)
            base = len(names)
            i_path.append(path)
            i_key.append(key)
            i_root.append(base + t.root)
            i_upper.append(upper)
            i_parent.append(parent_inst)
            i_leaves.append([base + x for x in t.leaves])
            i_topo.append([base + x for x in t.topo])
            i_depth.append(depth)
            i_span.append((base, base + t.size))
            prefix = f"{path}{SEP}" if path else ""
            names.extend([prefix + x for x in t.names])
            local.extend(t.names)
            kinds.extend(t.kinds)
            weight.extend(t.weights)
            inst_of.extend([k] * t.size)
            shift = base.__add__
            children.extend([tuple(map(shift, ch)) for ch in t.children])
            parent.extend([base + p if p >= 0 else -1 for p in t.parent])
            lower.extend([-1] * t.size)
            incoming.extend([list(map(shift, hs)) for hs in t.incoming])
            outgoing.extend([list(map(shift, hs)) for hs in t.outgoing])
            root_of.extend([-1] * t.size)
            root_of[base + t.root] = k
            for x, sub_key in t.lower:
                sub = f"{prefix}{t.names[x]}"
                lower[base + x] = instantiate(sub_key, sub, depth + 1, base + x, k)
            return k

        instantiate(H.top, "", 0, -1, -1)
        n = len(names)
        self._names = names
        self._local = local
        self._kind = kinds
        self._index = dict(zip(names, range(n), strict=True))
        self._w = weight
        self._inst = inst_of
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
        self._i_leaves = i_leaves
        self._i_span = i_span
        self._i_name = [H.graphs[k].name for k in i_key]
        # mutable state
        self._done = [False] * n  # met (nodes) / solved (hyper-arcs)
        self._blocked = [False] * n  # can no longer be taken (infeasible for good)
        self._unmet = [len(c) for c in children]  # hyper-arcs: children not yet met
        self._active = [False] * len(i_key)
        self._closed = [False] * len(i_key)
        self._feasible: dict[int, None] = {}
        self._live: dict[int, None] = {}  # active, not closed lower instances
        self._inside = [0.0] * n
        self._out_val = [0.0] * n
        self._out_gen = [0] * n
        # initial inside costs, deepest instances first (their roots weigh their upper arcs)
        # (every instance of one definition starts with the same values: compute them once)
        calc = self._calc_inside
        ins = self._inside
        first: dict[str, int] = {}
        for k in sorted(range(len(i_key)), key=lambda k: -i_depth[k]):
            lo, hi = i_span[k]
            seen = first.get(i_key[k])
            if seen is not None:
                slo, shi = i_span[seen]
                ins[lo:hi] = ins[slo:shi]
                continue
            first[i_key[k]] = k
            for e in i_topo[k]:
                ins[e] = calc(e)

    # ------------------------------------------------------------------ cost helpers ----
    def _calc_inside(self, e: int) -> float:
        if self._kind[e]:  # hyper-arc
            if self._blocked[e]:
                return INF
            if self._done[e]:
                own = 0.0
            elif self._lower[e] >= 0:
                own = self._inside[self._i_root[self._lower[e]]]  # eq. 19
            else:
                own = self._w[e]
            ins = self._inside
            for c in self._children[e]:
                own += ins[c]
            return own
        if self._blocked[e]:
            return INF
        own = 0.0 if self._done[e] else self._w[e]
        arcs = self._in[e]
        if not arcs:
            return own
        best = INF
        ins = self._inside
        for h in arcs:
            v = ins[h]
            if v < best:
                best = v
        return own + best

    def _propagate(self, start: int) -> None:
        """Recompute inside(start) and push changes to its ancestors (and upper arcs)."""
        ins = self._inside
        stack = [start]
        changed = False
        while stack:
            e = stack.pop()
            v = self._calc_inside(e)
            if v == ins[e]:
                continue
            ins[e] = v
            changed = True
            if self._kind[e]:
                stack.append(self._parent[e])
            else:
                stack.extend(self._out[e])
                k = self._root_of[e]
                if k >= 0 and self._i_upper[k] >= 0:
                    stack.append(self._i_upper[k])
        if changed:
            self._gen += 1

    def _outside(self, e: int) -> float:
        """Cheapest remaining cost from element e (node or hyper-arc) to the top root."""
        gen = self._gen
        if self._out_gen[e] == gen:
            return self._out_val[e]
        if self._kind[e]:
            p = self._parent[e]
            if self._blocked[p]:
                val = INF
            else:
                val = (0.0 if self._done[p] else self._w[p]) + self._outside(p)
        else:
            k = self._root_of[e]
            if k >= 0:
                u = self._i_upper[k]
                if u < 0:
                    val = 0.0
                elif self._blocked[u]:
                    val = INF
                else:
                    # the lower path replaces w(u) in the upper path (Algorithm 6, line 27)
                    val = self._outside(u)
                    ins = self._inside
                    for c in self._children[u]:
                        val += ins[c]
            else:
                val = INF
                ins = self._inside
                for h in self._out[e]:
                    if self._blocked[h]:
                        continue
                    own = 0.0 if self._done[h] else self._w[h]
                    if self._lower[h] >= 0 and not self._done[h]:
                        own = ins[self._i_root[self._lower[h]]]
                    for c in self._children[h]:
                        if c != e:
                            own += ins[c]
                    if own < val:
                        cand = own + self._outside(h)
                        if cand < val:
                            val = cand
        self._out_val[e] = val
        self._out_gen[e] = gen
        return val

    # -------------------------------------------------------------- feasibility rules ----
    def _add_feasible(self, e: int) -> None:
        self._feasible[e] = None

    def _drop_feasible(self, e: int) -> None:
        self._feasible.pop(e, None)
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
        """Instance k becomes active: its feasible leaves join the feasible set."""
        if self._active[k] or self._closed[k]:
            return
        self._active[k] = True
        if k:
            self._live[k] = None
        for n in self._i_leaves[k]:
            if self._node_feasible(n):
                self._add_feasible(n)

    def _close(self, k: int) -> None:
        """Instance k will never be used again (solved, or its upper arc is infeasible)."""
        if self._closed[k]:
            return
        self._closed[k] = True
        self._active[k] = False
        self._live.pop(k, None)
        inst = self._inst
        for e in [e for e in self._feasible if inst[e] == k]:
            self._drop_feasible(e)
        for e in self._i_hyperarcs(k):
            if self._lower[e] >= 0:
                self._close(self._lower[e])

    def _i_hyperarcs(self, k: int) -> Iterator[int]:
        # element ids of one instance are contiguous: its nodes, then its hyper-arcs
        kind = self._kind
        return (e for e in range(self._i_span[k][0], self._i_span[k][1]) if kind[e])

    def _meet(self, n: int) -> None:
        self._done[n] = True
        self._drop_feasible(n)
        self._propagate(n)
        for h in self._out[n]:
            self._unmet[h] -= 1
            if self._arc_enabled(h):
                if self._lower[h] >= 0:
                    self._activate(self._lower[h])
                else:
                    self._add_feasible(h)
        k = self._root_of[n]
        if k >= 0 and self._i_upper[k] >= 0:
            u = self._i_upper[k]
            if not self._done[u] and not self._blocked[u]:
                self._solve(u)  # eq. 18: the lower graph is solved, so is its upper arc

    def _solve(self, h: int) -> None:
        self._done[h] = True
        self._drop_feasible(h)
        if self._lower[h] >= 0:
            self._close(self._lower[h])
        p = self._parent[h]
        if self._node_feasible(p):
            self._add_feasible(p)
        # Algorithm 2, lines 8-13: alternatives sharing a child with h become infeasible
        for c in self._children[h]:
            for other in self._out[c]:
                if other != h and not self._blocked[other] and not self._done[other]:
                    self._block(other)
        self._propagate(h)

    def _block(self, e: int) -> None:
        self._blocked[e] = True
        self._drop_feasible(e)
        if self._kind[e]:
            if self._lower[e] >= 0:
                self._close(self._lower[e])
        else:
            for h in self._out[e]:
                if not self._blocked[h] and not self._done[h]:
                    self._block(h)
        self._propagate(e)
        self._gen += 1

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
        return self._query

    def element_id(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise UnknownNameError(_unknown(name, self._index)) from None

    def element_name(self, e: int) -> str:
        return self._names[e]

    def kind(self, name: str) -> Kind:
        return "hyperarc" if self._kind[self.element_id(name)] else "node"

    def weight(self, name: str) -> float:
        return self._w[self.element_id(name)]

    def is_met(self, node: str) -> bool:
        e = self.element_id(node)
        return not self._kind[e] and self._done[e]

    def is_solved(self, hyperarc: str) -> bool:
        e = self.element_id(hyperarc)
        return bool(self._kind[e]) and self._done[e]

    def is_feasible(self, name: str) -> bool:
        return self.element_id(name) in self._feasible

    def is_blocked(self, name: str) -> bool:
        return self._blocked[self.element_id(name)]

    def has_lower_graph(self, hyperarc: str) -> bool:
        return self._lower[self.element_id(hyperarc)] >= 0

    def graph_of(self, name: str) -> str:
        """Instance path of the graph instance an element belongs to ("" = top graph)."""
        return self._i_path[self._inst[self.element_id(name)]]

    def definition_of(self, name: str) -> AndOrGraph:
        return self.hierarchy.graphs[self._i_key[self._inst[self.element_id(name)]]]

    def local_name(self, name: str) -> str:
        return self._local[self.element_id(name)]

    def elements(self) -> list[str]:
        return list(self._names)

    def optimal_cost(self) -> float:
        """Remaining cost of the cheapest cooperation path of the whole task (eq. 9/11)."""
        return self._inside[self._i_root[0]]

    def query(self) -> QueryResult:
        """The current answer without reporting anything (query 0 of the protocol)."""
        return self.update()

    def update(
        self,
        met_nodes: Iterable[str] = (),
        solved_hyperarcs: Iterable[str] = (),
        infeasible: Iterable[str] = (),
    ) -> QueryResult:
        """Report met nodes and solved hyper-arcs (any instance); answer with the new state.

        Items are applied as soon as they are feasible, so one query may report a chain (e.g.
        a hyper-arc and then its parent). An item that is unknown, or never becomes feasible,
        raises an error and leaves the state unchanged. Reporting an element that is already
        met/solved is ignored (listed in :attr:`QueryResult.ignored`). ``infeasible`` marks
        elements as impossible (e.g. a robot action failed): hyper-arcs can no longer be solved,
        nodes no longer met, and every path through them is dropped.
        """
        items: list[tuple[str, int, str]] = []
        for name in met_nodes:
            e = self.element_id(name)
            if self._kind[e]:
                raise UnknownNameError(f"{name!r} is a hyper-arc, not a node: report it as solved")
            items.append(("met", e, name))
        for name in solved_hyperarcs:
            e = self.element_id(name)
            if not self._kind[e]:
                raise UnknownNameError(f"{name!r} is a node, not a hyper-arc: report it as met")
            items.append(("solved", e, name))
        blocks = [self.element_id(name) for name in infeasible]
        if self._outcome != "running" and (items or blocks):
            raise FlexhrcError(f"the cooperation is already {self._outcome}; nothing to update")
        self._query += 1
        ignored: list[str] = []
        if items or blocks:
            if len(items) == 1 and not blocks and items[0][1] in self._feasible:
                kind, e, name = items[0]
                self._apply(kind, e)
            else:
                ignored = self._apply_many(items, blocks)
        self._finish()
        return QueryResult(
            self._query,
            self._outcome == "solved",
            self._outcome == "failed",
            self._reason,
            dict(self._costs),
            self,
            ignored,
        )

    def mark_infeasible(self, *names: str) -> QueryResult:
        """Mark elements infeasible (for good) and answer with the new state."""
        return self.update(infeasible=names)

    def _apply(self, kind: str, e: int) -> None:
        self.events.append(Event(self._query, kind, self._names[e]))  # type: ignore[arg-type]
        if kind == "met":
            self._meet(e)
        elif kind == "solved":
            self._solve(e)
        else:
            self._block(e)
        self._check_failed_instances()

    def _apply_many(self, items: list[tuple[str, int, str]], blocks: list[int]) -> list[str]:
        snapshot = self._snapshot()
        n_events = len(self.events)
        ignored: list[str] = []
        try:
            for e in blocks:
                if not self._blocked[e] and not (self._done[e]):
                    self._apply("infeasible", e)
                else:
                    ignored.append(self._names[e])
            pending = []
            for kind, e, name in items:
                if self._done[e]:
                    ignored.append(name)
                else:
                    pending.append((kind, e, name))
            while pending:
                rest = []
                for kind, e, name in pending:
                    if self._done[e]:  # solved as a consequence (eq. 18)
                        continue
                    if e in self._feasible or (kind == "solved" and self._arc_enabled(e)):
                        self._apply(kind, e)
                    else:
                        rest.append((kind, e, name))
                if len(rest) == len(pending):
                    bad = ", ".join(f"{name} ({self._why_not(e)})" for _, e, name in rest)
                    raise InfeasibleUpdateError(f"not feasible, nothing changed: {bad}")
                pending = rest
        except BaseException:
            self._restore(snapshot)
            del self.events[n_events:]
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

    def _check_failed_instances(self) -> None:
        """A lower instance that can no longer be solved — nothing feasible left, or its root
        unreachable — makes its upper hyper-arc infeasible (eq. 17)."""
        inst = self._inst
        alive: set[int] = set()
        for e in self._feasible:
            k = inst[e]
            while k >= 0 and k not in alive:
                alive.add(k)
                k = self._i_parent[k]
        ins, roots = self._inside, self._i_root
        for k in [k for k in self._live if k not in alive or ins[roots[k]] == INF]:
            if self._active[k] and not self._closed[k]:
                u = self._i_upper[k]
                if not self._blocked[u] and not self._done[u]:
                    self._block(u)

    def _finish(self) -> None:
        top_root = self._i_root[0]
        if self._done[top_root]:
            self._outcome, self._reason = "solved", None
            self._costs = {}
            return
        gen = self._gen
        costs = self._costs
        if self._costs_gen != gen:
            costs.clear()
            self._costs_gen = gen
        ins = self._inside
        outside = self._outside
        for e in self._feasible:
            if e not in costs:
                c = ins[e] + outside(e)
                if c < INF:
                    costs[e] = c
        if not costs:
            self._outcome = "failed"
            self._reason = (
                "no feasible node or hyper-arc is left"
                if not self._feasible
                else "no feasible element is on a cooperation path that can still reach the root"
            )

    # ---------------------------------------------------------------- snapshot/state ----
    _STATE = ("_done", "_blocked", "_unmet", "_active", "_closed", "_inside")

    def _snapshot(self) -> tuple[Any, ...]:
        return (
            *(list(getattr(self, a)) for a in self._STATE),
            dict(self._feasible),
            dict(self._live),
            dict(self._costs),
            self._gen,
            self._costs_gen,
            self._outcome,
            self._reason,
        )

    def _restore(self, snap: tuple[Any, ...]) -> None:
        for a, v in zip(self._STATE, snap, strict=False):
            setattr(self, a, v)
        rest = snap[len(self._STATE) :]
        (
            self._feasible,
            self._live,
            self._costs,
            gen,
            self._costs_gen,
            self._outcome,
            self._reason,
        ) = rest
        self._gen = max(gen, self._gen) + 1  # invalidate memoised outside costs
        self._costs_gen = -1

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
        """Write the event history as JSON lines (one event per line)."""
        from flexhrc.jsonl import write_jsonl

        write_jsonl(path, (ev.to_dict() for ev in self.events))

    @staticmethod
    def load_events(path: str | Path) -> list[Event]:
        from flexhrc.errors import FormatError
        from flexhrc.jsonl import read_jsonl_lines

        events = []
        for line, d in read_jsonl_lines(path, required=("query", "type", "element")):
            try:
                ev = Event(int(d["query"]), d["type"], str(d["element"]))
            except (ValueError, TypeError) as exc:
                raise FormatError(f"malformed event: {exc}", path, line) from None
            if ev.type not in ("met", "solved", "infeasible"):
                raise FormatError(f"unknown event type {ev.type!r}", path, line)
            events.append(ev)
        return events

    @classmethod
    def replay(
        cls, graph: HierarchicalGraph | AndOrGraph, events: Iterable[Event | Mapping[str, Any]]
    ) -> OnlineGraph:
        """Rebuild the state reached by a recorded event history."""
        online = cls(graph)
        batch: list[Event] = []
        current: int | None = None

        def flush() -> None:
            if batch:
                online.update(
                    met_nodes=[ev.element for ev in batch if ev.type == "met"],
                    solved_hyperarcs=[ev.element for ev in batch if ev.type == "solved"],
                    infeasible=[ev.element for ev in batch if ev.type == "infeasible"],
                )

        for raw in events:
            ev = (
                raw
                if isinstance(raw, Event)
                else Event(int(raw["query"]), raw["type"], raw["element"])
            )
            if current is not None and ev.query != current:
                flush()
                batch = []
            current = ev.query
            batch.append(ev)
        flush()
        return online


class _Template:
    """Index structure of one graph definition, shared by all of its instances."""

    __slots__ = (
        "children",
        "incoming",
        "kinds",
        "leaves",
        "lower",
        "names",
        "outgoing",
        "parent",
        "root",
        "size",
        "topo",
        "weights",
    )

    def __init__(self, g: AndOrGraph):
        node_names = list(g.nodes)
        arc_list = list(g.hyperarcs.values())
        nn = len(node_names)
        idx = {name: i for i, name in enumerate(node_names)}
        self.names = node_names + [h.name for h in arc_list]
        self.size = len(self.names)
        self.kinds = [0] * nn + [1] * len(arc_list)
        self.weights = [float(n.weight) for n in g.nodes.values()] + [
            float(h.weight) for h in arc_list
        ]
        get = idx.__getitem__
        self.children: list[tuple[int, ...]] = [()] * nn + [
            tuple(map(get, h.children)) for h in arc_list
        ]
        self.parent = [-1] * nn + [idx[h.parent] for h in arc_list]
        self.incoming: list[list[int]] = [[] for _ in range(self.size)]
        self.outgoing: list[list[int]] = [[] for _ in range(self.size)]
        for j, h in enumerate(arc_list, nn):
            self.incoming[idx[h.parent]].append(j)
            for c in h.children:
                self.outgoing[idx[c]].append(j)
        self.root = idx[g.root]  # type: ignore[index]
        self.leaves = [i for i in range(nn) if not self.incoming[i]]
        self.topo: list[int] = []
        for name in g.topological_order():
            i = idx[name]
            self.topo.extend(self.incoming[i])
            self.topo.append(i)
        self.lower = [(j, h.lower) for j, h in enumerate(arc_list, nn) if h.lower is not None]


def _num(x: float) -> float | int | None:
    if x == INF:
        return None
    return int(x) if float(x).is_integer() else x


def _unknown(name: str, index: Mapping[str, int]) -> str:
    import difflib

    close = difflib.get_close_matches(name, list(index), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else ""
    return f"unknown element {name!r}{hint}"
