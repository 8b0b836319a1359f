"""``flexhrc plan SCENARIO``: the optimal cooperation path, allocation and schedule (CP-SAT)."""

from __future__ import annotations

import argparse

from flexhrc.cli.common import add_json_flag, add_segments_option, config_of, emit, float_range


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg, unused-ignore]
    p = sub.add_parser(
        "plan",
        help="the optimal path, allocation and schedule of a task (CP-SAT; the plan extra)",
        description="Solve a scenario's task with OR-tools CP-SAT: one cooperation path through "
        "the AND/OR graph, the agent of every action and its start time, under the graph's "
        "precedence, the domain's preconditions and reach, joint actions on every agent they "
        "name, one action per agent at a time, durations from the branch simulator a run uses. "
        "Prints the schedule, its objective, the proven bound and the solver status "
        "(docs/planning.md). Exit 0 with a schedule, 1 without, 2 on bad input.",
    )
    p.add_argument("scenario", metavar="SCENARIO", help="a scenario file or a shipped name")
    p.add_argument(
        "--objective",
        choices=["makespan", "idle", "workload"],
        default="makespan",
        help="what to minimise: makespan (default: when the goal is met), idle (the agents' "
        "idle time before it, then the makespan), workload (the persons' busy time, then the "
        "makespan)",
    )
    p.add_argument(
        "--time-limit",
        type=float_range(0, 3600, lo_open=True),
        default=10.0,
        metavar="S",
        help="the solver's time limit in seconds (default 10); the best plan found by then, "
        "with its proven bound",
    )
    p.add_argument(
        "--simulator",
        choices=["analytic", "kinematic"],
        default=None,
        help="how actions are timed: analytic or kinematic (the sim extra; where the actions "
        "have motion kinds); default: the scenario's simulator, as flexhrc run",
    )
    p.add_argument(
        "--human",
        choices=["passive", "takeover", "cooperative", "random"],
        metavar="PROFILE",
        default=None,
        help="the operators' profile (checked; the optimum is the same for every profile)",
    )
    p.add_argument(
        "--travel",
        action="store_true",
        help="model the hands' travel from one hyper-arc to the next (the order of each "
        "agent's branches, for agents with at most 8; closer to a run's times on small tasks, "
        "slower to prove on big ones; beyond 8, each branch as short as travel from anywhere "
        "could make it: a lower bound)",
    )
    p.add_argument(
        "--exact-travel",
        action="store_true",
        help="--travel with the order of every agent's branches however many (warm-started "
        "from the plan without travel): the optimum of a run's times, slow on big tasks",
    )
    p.add_argument("--seed", type=int, default=0, help="solver seed and generated tasks' seed")
    p.add_argument("--plot", metavar="GANTT.png", help="draw the Gantt chart (.png, .svg, .pdf)")
    add_segments_option(p)
    add_json_flag(p)
    p.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace) -> int:
    from flexhrc.app.plan import PlanConfig, plan_scenario

    report = plan_scenario(config_of(PlanConfig, args))
    emit(args, report.json, report.text)
    return report.exit_code
