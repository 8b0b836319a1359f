"""Summaries recomputed from a saved cooperation log (``flexhrc replay LOG``).

Counts and simulated times come from the logged actions and decisions themselves; the
wall-clock compute times (Task Manager, representation, simulator) cannot be recomputed and are
read from the log's closing ``summary`` event when there is one.

:func:`check_log` validates every event first — its type and fields against the catalogue of
:mod:`flexhrc.events`, a finite time that never goes back, one run per log — and names the line
of the first bad one, so an edited or corrupted log is refused rather than summarised into
nonsense. A log without an ``outcome`` event is a run that was cut short (killed, or the machine
went down): it is summarised up to its last event and says so.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from flexhrc.errors import FormatError
from flexhrc.events import LOG_EVENTS, REPLAY_TYPES, finite_number

CUT_SHORT = "cut_short"


def _number(v: Any) -> bool:
    return finite_number(v)


def check_log(lines: Sequence[tuple[int, dict[str, Any]]], source: str | Path) -> None:
    """Validate every event of a cooperation log; the first bad one is a :class:`FormatError`
    naming its line. ``lines`` are ``(line number, event)`` pairs as
    :func:`flexhrc.jsonl.read_jsonl_lines` returns them."""
    last_t = 0.0
    seen: dict[str, int] = {}  # start / outcome / summary -> line
    commands: dict[int, int] = {}
    ended: dict[int, int] = {}

    def fail(message: str, line: int) -> FormatError:
        return FormatError(message, source, line)

    for n, (line, ev) in enumerate(lines):
        kind, t = ev["type"], ev["t"]
        if kind == "behave_start":  # the header of a behaviour network's log
            raise fail("a behaviour network's log: read it with 'flexhrc behave replay'", line)
        if not isinstance(kind, str) or kind not in REPLAY_TYPES:
            raise fail(f"unknown event type {kind!r} (not a flexhrc cooperation log?)", line)
        if not _number(t) or t < 0:
            raise fail(f"{kind}: 't' must be a finite time >= 0, got {t!r:.40}", line)
        if kind in ("start", "outcome", "summary"):
            if kind in seen:
                what = "run starts" if kind == "start" else f"'{kind}' event"
                raise fail(
                    f"a second {what} (the first is on line {seen[kind]}): a log holds one run",
                    line,
                )
            seen[kind] = line
        if t < last_t - 1e-9:
            raise fail(
                f"{kind}: time goes back ({t} s after {last_t} s): events are written in time "
                "order",
                line,
            )
        last_t = max(last_t, float(t))
        if n == 0 and kind != "start":
            raise fail(f"the log must begin with a 'start' event, not {kind!r}", line)
        problem = LOG_EVENTS[kind].problem(ev)  # the fields of its schema in flexhrc.events
        if problem is not None:
            raise fail(problem, line)
        if kind == "command":
            cid = ev["id"]
            if cid in commands:
                raise fail(f"command {cid} was already issued on line {commands[cid]}", line)
            commands[cid] = line
        elif kind == "summary":
            # the runner writes the summary at the end, stamped with the makespan it reports
            total = ev["timing"].get("total_s")
            if total is not None and abs(float(total) - last_t) > 1e-6:
                raise fail(
                    f"summary: the run ended at {total} s but its events reach {last_t} s "
                    "(an edited log?)",
                    line,
                )
        elif kind == "action_end":
            cid = ev.get("command")
            if isinstance(cid, int) and not isinstance(cid, bool):
                if cid in ended:
                    raise fail(f"command {cid} already ended on line {ended[cid]}", line)
                ended[cid] = line


def _decision_terms(ev: dict[str, Any]) -> dict[str, Any]:
    """One decision of a shaped utility as ``--json`` shows it: each branch's agents, grounding
    and terms (success, time, preference, workload, utility), and which one was chosen."""
    return {
        "t": ev.get("t", 0.0),
        "element": ev.get("element"),
        "chosen": ev.get("chosen"),
        "branches": [
            {
                "agents": b.get("agents", []),
                "grounding": b.get("grounding", {}),
                "terms": b.get("terms", {}),
            }
            for b in ev.get("branches", [])
        ],
    }


def summarise_log(events: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """Table I and the counts of a log (validated with :func:`check_log` first)."""
    events = list(events)
    robot_actions = human_actions = 0
    robot_s = human_s = 0.0
    legs: dict[str, int] = {}
    solved_by: dict[str, int] = {}
    solved: list[dict[str, Any]] = []
    humans = {"human"}
    fixed_events = any(ev.get("type") == "fixed" for ev in events)
    decisions = branches = 0
    # each decision's branches with their terms, when the run had a ``utility:`` (issue 22)
    terms: list[dict[str, Any]] = []
    outcome: str | None = None
    reason = None
    simulator = None
    end = 0.0
    for ev in events:
        end = max(end, float(ev.get("t", 0.0)))
        kind = ev.get("type")
        if kind == "start":
            simulator = ev.get("simulator")
            for agent in ev.get("agents", []):
                legs.setdefault(agent, 0)
                solved_by.setdefault(agent, 0)
            humans = set(ev.get("humans", ["human"]))
        elif kind == "decision":
            decisions += 1
            branches += len(ev.get("branches", []))
            if any("terms" in b for b in ev.get("branches", [])):
                terms.append(_decision_terms(ev))
        elif kind == "outcome":
            outcome, reason = ev["outcome"], ev.get("reason")
        elif kind == "action_end":
            dt = float(ev["t"]) - float(ev["start"])
            human = any(a in humans for a in ev["agents"])
            if human:
                human_s += dt
            else:
                robot_s += dt
            if ev["status"] != "done":
                continue
            if human:
                human_actions += 1
            else:
                robot_actions += 1
            if not fixed_events and ev["action"].startswith("screw("):
                for agent in ev["agents"]:  # logs written before 'fixed' events existed
                    legs[agent] = legs.get(agent, 0) + 1
        elif kind == "fixed":
            for agent in ev["agents"]:
                legs[agent] = legs.get(agent, 0) + 1
        elif kind == "solved":
            agents = list(ev.get("agents", []))
            solved.append({"hyperarc": ev["element"], "agent": "+".join(agents), "t": ev["t"]})
            for agent in agents:
                solved_by[agent] = solved_by.get(agent, 0) + 1
    closing: dict[str, Any] = next(
        (ev for ev in reversed(events) if ev.get("type") == "summary"), {}
    )
    start = next((ev for ev in events if ev.get("type") == "start"), {})
    # logs written before scenarios were named in them are all of the table
    table = start.get("scenario", TABLE_SCENARIO) == TABLE_SCENARIO
    complete = outcome is not None
    if outcome is None:
        outcome = CUT_SHORT
        reason = (
            f"the run was cut short: the log ends after {len(events)} events "
            f"(t = {end:.2f} s) without an outcome"
        )
    compute = closing.get("timing", {})
    return {
        "outcome": outcome,
        "reason": reason,
        "complete": complete,
        "compute_recorded": bool(compute),
        "simulator": simulator or closing.get("simulator"),
        # the failure policy the run used (logs written before it was a choice: retry, unsaid)
        **({"on_failure": start["on_failure"]} if "on_failure" in start else {}),
        "events": len(events),
        "robot_actions": robot_actions,
        "human_actions": human_actions,
        "decisions": decisions,
        "branches_simulated": branches,
        **({"decision_terms": terms} if terms else {}),
        "timing": {
            "task_manager_s": compute.get("task_manager_s", 0.0),
            "task_representation_s": compute.get("task_representation_s", 0.0),
            "simulator_s": compute.get("simulator_s", 0.0),
            "robot_actions_s": round(robot_s, 6),
            "human_actions_s": round(human_s, 6),
            "total_s": round(end, 6),
        },
        "fixed_by_agent": legs,
        # the table's name of the same count (a JSON key that stays): only where it is the table
        **({"legs_by_agent": dict(legs)} if table else {}),
        "solved_hyperarcs": solved,
        "by_agent": solved_by,
    }


#: The scenario whose logs count fixed objects as legs (``legs_by_agent``, its older key).
TABLE_SCENARIO = "table_assembly"


def solved_by_line(data: dict[str, Any]) -> str:
    """Who did what, in the words of the task: hyper-arcs solved by each agent — and, for the
    table assembly, the legs each connected (the paper's figure)."""
    by = ", ".join(f"{a}: {n}" for a, n in data.get("by_agent", {}).items())
    line = f"hyper-arcs solved by {by}"
    if "legs_by_agent" in data:
        legs = ", ".join(f"{a}: {n}" for a, n in data["legs_by_agent"].items())
        line = f"legs connected by {legs}; {line}"
    return line


def plural(n: int, word: str, many: str | None = None) -> str:
    """``1 branch``, ``2 branches``, ``0 objects``."""
    if n == 1:
        return f"{n} {word}"
    if many is None:
        many = word + ("es" if word.endswith(("s", "x", "ch", "sh")) else "s")
    return f"{n} {many}"


def outcome_line(data: dict[str, Any], subject: str = "", *, simulated: bool = False) -> str:
    """The one-line summary under Table I (``flexhrc run``, ``demo``, ``replay``): outcome, who
    solved what, decisions, branches (``simulated``: with the simulator that scored them) and
    actions; ``subject`` goes in front (``"ball_in_box: "``)."""
    branches = plural(data["branches_simulated"], "branch", "branches")
    if simulated:
        branches += f" simulated ({data['simulator']} simulator)"
    return (
        f"{subject}outcome {data['outcome']}"
        + (f" ({data['reason']})" if data["reason"] else "")
        + f"; {solved_by_line(data)}; {plural(data['decisions'], 'decision tree')}, {branches}; "
        f"{data['robot_actions']} robot and {plural(data['human_actions'], 'human action')}"
    )


def table_i(summary: dict[str, Any]) -> str:
    """The paper's Table I from a run summary, in two parts that are never added up.

    Compute (wall clock of this process: Task Manager, task representation, simulator) and
    simulated time (how long the agents' actions take on the simulated clock) are different
    quantities; the paper's Table I puts them in one column, which here would add milliseconds
    of computation to minutes of make-believe motion.
    """
    if summary.get("timing_profile") == "paper":
        return _table_i_beside_paper(summary)
    t = summary["timing"]
    compute = [
        ("Task Manager", t["task_manager_s"]),
        ("Task Representation", t["task_representation_s"]),
        ("Simulator", t["simulator_s"]),
    ]
    simulated = [
        ("Robot actions", t["robot_actions_s"]),
        ("Human actions", t["human_actions_s"]),
    ]
    sim = summary.get("simulator")
    head = f"Computation ({sim} simulator)" if sim else "Computation (wall clock)"
    total = sum(v for _, v in compute)
    lines = [f"{head:<34}{'time [s]':>12}{'time [%]':>10}"]
    if summary.get("compute_recorded", True):
        for name, v in compute:
            lines.append(f"{name:<34}{v:>12.4f}{100 * v / total if total else 0:>10.2f}")
        lines.append(f"{'Compute total (wall clock)':<34}{total:>12.4f}{100.0:>10.2f}")
    else:  # a log cut short before its closing summary: the compute was never written down
        for name, _ in compute:
            lines.append(f"{name:<34}{'n/a':>12}{'':>10}")
        lines.append("(not recorded: the log ends before the run's closing summary)")
    lines.append("")
    lines.append(f"{'Simulated time (simulated clock)':<34}{'time [s]':>12}")
    for name, v in simulated:
        lines.append(f"{name:<34}{v:>12.2f}")
    lines.append(f"{'Assembly makespan':<34}{t['total_s']:>12.2f}")
    lines.append("(robot and human action times overlap; they add up to more than the makespan)")
    return "\n".join(lines)


#: The paper's Table I (000, §VII-C): averages of eight 4-leg assemblies on the real Baxter, s.
PAPER_TABLE_I = {
    "task_manager_s": 0.01,
    "task_representation_s": 0.57,
    "simulator_s": 4.15,
    "robot_actions_s": 219.45,
    "human_actions_s": 25.82,
    "total_s": 250.09,
}


def _table_i_beside_paper(summary: dict[str, Any]) -> str:
    """Table I of a run timed by the ``paper`` profile, each row beside the paper's figure.

    The paper's total is the sum of its rows (robot and human actions done one after the
    other, computation included); the run's sum is printed the same way, and its makespan
    below, as robot and human actions may overlap here."""
    t = summary["timing"]
    rows = [
        ("Task Manager", "task_manager_s"),
        ("Task Representation", "task_representation_s"),
        ("Simulator", "simulator_s"),
        ("Robot actions", "robot_actions_s"),
        ("Human actions", "human_actions_s"),
    ]
    recorded = summary.get("compute_recorded", True)
    sim = summary.get("simulator") or "wall clock"
    lines = [
        f"Table I beside the paper ({sim} simulator, paper timing)",
        f"{'':<34}{'this run [s]':>14}{'paper [s]':>12}",
    ]
    total = 0.0
    for i, (name, key) in enumerate(rows):
        if i == 3:
            lines.append("simulated clock:")
        elif i == 0:
            lines.append("compute (wall clock):")
        v = t[key]
        total += v
        shown = (
            f"{v:>14.4f}" if i < 3 and recorded else (f"{v:>14.2f}" if i >= 3 else f"{'n/a':>14}")
        )
        lines.append(f"  {name:<32}{shown}{PAPER_TABLE_I[key]:>12.2f}")
    lines.append(
        f"  {'Total (sum of the rows)':<32}{total:>14.2f}{PAPER_TABLE_I['total_s']:>12.2f}"
    )
    lines.append(f"  {'Assembly makespan':<32}{t['total_s']:>14.2f}{'–':>12}")
    lines.append(
        "(the paper: a real Baxter, eight runs; here one simulated run whose action times are "
        "calibrated on the paper's totals, see --timing)"
    )
    return "\n".join(lines)
