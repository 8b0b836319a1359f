"""ASCII and Graphviz DOT renderings of a task / behaviour network (in the style of py_trees).

``to_ascii`` draws the tree with box-drawing characters; when given node snapshots (a running
:class:`~flexhrc.behavior.network.BehaviorNetwork`) each line also shows state, activation level
and activation potential. ``to_dot`` produces a ``digraph`` with goal nodes as boxes and
behaviours as ellipses, coloured by state when states are given.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from flexhrc.behavior.task import BEHAVIOR, Task, TaskNode

STATE_COLOURS = {
    "inactive": "#d9d9d9",
    "active": "#ffd966",
    "running": "#6aa84f",
    "done": "#3c78d8",
}


def _esc(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"')


def _label(node: TaskNode, snaps: Mapping[str, Mapping[str, Any]] | None) -> str:
    text = node.name if node.kind == BEHAVIOR else f"{node.kind} ({node.name})"
    if snaps and node.name in snaps:
        s = snaps[node.name]
        text += f"  [{s['state']}] level={s['level']:.2f} potential={s['potential']:.2f}"
    return text


def to_ascii(
    task: Task | TaskNode, snapshots: Mapping[str, Mapping[str, Any]] | None = None
) -> str:
    root = task.root if isinstance(task, Task) else task
    lines = [_label(root, snapshots)]

    def walk(node: TaskNode, prefix: str) -> None:
        for i, child in enumerate(node.children):
            last = i == len(node.children) - 1
            lines.append(prefix + ("└── " if last else "├── ") + _label(child, snapshots))
            walk(child, prefix + ("    " if last else "│   "))

    walk(root, "")
    return "\n".join(lines)


def to_dot(
    task: Task | TaskNode,
    snapshots: Mapping[str, Mapping[str, Any]] | None = None,
    name: str = "task",
    *,
    legend: bool = False,
    caption: str | None = None,
) -> str:
    """DOT text; ``legend`` adds a key of the state colours, ``caption`` a title."""
    root = task.root if isinstance(task, Task) else task
    out = [f'digraph "{name}" {{', "  rankdir=TB;", '  node [fontname="Helvetica"];']
    if caption:
        out.append(f'  labelloc=t; label="{_esc(caption)}"; fontname="Helvetica";')
    for node in root.walk():
        attrs = []
        if node.kind == BEHAVIOR:
            attrs += ["shape=ellipse", f'label="{node.name}"']
        else:
            attrs += ["shape=box", f'label="{node.kind}\\n{node.name}"']
        if snapshots and node.name in snapshots:
            colour = STATE_COLOURS.get(str(snapshots[node.name]["state"]), "white")
            attrs += ["style=filled", f'fillcolor="{colour}"']
        out.append(f'  "{node.name}" [{", ".join(attrs)}];')
    for node in root.walk():
        for child in node.children:
            out.append(f'  "{node.name}" -> "{child.name}";')
    if legend:
        out.append('  subgraph cluster_legend { label="state"; fontname="Helvetica"; style=dashed;')
        keys = [f"legend_{state}" for state in STATE_COLOURS]
        for key, (state, colour) in zip(keys, STATE_COLOURS.items(), strict=True):
            out.append(
                f'    "{key}" [label="{state}", shape=box, style=filled, fillcolor="{colour}"];'
            )
        out.append("    " + " -> ".join(f'"{k}"' for k in keys) + " [style=invis];")
        out.append("  }")
    out.append("}")
    return "\n".join(out) + "\n"
