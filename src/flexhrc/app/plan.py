"""``flexhrc plan SCENARIO`` as one call: :class:`PlanConfig` in, :class:`PlanReport` out.

Load the scenario (a file or a shipped name, as ``flexhrc run`` takes it), check every option and
the ``--plot`` path before any work, solve the task with CP-SAT (:func:`flexhrc.planning.solve`),
and give the schedule as text (one line per action, then the objective, the proven bound and the
solver status) and as the JSON of the contract (:meth:`flexhrc.planning.Plan.to_json`); with
``plot`` draw the Gantt chart (:func:`plot_gantt`: one lane per agent, a joint action on each of
its lanes), written atomically. The plan's makespan is comparable with ``timing.total_s`` of
``flexhrc run --json``: the same durations, from the same branch simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from flexhrc.cell.replay import PLOT_SUFFIXES, need_matplotlib
from flexhrc.errors import FlexhrcError
from flexhrc.events import PROFILES
from flexhrc.planning import OBJECTIVES, Plan, solve

SIMULATOR_CHOICES = ("analytic", "kinematic")


@dataclass(frozen=True)
class PlanConfig:
    """The options of ``flexhrc plan``, with its defaults (checked when made)."""

    scenario: str | Path = "table_assembly"
    objective: str = "makespan"
    time_limit: float = 10.0
    simulator: str | None = None
    human: str | None = None
    plot: str | Path | None = None
    segments: str | None = None
    seed: int = 0
    travel: bool = False
    exact_travel: bool = False

    def __post_init__(self) -> None:
        for option, value, choices in (
            ("--objective", self.objective, OBJECTIVES),
            ("--simulator", self.simulator, (None, *SIMULATOR_CHOICES)),
            ("--human", self.human, (None, *PROFILES)),
        ):
            if value not in choices:
                names = ", ".join(c for c in choices if c is not None)
                raise FlexhrcError(f"{option} {value!r}: choose one of {names}")
        t = self.time_limit
        if isinstance(t, bool) or not isinstance(t, int | float) or not math.isfinite(t):
            raise FlexhrcError(f"--time-limit must be a number of seconds, got {t!r}")
        if not 0 < t <= 3600:
            raise FlexhrcError(f"--time-limit must be in (0, 3600] seconds, got {t:g}")


@dataclass
class PlanReport:
    """A solved plan: ``plan``, ``json`` (the ``--json`` contract), ``text`` (what is printed)."""

    plan: Plan
    json: dict[str, Any]
    text: str
    scenario: str

    @property
    def exit_code(self) -> int:
        """0 with a schedule (optimal or feasible), 1 without (infeasible, unknown)."""
        return 0 if self.plan.status in ("optimal", "feasible") else 1


def plan_scenario(config: PlanConfig) -> PlanReport:
    """Plan the task ``config`` names (see the module docstring)."""
    from flexhrc.files import atomic_output, check_output
    from flexhrc.scenario import load_scenario

    spec = config.scenario
    inputs = [spec] if Path(str(spec)).exists() else []
    if config.plot is not None:  # before the work: a long solve never ends on "cannot write"
        check_output(config.plot, option="--plot", suffixes=PLOT_SUFFIXES, inputs=inputs)
        need_matplotlib()
    sc = load_scenario(spec, seed=config.seed, segments=config.segments)
    if config.simulator is not None and config.simulator not in sc.simulators:
        raise FlexhrcError(
            f"--simulator {config.simulator}: {sc.name} runs on {', '.join(sc.simulators)} only"
        )
    plan = solve(
        sc,
        objective=config.objective,
        time_limit_s=config.time_limit,
        simulator=config.simulator,
        human=config.human,
        seed=config.seed,
        travel=config.travel,
        exact_travel=config.exact_travel,
    )
    title = f"{sc.name}: {config.objective} {_fmt(plan.objective)} s ({plan.status})"
    if config.plot is not None and plan.schedule:
        with atomic_output(config.plot) as tmp:
            plot_gantt(plan, tmp, title, agents=list(sc.domain.agents))
    return PlanReport(plan, plan.to_json(), plan_text(plan, str(sc.name)), str(sc.name))


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.3f}"


def plan_text(plan: Plan, name: str) -> str:
    """The schedule, one action a line, then the objective, the bound and the status."""
    lines = [f"{name}: plan ({plan.goal})"]
    for e in plan.schedule:
        who = "+".join(e.agents) or "-"
        lines.append(f"{e.start_s:8.3f} - {e.end_s:8.3f} s  {who:<12} {e.action}  [{e.hyperarc}]")
    if not plan.schedule:
        lines.append("no schedule")
    by = ", ".join(f"{a}: {n}" for a, n in plan.by_agent.items())
    if by:
        lines.append(f"hyper-arcs by agent: {by}")
    gap = plan.gap
    lines.append(
        f"{plan.goal} {_fmt(plan.objective)} s, proven bound {_fmt(plan.bound)} s"
        + (f" (gap {gap:.1%})" if gap is not None else "")
        + (f", makespan {_fmt(plan.makespan_s)} s" if plan.goal != "makespan" else "")
        + f"; status {plan.status.upper()} in {plan.solve_s:.3f} s"
    )
    return "\n".join(lines)


def plot_gantt(plan: Plan, path: str | Path, title: str, agents: list[str] | None = None) -> None:
    """The Gantt chart of ``plan``: one lane per agent (top to bottom in ``agents``' order),
    a bar per action on each lane of its agents (a joint action on every lane it occupies,
    hatched), a node process drawn lighter; bars coloured by hyper-arc, labelled with the
    action's name; the makespan as a dashed line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lanes = list(agents or [])
    for e in plan.schedule:
        for a in e.agents:
            if a not in lanes:
                lanes.append(a)
    row = {a: i for i, a in enumerate(lanes)}
    arcs = list(dict.fromkeys(e.hyperarc for e in plan.schedule))
    cmap = plt.get_cmap("tab20")
    colour = {h: cmap(i % 20) for i, h in enumerate(arcs)}
    fig, ax = plt.subplots(figsize=(11, 1.0 + 0.55 * max(1, len(lanes))))
    for e in plan.schedule:
        width = e.end_s - e.start_s
        for a in e.agents:
            ax.barh(
                row[a],
                width,
                left=e.start_s,
                height=0.7,
                color=colour[e.hyperarc],
                edgecolor="black",
                linewidth=0.5,
                hatch="//" if len(e.agents) > 1 else None,
            )
            if width > 0.6:
                ax.text(
                    e.start_s + width / 2,
                    row[a],
                    e.action.split("(")[0],
                    ha="center",
                    va="center",
                    fontsize=7,
                    clip_on=True,
                )
    if plan.makespan_s is not None:
        ax.axvline(plan.makespan_s, color="black", linestyle="--", linewidth=1)
        ax.text(plan.makespan_s, -0.8, f" {plan.makespan_s:.2f} s", fontsize=8, va="bottom")
    ax.set_yticks(range(len(lanes)))
    ax.set_yticklabels(lanes)
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    ax.set_title(title, fontsize=10)
    handles = [plt.Rectangle((0, 0), 1, 1, color=colour[h]) for h in arcs]
    if len(arcs) <= 24:
        ax.legend(handles, arcs, fontsize=6, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(path, format=Path(path).suffix.lstrip(".") or "png", dpi=120)
    plt.close(fig)
