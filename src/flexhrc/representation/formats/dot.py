"""DOT export of AND/OR graphs, for graphviz.

Nodes are ellipses (root: double border), hyper-arcs small boxes: edges run from the children
into the hyper-arc and from the hyper-arc to its parent, so AND reads as "all arrows into one
box" and OR as "several boxes into one node". Every distinct graph definition is a cluster; a
hyper-arc with a lower graph is drawn as a double box with a dashed edge to the lower graph's
root. With an :class:`~flexhrc.representation.OnlineGraph`, the current statuses colour the top
graph instance (met/solved green, feasible orange with its cost, infeasible grey).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import TYPE_CHECKING

from flexhrc.errors import FlexhrcError
from flexhrc.representation.hierarchy import HierarchicalGraph

if TYPE_CHECKING:
    from flexhrc.representation.online import OnlineGraph


def _q(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _w(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def to_dot(
    hierarchy: HierarchicalGraph, online: OnlineGraph | None = None, *, legend: bool = True
) -> str:
    """The hierarchy as DOT text (statuses of ``online`` shown for the top graph), with a
    legend of the shapes (and, with ``online``, the status colours) unless ``legend=False``."""
    lines = [
        "digraph andor {",
        "  rankdir=BT;",
        '  node [fontname="Helvetica", fontsize=10];',
        "  edge [arrowsize=0.6];",
        "  compound=true;",
    ]
    keys = hierarchy.used_keys()
    costs = online.query().feasible if online is not None else {}
    for ci, key in enumerate(keys):
        g = hierarchy.graphs[key]
        is_top = key == hierarchy.top
        prefix = f"g{ci}:"
        lines.append(f"  subgraph cluster_{ci} {{")
        label = f"{g.name}" + ("" if is_top else f"  [{key}]")
        lines.append(f"    label={_q(label)}; style=rounded; color=gray60;")
        for n in g.nodes.values():
            attrs = [f"label={_q(n.name + (f' ({_w(n.weight)})' if n.weight else ''))}"]
            if n.name == g.root:
                attrs.append("peripheries=2")
            if online is not None and is_top:
                attrs += _status_attrs(online, n.name, costs)
            lines.append(f"    {_q(prefix + n.name)} [{', '.join(attrs)}];")
        for h in g.hyperarcs.values():
            hid = _q(prefix + "h:" + h.name)
            attrs = [
                "shape=box",
                "height=0.2",
                "fontsize=8",
                f"label={_q(f'{h.name} ({_w(h.weight)})')}",
            ]
            if h.lower is not None:
                attrs.append("peripheries=2")
            if online is not None and is_top:
                attrs += _status_attrs(online, h.name, costs)
            lines.append(f"    {hid} [{', '.join(attrs)}];")
            for c in h.children:
                lines.append(f"    {_q(prefix + c)} -> {hid} [arrowhead=none];")
            lines.append(f"    {hid} -> {_q(prefix + h.parent)};")
        lines.append("  }")
    for ci, key in enumerate(keys):
        g = hierarchy.graphs[key]
        for h in g.hyperarcs.values():
            if h.lower is not None:
                li = keys.index(h.lower)
                lower_root = hierarchy.graphs[h.lower].root
                lines.append(
                    f"  {_q(f'g{ci}:h:{h.name}')} -> {_q(f'g{li}:{lower_root}')} "
                    f'[style=dashed, color=gray40, constraint=false, label="expands"];'
                )
    if legend:
        lines += _legend(online is not None)
    lines.append("}")
    return "\n".join(lines) + "\n"


def _legend(statuses: bool) -> list[str]:
    """A cluster that explains the drawing: shapes always, colours when statuses are shown."""
    items = [
        ("lg_node", 'label="node (weight)"'),
        ("lg_root", 'label="root", peripheries=2'),
        ("lg_arc", 'shape=box, height=0.2, fontsize=8, label="hyper-arc (weight)"'),
        ("lg_lower", 'shape=box, height=0.2, fontsize=8, peripheries=2, label="has a lower graph"'),
    ]
    if statuses:
        items += [
            ("lg_done", 'style=filled, fillcolor=palegreen, label="met / solved"'),
            ("lg_feasible", 'style=filled, fillcolor=orange, label="feasible (cost)"'),
            ("lg_blocked", 'style=dashed, fontcolor=gray50, color=gray50, label="infeasible"'),
        ]
    out = [
        "  subgraph cluster_legend {",
        '    label="legend — AND: all arrows into one box; OR: several boxes into one node"; '
        "style=rounded; color=gray80; fontsize=9;",
        "    rank=same;",
    ]
    # graphviz lays a rank=same row out right to left here (rankdir=BT): reverse it
    out += [f"    {name} [{attrs}];" for name, attrs in reversed(items)]
    out.append("  }")
    return out


def _status_attrs(online: OnlineGraph, name: str, costs: dict[str, float]) -> list[str]:
    kind = online.kind(name)
    done = online.is_met(name) if kind == "node" else online.is_solved(name)
    if done:
        return ["style=filled", "fillcolor=palegreen"]
    if name in costs:
        return ["style=filled", "fillcolor=orange", f"xlabel={_q('cost ' + _w(costs[name]))}"]
    if online.is_blocked(name):
        return ["style=dashed", "fontcolor=gray50", "color=gray50"]
    return []


def render(dot_text: str, out: str | Path) -> Path:
    """Write ``out`` (.dot as is; .svg/.png/.pdf through graphviz's ``dot``)."""
    from flexhrc.files import atomic_output, atomic_write_text

    out = Path(out)
    fmt = out.suffix.lower().lstrip(".")
    if fmt == "dot" or fmt == "gv":
        atomic_write_text(out, dot_text)
        return out
    if fmt not in ("svg", "png", "pdf"):
        raise FlexhrcError(
            f"{out}: unsupported output format {fmt!r}; use .dot, .svg, .png or .pdf"
        )
    exe = shutil.which("dot")
    if exe is None:
        raise FlexhrcError(
            "rendering to SVG/PNG needs graphviz's 'dot' program, which is not installed "
            "(Debian/Ubuntu: apt-get install graphviz); use -o FILE.dot to write DOT text instead"
        )
    try:
        with atomic_output(out) as tmp:  # graphviz writes beside it; renamed when done
            proc = subprocess.run(
                [exe, f"-T{fmt}", "-o", str(tmp)], input=dot_text, text=True, capture_output=True
            )
            if proc.returncode != 0:
                raise FlexhrcError(f"graphviz failed: {proc.stderr.strip()}")
    except OSError as exc:
        raise FlexhrcError(f"{out}: cannot write: {exc.strerror or exc}") from None
    return out
