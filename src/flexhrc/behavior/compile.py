"""One task, two executors: THEN/AND/OR tasks as AND/OR graphs, and back.

:func:`compile_task` turns a task of paper 002 into a flexhrc hierarchical AND/OR graph (paper
000) whose cooperation paths are exactly the orders the task allows, so the same task can be run
by the behaviour network or handed to the Task Manager, which cooperates with people. Every
behaviour leaf ``b`` becomes exactly one hyper-arc named ``b`` with the action list ``[b]``
(weight 1); everything else is structure (weight 0, no action). With ``s`` the node that is met
when a sub-task may start and ``t`` the node it meets when it is achieved:

* behaviour ``b``: the hyper-arc ``b: [s] -> t``;
* ``THEN(c1 … ck)``: a chain ``s -> c1@done -> … -> t``;
* ``OR(c1 … ck)``: every alternative from ``s`` into the one parent ``t``. The first hyper-arcs
  of the alternatives share the child ``s``, and solving a hyper-arc makes every other hyper-arc
  that shares a child with it infeasible (paper 000, Algorithm 2) — so exactly one alternative
  can be carried out;
* ``AND(c1 … ck)``: in an AND/OR graph a node is consumed by one hyper-arc only, so a single node
  ``s`` cannot start k branches. A hyper-arc ``AND_i@start: [s] -> AND_i@started`` takes ``s``
  (which excludes the other alternatives of an enclosing OR right away), then the transition
  ``AND_i@expand: [AND_i@started] -> t`` expands into the lower graph ``AND_i`` (eq. 14): its
  leaves ``c@ready`` become feasible when ``AND_i@started`` is met, each branch runs from
  ``c@ready`` to ``c@done``, and *one hyper-arc with all children*, ``AND_i: [c1@done … ck@done]
  -> AND_i@done``, joins them; meeting the lower root solves ``AND_i@expand`` (eq. 18).

The graph has ``start`` as its only top leaf and ``done`` as its root; its size is linear in the
task (at most 3 hyper-arcs and 4 nodes per task node). ``@`` cannot occur in a behaviour name, so
structural names never clash with behaviours.

:func:`task_from_graph` is the reverse: it reads a graph as a task (a node with several incoming
hyper-arcs is an OR, a hyper-arc is THEN(AND(its children's tasks), its behaviour), a transition
is its lower graph's task) and refuses, with the reason, a graph that is not series-parallel.
"""

from __future__ import annotations

from typing import Any

from flexhrc.behavior.task import AND, BEHAVIOR, OR, THEN, Task, TaskNode, build_task
from flexhrc.errors import FlexhrcError
from flexhrc.representation.graph import AndOrGraph, Hyperarc
from flexhrc.representation.hierarchy import HierarchicalGraph

TOP = "task"
START = "start"
DONE = "done"


class NotSeriesParallelError(FlexhrcError):
    """An AND/OR graph that has no THEN/AND/OR task form; the message says why."""


class _EmptyAlternative(Exception):
    """Internal: two alternatives of which one is a prefix of the other."""


# ----------------------------------------------------------------------------- task -> graph


def compile_task(task: Task) -> HierarchicalGraph:
    """The AND/OR graph of ``task`` (see the module docstring); validated."""
    graphs: dict[str, AndOrGraph] = {}
    top = AndOrGraph(TOP, root=DONE, source=task.source)
    top.add_node(START)
    top.add_node(DONE)
    graphs[TOP] = top
    _emit(task.root, top, START, DONE, graphs)
    hierarchy = HierarchicalGraph(graphs, TOP)
    hierarchy.validate()
    return hierarchy


def _node(g: AndOrGraph, name: str) -> str:
    if name not in g.nodes:
        g.add_node(name)
    return name


