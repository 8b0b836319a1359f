"""Timeline picture of a cooperation: who did what, when (one lane per agent).

The table's motions keep their colours; any other action of a scenario gets one from a fixed
palette (in order of first appearance, so the same log always draws the same picture), and the
legend lists the actions the log holds.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

from flexhrc.errors import OptionalDependencyError

COLOURS = {
    "approach": "#9ecae1",
    "grasp": "#6baed6",
    "transport": "#4292c6",
    "screw": "#2171b5",
    "ungrasp": "#c6dbef",
    "rest": "#dddddd",
    "pick_up": "#fd8d3c",
    "put_down": "#fdae6b",
}
#: colours for the actions of other scenarios (tab10 without the table's blue and orange)
PALETTE = ("#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
           "#98df8a", "#c5b0d5", "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5", "#d62728")  # fmt: skip


def intervals(events: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """Finished actions from an event log: agent, action, start, end, status."""
    out = []
    for ev in events:
        if ev.get("type") != "action_end":
            continue
        for agent in ev["agents"]:
            out.append(
                {
                    "agent": agent,
                    "action": ev["action"],
                    "start": float(ev["start"]),
                    "end": float(ev["t"]),
                    "status": ev["status"],
                }
            )
    return out


def plot_timeline(events: list[dict[str, Any]], out: str | Path, title: str = "") -> Path:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Patch
    except ImportError:
        raise OptionalDependencyError("the timeline plot", "viz", "matplotlib") from None
    spans = intervals(events)
    present = {s["agent"] for s in spans}
    lanes = [a for a in ("right", "left", "human") if a in present] or ["right", "left", "human"]
    lanes += sorted(present - set(lanes))
    colours = dict(COLOURS)
    for sp in spans:
        kind = sp["action"].split("(")[0]
        if kind not in colours:
            colours[kind] = PALETTE[(len(colours) - len(COLOURS)) % len(PALETTE)]
    used = {sp["action"].split("(")[0] for sp in spans}
    fig, ax = plt.subplots(figsize=(12, max(2.4, 0.8 * len(lanes) + 0.8)))
    for s in spans:
        y = lanes.index(s["agent"])
        kind = s["action"].split("(")[0]
        colour = colours[kind]
        if kind == "screw" and s["agent"] == "human":
            colour = "#d94801"
        hatch = "//" if s["status"] != "done" else None
        ax.broken_barh(
            [(s["start"], s["end"] - s["start"])],
            (y - 0.35, 0.7),
            facecolors=colour,
            edgecolor="black" if s["status"] != "done" else "white",
            hatch=hatch,
            linewidth=0.6,
        )
        if kind == "screw" and s["status"] == "done":
            leg = s["action"].split("(")[1].split(",")[1].strip()
            ax.text(
                (s["start"] + s["end"]) / 2,
                y,
                leg,
                ha="center",
                va="center",
                fontsize=7,
                color="white",
            )
    for ev in events:
        if ev.get("type") == "suggestion":
            ax.axvline(ev["t"], color="#d94801", linestyle=":", linewidth=0.8)
    ax.set_yticks(range(len(lanes)))
    ax.set_yticklabels(lanes)
    ax.set_xlabel("simulated time [s]")
    ax.set_title(title or "who did what, when")
    legend = [Patch(facecolor=c, label=k) for k, c in colours.items() if k in used or not used]
    if (
        any(sp["action"].startswith("screw(") and sp["agent"] == "human" for sp in spans)
        or not used
    ):
        legend.append(Patch(facecolor="#d94801", label="screw (human)"))
    legend.append(Patch(facecolor="white", edgecolor="black", hatch="//", label="stopped / failed"))
    ax.legend(
        handles=legend,
        loc="upper center",
        bbox_to_anchor=(0.5, -0.3),
        ncol=6,
        fontsize=7,
        frameon=False,
    )
    ax.grid(True, axis="x", alpha=0.3)
    fig.tight_layout()
    out = Path(out)  # the caller checked it (flexhrc.files.check_output); no folder is created
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
