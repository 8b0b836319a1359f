"""The plots of ``flexhrc experiment``: box plots per policy, one panel per scenario.

``makespan.png``: the makespan of the solved runs of each (profile, policy) pair, one panel per
scenario (each its own scale), the CP-SAT optimum a dashed line across the panel where
:mod:`flexhrc.planning` could solve it. ``idle.png``: the mean idle time of the arms (top row)
and of the persons (bottom row), the optimal schedule's as the reference. Each box is the
interquartile range with the median; whiskers reach 1.5 IQR; every run is a dot.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol


class Design(Protocol):
    """What the plots read of an :class:`~flexhrc.app.experiment.ExperimentConfig` (which
    imports this module)."""

    @property
    def name(self) -> str: ...
    @property
    def scenarios(self) -> Sequence[Any]: ...  # each with a ``label``
    @property
    def profiles(self) -> Sequence[str]: ...
    @property
    def policies(self) -> Sequence[str]: ...
    @property
    def utilities(self) -> Mapping[str, Any]: ...
    @property
    def seeds(self) -> Sequence[int]: ...
    @property
    def objective(self) -> str: ...


#: a colour per policy (paper: the paper's greedy decision; lookahead: CP-SAT ahead)
POLICY_COLOURS = {"paper": "#4c72b0", "lookahead": "#dd8452"}
OTHER_COLOURS = ("#55a868", "#c44e52", "#8172b2", "#937860")


def plot_box(
    rows: Sequence[Mapping[str, Any]],
    config: Design,
    reference: Mapping[str, Mapping[str, Any]],
    what: str,
    path: str | Path,
) -> None:
    """Draw ``makespan.png`` (``what="makespan"``) or ``idle.png`` (``"idle"``) to ``path``
    (atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    from flexhrc.files import atomic_output

    scenarios = [s.label for s in config.scenarios]
    if what == "makespan":
        panels = [("makespan_s", "makespan (s)")]
    else:
        panels = [("arm_idle_s", "arm idle, mean (s)"), ("person_idle_s", "person idle, mean (s)")]
    # the line is "the optimum" where the plan optimises what the plot shows
    optimal = config.objective == ("makespan" if what == "makespan" else "idle")
    ref_name = "CP-SAT optimum" if optimal else f"CP-SAT plan ({config.objective}-optimal)"
    ncols = min(len(scenarios), 4)
    blocks = math.ceil(len(scenarios) / ncols)
    nrows = blocks * len(panels)
    # boxes side by side per policy, in groups per (profile, utility)
    groups = [(p, u) for p in config.profiles for u in config.utilities]
    npol = len(config.policies)
    colours = {
        pol: POLICY_COLOURS.get(pol, OTHER_COLOURS[i % len(OTHER_COLOURS)])
        for i, pol in enumerate(config.policies)
    }
    per_panel = max(len(groups) * npol, 1)
    fig_w = max(4.0, min(4.5, 1.0 + 0.55 * per_panel) * ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(fig_w, 3.4 * nrows), squeeze=False)
    for si, sc in enumerate(scenarios):
        block, col = divmod(si, ncols)
        for pi, (metric, ylabel) in enumerate(panels):
            ax = axes[block * len(panels) + pi][col]
            data, cols, positions = [], [], []
            ticks, labels = [], []
            for g, (profile, utility) in enumerate(groups):
                left = 1 + g * (npol + 0.8)
                ticks.append(left + (npol - 1) / 2)
                labels.append(profile if len(config.utilities) == 1 else f"{profile}\n{utility}")
                for k, policy in enumerate(config.policies):
                    xs = [
                        float(r[metric])
                        for r in rows
                        if r["scenario"] == sc
                        and r["profile"] == profile
                        and r["policy"] == policy
                        and r["utility"] == utility
                        and r["outcome"] == "solved"
                        and r.get(metric) is not None
                    ]
                    data.append(xs)
                    cols.append(colours[policy])
                    positions.append(left + k)
            shown = [(p, d, c) for p, d, c in zip(positions, data, cols, strict=True) if d]
            if shown:
                bp = ax.boxplot(
                    [d for _, d, _ in shown],
                    positions=[p for p, _, _ in shown],
                    widths=0.6,
                    patch_artist=True,
                    showfliers=False,
                    medianprops={"color": "black", "linewidth": 1.5},
                )
                for patch, (_, _, c) in zip(bp["boxes"], shown, strict=True):
                    patch.set_facecolor(c)
                    patch.set_alpha(0.55)
                for p, d, c in shown:  # every run, jittered
                    n = len(d)
                    xs = [p + 0.18 * ((i / max(n - 1, 1)) - 0.5) for i in range(n)]
                    ax.scatter(xs, d, s=9, color=c, edgecolor="black", linewidth=0.3, zorder=3)
            else:
                ax.text(
                    0.5,
                    0.5,
                    "no solved run",
                    ha="center",
                    va="center",
                    transform=ax.transAxes,
                    color="grey",
                )
            ref = _reference(reference.get(sc), metric)
            if ref is not None:
                ax.axhline(ref, color="#2ca02c", linestyle="--", linewidth=1.3, zorder=1)
                ax.annotate(
                    f"{ref:.3g}",
                    xy=(1.0, ref),
                    xycoords=("axes fraction", "data"),
                    xytext=(-3, 2),
                    textcoords="offset points",
                    ha="right",
                    va="bottom",
                    fontsize=7,
                    color="#2ca02c",
                    bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8},
                    zorder=4,
                )
            ax.set_xticks(ticks)
            ax.set_xticklabels(labels, fontsize=8)
            ax.set_xlim(positions[0] - 0.7, positions[-1] + 0.7)
            values = [x for d in data for x in d] + ([ref] if ref is not None else [])
            if values:  # the data and the optimum, with a margin (not from 0: a few % show)
                lo, hi = min(values), max(values)
                pad = max((hi - lo) * 0.12, abs(hi) * 0.03, 0.05)
                ax.set_ylim(max(0.0, lo - pad) if lo >= 0 else lo - pad, hi + pad)
            if pi == 0:
                ax.set_title(sc, fontsize=10)
            if col == 0:
                ax.set_ylabel(ylabel, fontsize=9)
            ax.tick_params(axis="y", labelsize=8)
            ax.grid(axis="y", alpha=0.3)
    for k in range(len(scenarios), blocks * ncols):  # empty panels of the last block
        block, col = divmod(k, ncols)
        for pi in range(len(panels)):
            axes[block * len(panels) + pi][col].set_visible(False)
    handles: list[Any] = [
        Patch(facecolor=c, alpha=0.55, label=f"policy {p}") for p, c in colours.items()
    ]
    if any(reference.get(sc) for sc in scenarios):
        from matplotlib.lines import Line2D

        handles.append(Line2D([], [], color="#2ca02c", linestyle="--", label=ref_name))
    n = len(config.seeds)
    title = "makespan" if what == "makespan" else "idle time"
    fig.suptitle(
        f"{config.name}: {title} per policy and operator profile ({n} seed{'s' * (n != 1)} "
        "per box)",
        fontsize=11,
    )
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.05, 1, 0.95))
    with atomic_output(path) as tmp:
        fig.savefig(tmp, dpi=110)
    plt.close(fig)


def _reference(ref: Mapping[str, Any] | None, metric: str) -> float | None:
    """The optimum's figure for ``metric``: the makespan, or the mean idle time of the arms
    or the persons in the optimal schedule."""
    v = ref.get(metric) if ref else None
    return float(v) if isinstance(v, int | float) else None