def _emit(node: TaskNode, g: AndOrGraph, s: str, t: str, graphs: dict[str, AndOrGraph]) -> None:
    if node.kind == BEHAVIOR:
        g.add_hyperarc(Hyperarc(node.name, (s,), t, 1.0, (node.name,)))
    elif node.kind == THEN:
        prev = s
        last = len(node.children) - 1
        for i, child in enumerate(node.children):
            nxt = t if i == last else _node(g, f"{child.name}@done")
            _emit(child, g, prev, nxt, graphs)
            prev = nxt
    elif node.kind == OR:
        for child in node.children:
            _emit(child, g, s, t, graphs)
    else:
        assert node.kind == AND
        started = _node(g, f"{node.name}@started")
        g.add_hyperarc(Hyperarc(f"{node.name}@start", (s,), started))
        lower = AndOrGraph(node.name, root=f"{node.name}@done")
        ends = []
        for child in node.children:
            ready = _node(lower, f"{child.name}@ready")
            end = _node(lower, f"{child.name}@done")
            _emit(child, lower, ready, end, graphs)
            ends.append(end)
        _node(lower, f"{node.name}@done")
        lower.add_hyperarc(Hyperarc(node.name, tuple(ends), f"{node.name}@done"))
        graphs[node.name] = lower
        g.add_hyperarc(Hyperarc(f"{node.name}@expand", (started,), t, lower=node.name))


# ----------------------------------------------------------------------------- graph -> task

# A task under construction: None (nothing to do), a behaviour name, or (kind, [parts]).
_Part = Any


def task_from_graph(hierarchy: HierarchicalGraph, source: str = "<graph>") -> Task:
    """The THEN/AND/OR task of a series-parallel AND/OR graph.

    A hyper-arc with actions is a behaviour named after the hyper-arc; one without is structure.
    Raises :class:`NotSeriesParallelError` naming the node or hyper-arc that has no task form.
    """
    conv = _Converter(hierarchy, source)
    top = hierarchy.top_graph
    if top.root is None:
        raise NotSeriesParallelError(f"{source}: the top graph has no root")
    part = conv.node(hierarchy.top, top.root, 0)
    if part is None:
        raise NotSeriesParallelError(
            f"{source}: no hyper-arc on the way to the root has an action: nothing to do"
        )
    spec = _spec(part)
    seen: set[str] = set()
    for name in _behaviours(part):
        if name in seen:
            raise NotSeriesParallelError(
                f"{source}: hyper-arc {name!r} is needed on two branches that are not "
                "alternatives of one OR (a node is shared by two AND branches): not series-parallel"
            )
        seen.add(name)
    return build_task(spec, source)


class _Converter:
    def __init__(self, hierarchy: HierarchicalGraph, source: str) -> None:
        self.h = hierarchy
        self.source = source
        self.memo: dict[tuple[str, str], _Part] = {}
        self.used_lower: dict[str, str] = {}

    def fail(self, message: str) -> NotSeriesParallelError:
        return NotSeriesParallelError(f"{self.source}: {message}")

    def node(self, key: str, name: str, depth: int) -> _Part:
        if depth > 400:
            raise self.fail("the graph is nested too deeply to be a task")
        memo_key = (key, name)
        if memo_key in self.memo:
            return self.memo[memo_key]
        g = self.h.graphs[key]
        incoming = g.incoming(name)
        if not incoming:
            part: _Part = None  # a leaf: met when its graph starts
        else:
            alternatives = [self.arc(key, h, depth + 1) for h in incoming]
            try:
                part = _alternatives(alternatives)
            except _EmptyAlternative:
                where = f"node {name!r}" + (f" of graph {key!r}" if key != self.h.top else "")
                arcs = ", ".join(h.name for h in incoming)
                raise self.fail(
                    f"{where}: its hyper-arcs {arcs} include one that does nothing another does "
                    "not (an OR with an empty alternative) — give the hyper-arcs actions, or "
                    "this graph has no THEN/AND/OR form"
                ) from None
        self.memo[memo_key] = part
        return part

    def arc(self, key: str, h: Hyperarc, depth: int) -> _Part:
        children = [self.node(key, c, depth + 1) for c in h.children]
        parts: list[_Part] = [_flat(AND, [c for c in children if c is not None])]
        if h.lower is not None:
            if h.actions:
                raise self.fail(
                    f"hyper-arc {h.name!r} has both actions and a lower graph: a task leaf is "
                    "one behaviour"
                )
            if h.lower in self.used_lower:
                raise self.fail(
                    f"lower graph {h.lower!r} is used by hyper-arcs {self.used_lower[h.lower]!r} "
                    f"and {h.name!r}: its behaviours would appear twice in the task"
                )
            self.used_lower[h.lower] = h.name
            lower = self.h.graphs[h.lower]
            assert lower.root is not None
            parts.append(self.node(h.lower, lower.root, depth + 1))
        elif h.actions:
            from flexhrc.behavior.task import _NAME

            if not _NAME.match(h.name) or "@" in h.name:
                raise self.fail(
                    f"hyper-arc {h.name!r} has actions but its name is not a behaviour name "
                    "(letters, digits, _ - .)"
                )
            parts.append(h.name)
        return _flat(THEN, [p for p in parts if p is not None])


