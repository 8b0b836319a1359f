"""Synthetic AND/OR graphs for scale tests and benchmarks (issue 9, item 5): a seeded random
tree and a chain, the two shapes the engine's per-query cost is measured on."""

from __future__ import annotations

import random

from flexhrc.representation.graph import AndOrGraph


def random_tree(n_nodes: int, seed: int = 0) -> AndOrGraph:
    """A random AND/OR tree: 1-2 alternatives per node, 1-3 children per hyper-arc."""
    rng = random.Random(seed)
    g = AndOrGraph("tree", root="n0")
    g.add_node("n0", float(rng.randint(1, 9)))
    queue, count, arcs, i = ["n0"], 1, 0, 0
    while count < n_nodes and i < len(queue):
        p = queue[i]
        i += 1
        for _ in range(rng.choice((1, 1, 2))):
            kids = []
            for _ in range(rng.randint(1, 3)):
                if count >= n_nodes:
                    break
                name = f"n{count}"
                count += 1
                g.add_node(name, float(rng.randint(1, 9)))
                kids.append(name)
                queue.append(name)
            if kids:
                g.add_hyperarc(f"h{arcs}", kids, p, float(rng.randint(1, 9)))
                arcs += 1
    return g


def chain(n: int) -> AndOrGraph:
    """``n`` nodes in a line: n0 <- h1 <- n1 <- ... (every query changes every cost above)."""
    g = AndOrGraph("chain", root=f"n{n - 1}")
    for i in range(n):
        g.add_node(f"n{i}", 1.0)
    for i in range(1, n):
        g.add_hyperarc(f"h{i}", [f"n{i - 1}"], f"n{i}", 1.0)
    return g


__all__ = ["chain", "random_tree"]
