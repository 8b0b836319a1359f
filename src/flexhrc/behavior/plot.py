"""Gantt chart of behaviour states over time, like the paper's Fig. 4 and Fig. 6.

One row per behaviour (in task order); coloured bars show when it was inactive, active, running
and done. With two arms, running bars of the second arm are hatched and labelled. Resets by
validity checking are marked with a red cross, object moves with a triangle; the legend names
every colour, hatch and marker used.

The file is written atomically (a temporary file, then a rename).

matplotlib is optional (``pip install 'flexhrc[viz]'``) and imported only here, lazily.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from flexhrc.behavior.network import Run, RunResult
from flexhrc.behavior.render import STATE_COLOURS
from flexhrc.errors import OptionalDependencyError

STATE_ORDER = ("inactive", "active", "running", "done")
#: How the chart (and its legend) marks a reset by validity checking and an object moved.
RESET_MARK: dict[str, Any] = {"marker": "x", "color": "#cc0000", "markersize": 10, "mew": 2.5}
MOVE_MARK: dict[str, Any] = {"marker": "v", "color": "#cc0000", "markersize": 7}


def _pyplot():  # type: ignore[no-untyped-def, unused-ignore]
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise OptionalDependencyError("the Gantt chart (--plot)", "viz", "matplotlib") from None
    return plt


def gantt(result: RunResult, path: str | Path, title: str | None = None) -> Path:
    """Draw the behaviour-state Gantt chart of ``result`` into ``path`` (PNG, SVG or PDF)."""
    plt = _pyplot()
    from matplotlib.patches import Patch

    behaviors = list(result.behaviors)
    intervals = result.state_intervals()
    arms = list(result.arms)
    run_arm: dict[tuple[str, float], str] = {(r.behavior, r.start): r.arm for r in result.runs}
    fig, ax = _chart(plt, behaviors, max(result.time, 1e-6))
    for row, name in enumerate(reversed(behaviors)):
        for state, t0, t1 in intervals.get(name, []):
            kwargs = {"color": STATE_COLOURS[state], "edgecolor": "none"}
            if state == "running" and len(arms) > 1:
                arm = run_arm.get((name, t0), arms[0])
                if arm != arms[0]:
                    kwargs.update(hatch="///", edgecolor="white")
            ax.barh(row, t1 - t0, left=t0, height=0.62, **kwargs)
            if state == "running" and len(arms) > 1 and t1 - t0 > 2.5:
                arm = run_arm.get((name, t0), "")
                ax.text(
                    (t0 + t1) / 2, row, arm, ha="center", va="center", fontsize=7, color="white"
                )
    rows = {name: row for row, name in enumerate(reversed(behaviors))}
    moved = False
    for ev in result.log:
        if ev.kind == "reset" and ev.source in rows:
            ax.plot(ev.t, rows[ev.source], **RESET_MARK)
        elif ev.kind == "move" and str(ev.data.get("object")) in rows:
            ax.plot(ev.t, rows[str(ev.data["object"])] + 0.42, **MOVE_MARK)
            moved = True
    handles = [
        Patch(
            color=STATE_COLOURS[s],
            label=f"running ({arms[0]})" if s == "running" and len(arms) > 1 else s,
        )
        for s in STATE_ORDER
    ]
    if len(arms) > 1:
        handles.append(
            Patch(
                facecolor=STATE_COLOURS["running"],
                hatch="///",
                edgecolor="white",
                label=f"running ({arms[1]})",
            )
        )
    for shown, mark, label in (
        (moved, MOVE_MARK, "object moved by the experimenter"),
        (result.resets, RESET_MARK, "reset (validity check)"),
    ):
        if shown:
            handles.append(plt.Line2D([], [], linestyle="none", label=label, **mark))
    order = ", ".join(result.order)
    title = title or f"Behaviour states over time — order: {order}"
    return _save(plt, fig, ax, handles, min(len(handles), 4), title, path)


ROBOT_COLOURS = ("#3c78d8", "#e69138", "#6aa84f", "#8e7cc3")


def team_gantt(
    runs: list[Run],
    behaviors: list[str],
    path: str | Path,
    title: str | None = None,
    lost: list[str] | None = None,
    lost_at: Mapping[str, float] | None = None,
) -> Path:
    """Who did what when, for several robots sharing one task: one row per behaviour, one bar per
    run coloured by robot (arms named ``robot/arm``); a reset run is hatched, a run cut off by
    its robot's loss is outlined in red. Written atomically, like :func:`gantt`."""
    plt = _pyplot()
    from matplotlib.patches import Patch

    robots = sorted({r.arm.split("/", 1)[0] for r in runs})
    colour = {robot: ROBOT_COLOURS[i % len(ROBOT_COLOURS)] for i, robot in enumerate(robots)}
    end = max([r.end or r.start for r in runs] + [1e-6])
    rows = {name: row for row, name in enumerate(reversed(behaviors))}
    fig, ax = _chart(plt, behaviors, end)
    for r in runs:
        if r.behavior not in rows:
            continue
        robot = r.arm.split("/", 1)[0]
        stop = r.end if r.end is not None else (lost_at or {}).get(robot, end)
        kwargs: dict[str, object] = {"color": colour[robot], "edgecolor": "none"}
        if r.outcome == "reset":
            kwargs.update(hatch="///", edgecolor="white", alpha=0.6)
        elif r.outcome == "unfinished":
            kwargs.update(edgecolor="#cc0000", linewidth=2, alpha=0.5)
        ax.barh(rows[r.behavior], stop - r.start, left=r.start, height=0.62, **kwargs)
    handles = [Patch(color=colour[robot], label=f"running on {robot}") for robot in robots]
    if any(r.outcome == "reset" for r in runs):
        handles.append(Patch(facecolor="#999999", hatch="///", edgecolor="white", label="reset"))
    if any(r.outcome == "unfinished" for r in runs):
        handles.append(
            Patch(
                facecolor="#dddddd", edgecolor="#cc0000", linewidth=2, label="cut off (robot lost)"
            )
        )
    heading = title or "Who did what"
    if lost:
        heading += f" — lost: {', '.join(lost)}"
    return _save(plt, fig, ax, handles, 4, heading, path)


def _chart(plt: Any, behaviors: list[str], end: float) -> tuple[Any, Any]:
    """A figure with one row per behaviour (the first at the top), time along x up to ``end``."""
    fig, ax = plt.subplots(figsize=(11, max(2.8, 0.9 + 0.42 * len(behaviors))))
    ax.set_yticks(range(len(behaviors)))
    ax.set_yticklabels(list(reversed(behaviors)))
    ax.set_xlabel("time (s)")
    ax.set_xlim(0, end)
    ax.set_ylim(-0.6, len(behaviors) - 0.3)
    ax.grid(axis="x", color="#bbbbbb", linewidth=0.5, alpha=0.7)
    ax.set_axisbelow(True)
    return fig, ax


def _save(
    plt: Any, fig: Any, ax: Any, handles: list[Any], ncol: int, title: str, path: str | Path
) -> Path:
    """The legend under the chart, the title, and the file written atomically."""
    from flexhrc.files import OutputPathError, atomic_output

    ax.legend(
        handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=ncol, frameon=False
    )
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    out = Path(path)
    try:
        with atomic_output(out) as tmp:
            fig.savefig(tmp, dpi=120, format=out.suffix.lstrip(".").lower() or None)
    except OSError as exc:
        raise OutputPathError(f"--plot {out}: cannot write: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)
    return out