def _flat(kind: str, parts: list[_Part]) -> _Part:
    """``kind`` (THEN, AND or OR) of ``parts``, parts of the same kind merged into it and empty
    ones left out; a single part is itself (the same object: the OR factoring below compares by
    identity), no part at all is None."""
    if len(parts) == 1:
        return parts[0]
    flat: list[_Part] = []
    for p in parts:
        if isinstance(p, tuple) and p[0] == kind:
            flat.extend(p[1])
        elif p is not None:
            flat.append(p)
    if not flat:
        return None
    return flat[0] if len(flat) == 1 else (kind, flat)


def _alternatives(options: list[_Part]) -> _Part:
    """OR of the alternatives, with common prefixes factored out: alternatives that start with
    the same part (the same object, by memoisation: a node they all consume first) do it once,
    before they diverge — only one of them can consume that node."""
    if len(options) == 1:
        return options[0]
    return _or_of([list(o[1]) if isinstance(o, tuple) and o[0] == THEN else [o] for o in options])


def _or_of(seqs: list[list[_Part]]) -> _Part:
    groups: dict[int, list[list[_Part]]] = {}
    for seq in seqs:
        groups.setdefault(id(seq[0]), []).append(seq)
    out: list[_Part] = []
    for group in groups.values():
        if len(group) == 1:
            part = _flat(THEN, group[0])
        else:
            rests = [seq[1:] for seq in group]
            if any(not rest for rest in rests):
                raise _EmptyAlternative
            part = _flat(THEN, [group[0][0], _or_of(rests)])
        if part is None:  # an alternative that does nothing
            raise _EmptyAlternative
        out.append(part)
    return _flat(OR, out)


def _behaviours(part: _Part) -> list[str]:
    out: list[str] = []
    stack = [part]
    while stack:
        p = stack.pop()
        if p is None:
            continue
        if isinstance(p, str):
            out.append(p)
        else:
            stack.extend(p[1])
    return out


def _spec(part: _Part) -> Any:
    if isinstance(part, str):
        return (BEHAVIOR, part, None, None)
    kind, children = part
    return (kind, [_spec(c) for c in children], None, None)


def normalise(task: Task) -> str:
    """The prefix form with nested goals of the same kind merged and one-child goals removed —
    equal for tasks that allow the same orders by construction (used to compare round trips)."""

    def norm(node: TaskNode) -> _Part:
        if node.kind == BEHAVIOR:
            return node.name
        return _flat(node.kind, [norm(c) for c in node.children])

    def text(p: _Part) -> str:
        if isinstance(p, str):
            return p
        return "(" + " ".join([p[0], *(text(c) for c in p[1])]) + ")"

    return text(norm(task.root))
