"""Exact cooperation-path enumeration — the reference for the dynamic-programming costs.

A cooperation path cp (eq. 8) of a graph instance is a solution graph: the root, for every node
in it one incoming hyper-arc (OR choice) unless it is a leaf, and all children of every chosen
hyper-arc (AND). Its remaining cost is the sum of the weights of its nodes and hyper-arcs that
are not yet met/solved (eqs. 9, 11); a hyper-arc with a lower graph weighs the lower instance's
cheapest remaining path (eq. 19). Paths through an element that can no longer be taken are
excluded. The suggestion cost of a feasible element is the minimum over the paths containing it
(eq. 10), plus, for a lower instance, the cheapest upper path through its hyper-arc without that
hyper-arc's weight (Algorithm 6, line 27).

The number of paths grows exponentially (4^legs for the table assembly), so enumeration is
opt-in and guarded by ``limit``: past it, :class:`PathLimitError` says so.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

from flexhrc.errors import FlexhrcError
from flexhrc.representation.online import OnlineGraph

INF = math.inf
DEFAULT_LIMIT = 100_000


class PathLimitError(FlexhrcError):
    """Enumeration would exceed the allowed number of cooperation paths."""


def _paths(online: OnlineGraph, k: int, limit: int) -> list[frozenset[int]]:
    """Every cooperation path of instance k as a set of element ids (blocked ones excluded)."""
    g = online
    root = g._i_root[k]
    out: list[frozenset[int]] = []

    def expand(start: tuple[int, ...]) -> Iterator[frozenset[int]]:
        # depth-first over partial solution graphs, with an explicit stack (no recursion
        # limit on deep graphs): (nodes still to expand, elements chosen so far)
        stack: list[tuple[tuple[int, ...], frozenset[int]]] = [(start, frozenset())]
        while stack:
            todo, chosen = stack.pop()
            while todo and todo[0] in chosen:
                todo = todo[1:]
            if not todo:
                yield chosen
                continue
            n, rest = todo[0], todo[1:]
            if g._blocked[n]:
                continue
            arcs = g._in[n]
            if not arcs:
                stack.append((rest, chosen | {n}))
                continue
            for h in reversed(arcs):
                if not g._blocked[h]:
                    stack.append((rest + g._children[h], chosen | {n, h}))

    for p in expand((root,)):
        out.append(p)
        if len(out) > limit:
            raise PathLimitError(
                f"graph instance {g._i_path[k] or g._i_name[k]!r} has more than {limit} "
                "cooperation paths; use the dynamic-programming costs (the default) instead"
            )
    return out


def count_paths(online: OnlineGraph, limit: int = DEFAULT_LIMIT) -> dict[str, int]:
    """Number of cooperation paths of every graph instance (instance path -> count)."""
    online._materialise_all()  # enumeration walks every instance's structure
    return {online._i_path[k]: len(_paths(online, k, limit)) for k in range(len(online._i_key))}


def exact_costs(online: OnlineGraph, limit: int = DEFAULT_LIMIT) -> dict[str, float]:
    """Suggestion cost of every feasible element by enumerating paths (finite costs only)."""
    g = online
    g._materialise_all()  # enumeration walks every instance's structure
    n_inst = len(g._i_key)
    paths = [_paths(g, k, limit) for k in range(n_inst)]
    best: list[float | None] = [None] * n_inst  # cheapest remaining path cost of an instance

    def weight(e: int) -> float:
        if g._done[e]:
            return 0.0
        if g._kind[e] and g._lower[e] >= 0:
            return instance_best(g._lower[e])
        return g._w[e]

    def cost(p: frozenset[int]) -> float:
        return sum(weight(e) for e in p)

    def instance_best(k: int) -> float:
        if best[k] is None:
            best[k] = min((cost(p) for p in paths[k]), default=INF)
        return best[k]  # type: ignore[return-value]

    offsets: dict[int, float] = {}

    def offset(k: int) -> float:
        if k in offsets:
            return offsets[k]
        u = g._i_upper[k]
        if u < 0:
            val = 0.0
        elif g._blocked[u]:
            val = INF
        else:
            j = g._inst[u]
            through = [cost(p) for p in paths[j] if u in p]
            wu = weight(u)
            val = (min(through) - wu + offset(j)) if through and wu < INF else INF
        offsets[k] = val
        return val

    # instances are numbered depth-first from the top (an instance after the one above it):
    # fill the memos deepest first / top first so neither helper recurses more than a level
    for k in reversed(range(n_inst)):
        instance_best(k)
    for k in range(n_inst):
        offset(k)

    result: dict[str, float] = {}
    for e in g._feasible:
        k = g._inst[e]
        through = [cost(p) for p in paths[k] if e in p]
        if not through:
            continue
        c = min(through) + offset(k)
        if c < INF:
            result[g._names[e]] = c
    return result
