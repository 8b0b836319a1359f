"""Timeline picture of a cooperation: who did what, when (one lane per agent).

Each action is coloured by its kind (:mod:`flexhrc.taskmanager.kinds`; given the ``domain`` the
schema's ``kind``, else the action's name if it is a registered kind), so the table's motions
keep their colours; an action of an unregistered kind gets one from a fixed palette (in order of
first appearance, so the same log always draws the same picture), and the legend lists the kinds
the log holds.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from flexhrc.errors import OptionalDependencyError
from flexhrc.taskmanager.kinds import find_action_kind

if TYPE_CHECKING:
    from flexhrc.taskmanager.domain import Domain

#: the table's motions (their colours come from the kind registry)
TABLE_WORDS = ("approach", "grasp", "transport", "screw", "ungrasp", "rest", "pick_up", "put_down")


def kind_colour(kind: str) -> str | None:
    """The timeline colour of a registered kind (None: not registered, or no colour)."""
    found = find_action_kind(kind)
    return None if found is None else found.colour


COLOURS = {w: str(kind_colour(w)) for w in TABLE_WORDS}
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


def plot_timeline(
    events: list[dict[str, Any]], out: str | Path, title: str = "", domain: Domain | None = None
) -> Path:
    """Draw the timeline of one cooperation log to ``out`` (.png, .svg or .pdf)."""
    return plot_timelines([(events, title)], out, domain)


def plot_timelines(
    runs: Sequence[tuple[list[dict[str, Any]], str]],
    out: str | Path,
    domain: Domain | None = None,
    *,
    marks: Sequence[tuple[float, str]] = (),
) -> Path:
    """Draw the timelines of several cooperation logs (``(events, title)`` each) one above the
    other on one time axis, each kind in the same colour in all (``flexhrc replay --fork-at
    --plot``: the stored run above its what-if); ``marks``: (time, label) lines drawn across
    every timeline (where the what-if forked)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.patches import Patch
    except ImportError:
        raise OptionalDependencyError("the timeline plot", "viz", "matplotlib") from None
    every = [intervals(events) for events, _ in runs]
    spans_all = [sp for spans in every for sp in spans]
    present = {s["agent"] for s in spans_all}
    lanes = [a for a in ("right", "left", "human") if a in present] or ["right", "left", "human"]
    lanes += sorted(present - set(lanes))

    def kind_name(action: str) -> str:
        name = action.split("(")[0]
        schema = domain.actions.get(name) if domain is not None else None
        return schema.kind if schema is not None and schema.kind else name

    colours = dict(COLOURS)
    picked = 0
    for sp in spans_all:
        kind = kind_name(sp["action"])
        if kind not in colours:
            colour = kind_colour(kind)
            if colour is None:
                colour, picked = PALETTE[picked % len(PALETTE)], picked + 1
            colours[kind] = colour
    used = {kind_name(sp["action"]) for sp in spans_all}
    height = max(2.4, 0.8 * len(lanes) + 0.8)
    fig, axes = plt.subplots(
        len(runs), 1, figsize=(12, height * len(runs)), sharex=True, squeeze=False
    )
    for (events, title), spans, ax in zip(runs, every, axes[:, 0], strict=True):
        for s in spans:
            y = lanes.index(s["agent"])
            kind = kind_name(s["action"])
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
            args = s["action"].partition("(")[2].rstrip(")").split(",")
            if kind == "screw" and s["status"] == "done" and len(args) > 1:
                leg = args[1].strip()
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
        for t, label in marks:
            ax.axvline(t, color="black", linestyle="--", linewidth=1.0)
            ax.text(t, len(lanes) - 0.5, f" {label}", fontsize=7, va="top")
        ax.set_yticks(range(len(lanes)))
        ax.set_yticklabels(lanes)
        ax.set_title(title or "who did what, when")
        ax.grid(True, axis="x", alpha=0.3)
    ax = axes[-1, 0]
    ax.set_xlabel("simulated time [s]")
    legend = [Patch(facecolor=c, label=k) for k, c in colours.items() if k in used or not used]
    if (
        any(sp["action"].startswith("screw(") and sp["agent"] == "human" for sp in spans_all)
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
    fig.tight_layout()
    out = Path(out)  # the caller checked it (flexhrc.files.check_output); no folder is created
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
