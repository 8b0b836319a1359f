"""An experiment over a design, as one call: ``flexhrc experiment CONFIG.yaml`` (issue 23, item 4).

A *design* is the product of its axes: scenarios (shipped names, scenario files, or tasks
``generate:``-d by :mod:`flexhrc.scenario.generate`) × operator profiles × decision policies
(``paper``, ``lookahead``) × utilities (issue 22's ``utility:`` blocks; optional) × seeds. A
*cell* of the design is one combination without the seed; each seed is one *run*, a
:func:`~flexhrc.app.run.run_scenario` call exactly as ``flexhrc run`` makes it. Runs go to
parallel processes (``jobs``; a top-level worker, spawn-safe) and a failed run is a row with its
error, never the end of the experiment.

Per run (:data:`RUN_COLUMNS`): the makespan (``timing.total_s`` of ``run --json``, simulated
seconds); each agent's busy time (the union of the intervals it executed an action: its own,
a joint one, a node process, going to rest) and idle time (makespan − busy), averaged over the
arms and over the persons; the idle share of all agent-time; the person's share (persons' busy
time over every agent's); the stops, the re-plans (a started hyper-arc stopped and decided again
— ``abort`` — a precondition that failed at dispatch, or a ``replan`` event of a policy) and the
declines (``human_declined``); the Task Manager's decision latency measured in the engine
(:attr:`~flexhrc.app.run.RunReport.decision_latency`: median and 95th percentile, ms).

Per cell (:data:`SUMMARY_METRICS`): the median and the interquartile range (25th–75th
percentile) over the solved runs. Where :mod:`flexhrc.planning` can solve (OR-tools CP-SAT, the
``plan`` extra), each scenario's optimal makespan is the reference of the plots and of the
ratio ``makespan / optimum`` in the summary; without OR-tools the summary says so.

Outputs in the folder ``out`` (checked before the work; a folder with files in it is refused
unless ``force``; each file written atomically): ``runs.csv``, ``summary.csv``, ``summary.md``,
``makespan.png``, ``idle.png``, ``experiment.json`` and ``scenarios/`` (the generated tasks, so
every run can be made again with ``flexhrc run``). See ``docs/experiment.md``.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import json
import math
import os
import re
import sys
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.errors import FlexhrcError, FormatError

FORMAT_VERSION = 1
MAX_SEEDS = 10_000
MAX_RUNS = 100_000
TOP_KEYS = (
    "experiment",
    "name",
    "description",
    "scenarios",
    "profiles",
    "policies",
    "utilities",
    "seeds",
    "simulator",
    "reference",
)
SCENARIO_KEYS = ("name", "file", "generate")
GENERATE_KEYS = ("actions", "agents", "width", "seed", "persons")
REFERENCE_KEYS = ("objective", "time_limit_s")
#: the events that count as a re-plan (see the module docstring)
REPLAN_EVENTS = ("abort", "precondition_failed", "replan")
#: the columns of ``runs.csv``, in order
RUN_COLUMNS = (
    "run",
    "scenario",
    "profile",
    "policy",
    "utility",
    "seed",
    "outcome",
    "error",
    "makespan_s",
    "arms",
    "persons",
    "arm_busy_s",
    "arm_idle_s",
    "person_busy_s",
    "person_idle_s",
    "idle_share",
    "person_share",
    "stops",
    "replans",
    "declines",
    "decisions",
    "latency_median_ms",
    "latency_p95_ms",
    "wall_s",
    "busy_by_agent",
    "idle_by_agent",
)
#: the figures summarised per cell (median and interquartile range)
SUMMARY_METRICS = (
    "makespan_s",
    "arm_idle_s",
    "person_idle_s",
    "idle_share",
    "person_share",
    "stops",
    "replans",
    "declines",
    "latency_median_ms",
    "latency_p95_ms",
)
CELL_KEYS = ("scenario", "profile", "policy", "utility")
OUTPUT_FILES = (
    "runs.csv",
    "summary.csv",
    "summary.md",
    "makespan.png",
    "idle.png",
    "experiment.json",
)


# ------------------------------------------------------------------------------- the config --
@dataclass(frozen=True)
class ScenarioEntry:
    """One scenario of a design: its ``label`` (in the tables and plots), where it comes from
    (``source``: a shipped name or a file; None for a generated one), the ``generate``
    arguments of a generated task, and the config ``line`` it is on."""

    label: str
    source: str | None = None
    generate: Mapping[str, int] | None = None
    line: int | None = None


@dataclass(frozen=True)
class ExperimentConfig:
    """A design read from a config file (:func:`read_config`; docs/experiment.md)."""

    name: str
    scenarios: tuple[ScenarioEntry, ...]
    profiles: tuple[str, ...] = ("passive",)
    policies: tuple[str, ...] = ("paper",)
    seeds: tuple[int, ...] = (0,)
    #: name -> a ``utility:`` block (None: the scenario's own)
    utilities: Mapping[str, Mapping[str, Any] | None] = field(
        default_factory=lambda: {"scenario": None}
    )
    simulator: str | None = None
    objective: str = "makespan"
    time_limit_s: float = 10.0
    description: str = ""
    path: Path | None = None

    @property
    def cells(self) -> int:
        return len(self.scenarios) * len(self.profiles) * len(self.policies) * len(self.utilities)

    @property
    def runs(self) -> int:
        return self.cells * len(self.seeds)


def read_config(path: str | Path) -> ExperimentConfig:
    """Read and check an experiment config; every fault is one
    :class:`~flexhrc.errors.FormatError` ``FILE:LINE: message``."""
    from flexhrc.events import DECISION_POLICIES, PROFILES
    from flexhrc.representation.formats.yaml_format import read_yaml
    from flexhrc.scenario.simulators import CHOICES as SIMULATOR_CHOICES

    path = Path(path)
    doc = read_yaml(path)

    def line(d: Any, key: Any = None) -> int | None:
        lines = getattr(d, "lines", None)
        if key is not None and lines and key in lines:
            return int(lines[key])
        return getattr(d, "line", None)

    def fail(message: str, at: int | None) -> FormatError:
        return FormatError(message, path, at)

    if not isinstance(doc, dict):
        raise fail("an experiment config must be a mapping (experiment: 1, scenarios: ...)", 1)
    _known_keys(doc, TOP_KEYS, "", fail, line)
    if doc.get("experiment") != FORMAT_VERSION:
        raise fail(
            f"experiment: {FORMAT_VERSION} is required (the config format), got "
            f"{doc.get('experiment')!r}",
            line(doc, "experiment") or 1,
        )

    def names(key: str, allowed: Sequence[str], default: tuple[str, ...]) -> tuple[str, ...]:
        if key not in doc:
            return default
        v = doc[key]
        v = [v] if isinstance(v, str) else v
        if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
            raise fail(
                f"{key} must be a non-empty list of names, such as [{allowed[0]}]", line(doc, key)
            )
        for x in v:
            if x not in allowed:
                raise fail(f"{key}: unknown {x!r} (one of {', '.join(allowed)})", line(doc, key))
        if len(set(v)) != len(v):
            raise fail(f"{key}: a name is listed twice", line(doc, key))
        return tuple(v)

    profiles = names("profiles", PROFILES, ("passive",))
    policies = names("policies", DECISION_POLICIES, ("paper",))
    seeds = _seeds(doc.get("seeds", 1), lambda m: fail(m, line(doc, "seeds")))
    utilities: dict[str, Mapping[str, Any] | None] = {"scenario": None}
    if "utilities" in doc:
        u = doc["utilities"]
        if not isinstance(u, dict) or not u:
            raise fail(
                "utilities must be a mapping {name: utility block or null} (null: the "
                "scenario's own utility)",
                line(doc, "utilities"),
            )
        utilities = {}
        for k, block in u.items():
            if not isinstance(k, str) or not k.strip():
                raise fail(f"utilities: a name must be a word, got {k!r}", line(u, k))
            if block is not None:
                from flexhrc.taskmanager.utility import parse_utility

                _, problems = parse_utility(block, None)
                if problems:
                    raise fail(f"utilities: {k}: {problems[0][0]}", line(u, k))
            utilities[k] = block
    simulator = doc.get("simulator")
    if simulator is not None and simulator not in SIMULATOR_CHOICES:
        raise fail(
            f"simulator: unknown {simulator!r} (one of {', '.join(SIMULATOR_CHOICES)})",
            line(doc, "simulator"),
        )
    objective, time_limit = "makespan", 10.0
    if "reference" in doc:
        ref = doc["reference"]
        if not isinstance(ref, dict):
            raise fail(
                "reference must be a mapping {objective, time_limit_s}", line(doc, "reference")
            )
        _known_keys(ref, REFERENCE_KEYS, "reference: ", fail, line)
        objective = ref.get("objective", objective)
        if objective not in ("makespan", "idle", "workload"):
            raise fail(
                f"reference: objective must be makespan, idle or workload, got {objective!r}",
                line(ref, "objective"),
            )
        time_limit = ref.get("time_limit_s", time_limit)
        if (
            isinstance(time_limit, bool)
            or not isinstance(time_limit, int | float)
            or not math.isfinite(time_limit)
            or not 0 < time_limit <= 3600
        ):
            raise fail(
                f"reference: time_limit_s must be a number of seconds in (0, 3600], "
                f"got {time_limit!r}",
                line(ref, "time_limit_s"),
            )
    if "scenarios" not in doc:
        raise fail(
            "scenarios: is required (a list of shipped names, files or generate: entries)", 1
        )
    scenarios = _scenarios(
        doc["scenarios"], path, _item_lines(path, "scenarios", line(doc, "scenarios")), fail, line
    )
    for key in ("name", "description"):
        if key in doc and not isinstance(doc[key], str):
            raise fail(f"{key} must be text", line(doc, key))
    config = ExperimentConfig(
        name=str(doc.get("name") or path.stem),
        scenarios=scenarios,
        profiles=profiles,
        policies=policies,
        seeds=seeds,
        utilities=utilities,
        simulator=simulator,
        objective=objective,
        time_limit_s=float(time_limit),
        description=str(doc.get("description") or ""),
        path=path,
    )
    if config.runs > MAX_RUNS:
        raise fail(f"the design has {config.runs} runs; at most {MAX_RUNS}", 1)
    return config


def design_words(config: ExperimentConfig, times: str = " x ") -> str:
    """``4 scenarios x 2 profiles x 2 policies x 1 utility x 10 seeds``."""

    def n(count: int, word: str, many: str) -> str:
        return f"{count} {word if count == 1 else many}"

    return times.join(
        (
            n(len(config.scenarios), "scenario", "scenarios"),
            n(len(config.profiles), "profile", "profiles"),
            n(len(config.policies), "policy", "policies"),
            n(len(config.utilities), "utility", "utilities"),
            n(len(config.seeds), "seed", "seeds"),
        )
    )


def can_solve() -> bool:
    """Whether :func:`flexhrc.planning.solve` can run here (OR-tools, the ``plan`` extra)."""
    import importlib.util

    try:
        from flexhrc.planning import solve  # type: ignore[attr-defined, unused-ignore] # noqa: F401
    except ImportError:
        return False
    return importlib.util.find_spec("ortools") is not None


def _known_keys(
    d: Mapping[Any, Any],
    keys: Sequence[str],
    what: str,
    fail: Callable[[str, int | None], FormatError],
    line: Callable[..., int | None],
) -> None:
    """Every key of ``d`` is one of ``keys``, else one error (``what``: where, as its prefix)."""
    for key in d:
        if key not in keys:
            raise fail(f"{what}unknown key {key!r} (keys: {', '.join(keys)})", line(d, key))


def _seeds(v: Any, fail: Callable[[str], FormatError]) -> tuple[int, ...]:
    """``seeds: N`` (0 .. N-1) or a list of seeds."""
    from flexhrc.app.run import MAX_SEED

    def whole(x: Any) -> bool:
        return isinstance(x, int) and not isinstance(x, bool)

    if whole(v):
        if not 1 <= v <= MAX_SEEDS:
            raise fail(f"seeds must be a count in 1..{MAX_SEEDS} or a list of seeds, got {v}")
        return tuple(range(v))
    if isinstance(v, list) and v and all(whole(x) and 0 <= x <= MAX_SEED for x in v):
        if len(set(v)) != len(v):
            raise fail("seeds: a seed is listed twice")
        return tuple(v)
    raise fail(
        f"seeds must be a count (10: seeds 0..9) or a list of seeds in 0..{MAX_SEED}, got {v!r}"
    )


def _item_lines(path: Path, key: str, fallback: int | None) -> list[int | None]:
    """The line of each item of the top-level list ``key`` (a mapping remembers its own lines;
    a name in a list does not)."""
    import yaml

    from flexhrc.files import read_text

    try:
        node = yaml.compose(read_text(path), Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return []
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            if getattr(k, "value", None) == key and isinstance(v, yaml.SequenceNode):
                return [item.start_mark.line + 1 for item in v.value]
    return [fallback]


def _scenarios(
    v: Any,
    path: Path,
    at: list[int | None],
    fail: Callable[[str, int | None], FormatError],
    line: Callable[..., int | None],
) -> tuple[ScenarioEntry, ...]:
    """The ``scenarios:`` list: shipped names, files (relative to the config), ``generate:``."""
    from flexhrc.scenario.generate import GenerateSpec
    from flexhrc.scenario.loader import SHIPPED
    from flexhrc.scenario.source import NAMES

    if not isinstance(v, list) or not v:
        raise fail(
            "scenarios must be a non-empty list (shipped names, files, generate: ...)",
            at[0] if at else None,
        )
    out: list[ScenarioEntry] = []
    for i, item in enumerate(v):
        where = line(item) if isinstance(item, dict) else at[i] if i < len(at) else None
        if isinstance(item, str):
            item = {"file": item}
        if not isinstance(item, dict):
            raise fail(
                f"scenarios: an entry must be a name, a file or a mapping, got {item!r}", where
            )
        _known_keys(item, SCENARIO_KEYS, "scenarios: ", fail, line)
        if ("file" in item) == ("generate" in item):
            raise fail(
                "scenarios: an entry has either file: (a name or a file) or generate:", where
            )
        label = item.get("name")
        if label is not None and (
            not isinstance(label, str) or not re.fullmatch(r"[A-Za-z0-9_.-]+", label)
        ):
            raise fail(
                f"scenarios: name must be a word of letters, digits, _ . - (it names a file), "
                f"got {label!r}",
                line(item, "name") or where,
            )
        if "file" in item:
            src = item["file"]
            if not isinstance(src, str) or not src.strip():
                raise fail(
                    f"scenarios: file must be a shipped name or a path, got {src!r}",
                    line(item, "file") or where,
                )
            if (src in SHIPPED or src in NAMES) and not (path.parent / src).exists():
                source = src
            else:
                p = Path(src) if Path(src).is_absolute() else path.parent / src
                if not p.is_file():
                    known = ", ".join(sorted({*SHIPPED, *NAMES}))
                    raise fail(
                        f"scenarios: {src!r} is no shipped scenario ({known}) and no file ({p} "
                        "not found)",
                        line(item, "file") or where,
                    )
                source = str(p)
            out.append(ScenarioEntry(label or Path(src).stem, source, None, where))
            continue
        gen = item["generate"]
        gl = line(item, "generate")
        if not isinstance(gen, dict):
            raise fail("scenarios: generate must be a mapping {actions, agents, width, seed}", gl)
        _known_keys(gen, GENERATE_KEYS, "scenarios: generate: ", fail, line)
        missing = [k for k in ("actions", "agents", "width") if k not in gen]
        if missing:
            raise fail(f"scenarios: generate needs {', '.join(missing)}", gl)
        try:
            spec = GenerateSpec(**{k: gen[k] for k in GENERATE_KEYS if k in gen})
        except FlexhrcError as exc:  # the generator's words, without the command's dashes
            raise fail(f"scenarios: generate: {str(exc).replace('--', '')}", gl) from None
        out.append(ScenarioEntry(label or spec.name, None, dict(gen), where))
    labels = [e.label for e in out]
    for e in out:
        if labels.count(e.label) > 1:
            raise fail(f"scenarios: {e.label!r} is listed twice (give one a name:)", e.line)
    return tuple(out)


# ------------------------------------------------------------------------------- the runs --
@dataclass(frozen=True)
class RunTask:
    """One run of the design, as a worker process gets it (plain data: it is pickled)."""

    run: int
    scenario: str
    source: str
    profile: str
    policy: str
    utility: str
    utility_block: Mapping[str, Any] | None
    seed: int
    simulator: str | None

    def row(self) -> dict[str, Any]:
        """A row of :data:`RUN_COLUMNS`, empty but for the run's identity."""
        row: dict[str, Any] = {c: None for c in RUN_COLUMNS}
        row.update(
            run=self.run,
            scenario=self.scenario,
            profile=self.profile,
            policy=self.policy,
            utility=self.utility,
            seed=self.seed,
        )
        return row


_LOADED: dict[tuple[str, int | None], Any] = {}  # a worker's scenarios, loaded once
_SEEDED: dict[str, bool] = {}


def _seed_matters(source: str) -> bool:
    """Whether the run's seed changes the task itself (the bench of ``parallel_assembly``,
    an older table file's legs): then each run loads it as ``flexhrc run`` does."""
    if source not in _SEEDED:
        from flexhrc.scenario.legacy import is_legacy, read_document

        seeded = source == "parallel_assembly"
        p = Path(source)
        if not seeded and p.suffix.lower() in (".yaml", ".yml") and p.is_file():
            try:
                seeded = is_legacy(read_document(p))
            except FlexhrcError:
                seeded = False
        _SEEDED[source] = seeded
    return _SEEDED[source]


def _scenario(source: str, seed: int = 0) -> Any:
    """The scenario of a shipped name or a file, loaded once per process (and seed, where
    the seed changes it)."""
    from flexhrc.scenario.source import load_scenario

    key = (source, seed if _seed_matters(source) else None)
    if key not in _LOADED:
        _LOADED[key] = load_scenario(source, seed=seed)
    return _LOADED[key]


def run_one(task: RunTask) -> dict[str, Any]:
    """One run (the pool's worker: top level, so it can be pickled by name): a row of
    :data:`RUN_COLUMNS`. Whatever goes wrong is the row's ``error``, never an exception."""
    row = task.row()
    t0 = time.perf_counter()
    try:
        from flexhrc.app.run import RunConfig, run_scenario

        sc = _scenario(task.source, task.seed)
        # a task the seed changes goes as `flexhrc run SOURCE --seed S` takes it
        given: Any = task.source if _seed_matters(task.source) else sc
        if task.utility_block is not None:
            from flexhrc.taskmanager.utility import parse_utility

            utility, problems = parse_utility(task.utility_block, sc.domain)
            if problems:
                raise FlexhrcError(f"utility {task.utility}: {problems[0][0]}")
            given = dataclasses.replace(sc, utility=utility)
        config = RunConfig(
            given,
            human=task.profile if sc.humans else None,
            seed=task.seed,
            policy=task.policy,
            simulator=task.simulator,
            quiet=True,
        )
        report = run_scenario(config)
        row.update(metrics(report.json, report.result.events, sc, report.decision_latency))
    except Exception as exc:  # a failed run is a row with its error
        row["outcome"] = "error"
        where = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
        at = f" ({Path(where[0].filename).name}:{where[0].lineno})" if where else ""
        kind = "" if isinstance(exc, FlexhrcError) else f"{type(exc).__name__}: "
        row["error"] = f"{kind}{exc}{at if kind else ''}".replace("\n", " ")
    row["wall_s"] = round(time.perf_counter() - t0, 4)
    return row


def _union(intervals: Iterable[tuple[float, float]]) -> float:
    total, end = 0.0, -math.inf
    for a, b in sorted(intervals):
        if b <= end:
            continue
        total += b - max(a, end)
        end = b
    return total


def _mean(xs: Sequence[float]) -> float | None:
    return round(sum(xs) / len(xs), 6) if xs else None


def metrics(
    summary: Mapping[str, Any],
    events: Sequence[Mapping[str, Any]],
    scenario: Any,
    latency: Mapping[str, Any],
) -> dict[str, Any]:
    """A run's figures (see the module docstring) from its ``run --json`` summary, its event
    log and its decision latency."""
    makespan = float(summary["timing"]["total_s"])
    agents = scenario.domain.agents
    spans: dict[str, list[tuple[float, float]]] = {name: [] for name in agents}
    for ev in events:
        if ev.get("type") == "action_end" and ev.get("start") is not None:
            for a in ev.get("agents") or ():
                if a in spans:
                    spans[a].append((float(ev["start"]), float(ev["t"])))
    busy = {a: round(min(_union(s), makespan), 6) for a, s in spans.items()}
    idle = {a: round(max(makespan - b, 0.0), 6) for a, b in busy.items()}
    arms = [a for a in agents if not agents[a].is_human]
    persons = [a for a in agents if agents[a].is_human]

    all_busy = sum(busy.values())
    count = {t: sum(1 for e in events if e.get("type") == t) for t in (*REPLAN_EVENTS, "stop")}
    ms = {
        k: (None if latency.get(k) is None else round(1000 * latency[k], 4))
        for k in ("median_s", "p95_s")
    }
    return {
        "outcome": summary["outcome"],
        "error": None if summary["outcome"] == "solved" else summary.get("reason"),
        "makespan_s": round(makespan, 6),
        "arms": len(arms),
        "persons": len(persons),
        "arm_busy_s": _mean([busy[a] for a in arms]),
        "arm_idle_s": _mean([idle[a] for a in arms]),
        "person_busy_s": _mean([busy[a] for a in persons]),
        "person_idle_s": _mean([idle[a] for a in persons]),
        "idle_share": round(sum(idle.values()) / (len(agents) * makespan), 6)
        if makespan > 0 and agents
        else None,
        "person_share": round(sum(busy[a] for a in persons) / all_busy, 6) if all_busy else None,
        "stops": count["stop"],
        "replans": sum(count[t] for t in REPLAN_EVENTS),
        "declines": sum(1 for e in events if e.get("type") == "human_declined"),
        "decisions": summary.get("decisions"),
        "latency_median_ms": ms["median_s"],
        "latency_p95_ms": ms["p95_s"],
        "busy_by_agent": busy,
        "idle_by_agent": idle,
    }


# ----------------------------------------------------------------------- the reference ----
@dataclass(frozen=True)
class ReferenceTask:
    """The CP-SAT optimum of one scenario (plain data for a worker)."""

    scenario: str
    source: str
    objective: str
    time_limit_s: float
    simulator: str | None
    seed: int = 0  # a task the seed changes (parallel_assembly) is planned at this one


def solve_one(task: ReferenceTask) -> dict[str, Any]:
    """The optimum of one scenario (a worker, as :func:`run_one`): ``status``, ``makespan_s``,
    ``bound``, ``idle_by_agent`` when the schedule says, or ``error``."""
    out: dict[str, Any] = {"scenario": task.scenario}
    try:
        from flexhrc.planning import solve  # type: ignore[attr-defined, unused-ignore]
    except ImportError as exc:  # OR-tools (the plan extra) missing: no reference
        out["error"] = f"no optimum: {exc}"
        return out
    t0 = time.perf_counter()
    try:
        sc = _scenario(task.source, task.seed)
        kwargs: dict[str, Any] = {"objective": task.objective, "time_limit_s": task.time_limit_s}
        if task.simulator is not None:
            kwargs["simulator"] = task.simulator
        plan = solve(sc, **kwargs)
        out.update(status=str(plan.status), makespan_s=plan.makespan_s, bound=plan.bound)
        idle = _plan_idle(plan.to_json(), sc)
        if idle is not None:
            agents = sc.domain.agents
            for key, human in (("arm_idle_s", False), ("person_idle_s", True)):
                out[key] = _mean([v for a, v in idle.items() if agents[a].is_human == human])
            out["idle_by_agent"] = idle
    except Exception as exc:
        out["error"] = f"{type(exc).__name__}: {exc}".replace("\n", " ")
    out["solve_s"] = round(time.perf_counter() - t0, 3)
    return out


def _plan_idle(doc: Mapping[str, Any], scenario: Any) -> dict[str, float] | None:
    """Each agent's idle time in a plan's schedule (``{"action", "agents", "start_s",
    "end_s"}`` items), None when the plan has none."""
    sched = doc.get("schedule") if isinstance(doc, Mapping) else None
    span = doc.get("makespan_s") if isinstance(doc, Mapping) else None
    if not isinstance(sched, list) or not isinstance(span, int | float):
        return None
    spans: dict[str, list[tuple[float, float]]] = {a: [] for a in scenario.domain.agents}
    for item in sched:
        for a in item.get("agents") or ():
            if a in spans:
                spans[a].append((float(item["start_s"]), float(item["end_s"])))
    return {a: round(max(float(span) - _union(s), 0.0), 6) for a, s in spans.items()}


# ---------------------------------------------------------------------------- summaries ----
def _quartiles(xs: Sequence[float]) -> tuple[float, float, float]:
    """25th, 50th and 75th percentiles (linear between closest ranks, as numpy's default)."""
    s = sorted(xs)

    def q(p: float) -> float:
        k = (len(s) - 1) * p
        lo, hi = math.floor(k), math.ceil(k)
        return s[lo] + (s[hi] - s[lo]) * (k - lo)

    return q(0.25), q(0.5), q(0.75)


def summarise(
    rows: Sequence[Mapping[str, Any]],
    config: ExperimentConfig,
    reference: Mapping[str, Mapping[str, Any]],
) -> list[dict[str, Any]]:
    """One row per cell of the design: runs, solved, errors, median and quartiles of each
    :data:`SUMMARY_METRICS` over the solved runs, the optimum and the median's ratio to it."""
    out = []
    design = (config.scenarios, config.profiles, config.policies, config.utilities)
    for sc, profile, policy, utility in itertools.product(*design):
        key = (sc.label, profile, policy, utility)
        mine = [r for r in rows if tuple(r[k] for k in CELL_KEYS) == key]
        solved = [r for r in mine if r["outcome"] == "solved"]
        cell: dict[str, Any] = dict(zip(CELL_KEYS, key, strict=True))
        cell.update(
            runs=len(mine),
            solved=len(solved),
            errors=sum(1 for r in mine if r["outcome"] == "error"),
        )
        for m in SUMMARY_METRICS:
            xs = [float(r[m]) for r in solved if r.get(m) is not None]
            q1, med, q3 = _quartiles(xs) if xs else (None, None, None)
            cell[f"{m}_median"] = _round(med)
            cell[f"{m}_q1"] = _round(q1)
            cell[f"{m}_q3"] = _round(q3)
        opt = reference.get(sc.label, {}).get("makespan_s")
        cell["optimum_s"] = _round(opt)
        med = cell["makespan_s_median"]
        cell["makespan_ratio"] = _round(med / opt) if med is not None and opt else None
        out.append(cell)
    return out


def _round(x: float | None, digits: int = 4) -> float | None:
    return None if x is None else round(float(x), digits)


def _csv(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(
            {
                c: json.dumps(r.get(c), sort_keys=True) if isinstance(r.get(c), dict) else r.get(c)
                for c in columns
            }
        )
    return buf.getvalue()


def _summary_md(
    cells: Sequence[Mapping[str, Any]],
    config: ExperimentConfig,
    notes: Sequence[str],
    total: Mapping[str, Any],
) -> str:
    def fig(c: Mapping[str, Any], m: str, unit: str = "", scale: float = 1.0) -> str:
        med = c[f"{m}_median"]
        if med is None:
            return "–"
        q1, q3 = c[f"{m}_q1"], c[f"{m}_q3"]
        return f"{med * scale:.3g}{unit} [{q1 * scale:.3g}–{q3 * scale:.3g}]"

    lines = [
        f"# Experiment {config.name}",
        "",
        *([config.description.strip(), ""] if config.description.strip() else []),
        f"{total['runs']} runs ({design_words(config, ' × ')}), {total['solved']} solved, "
        f"{total['errors']} errors; "
        f"{total['wall_s']:.1f} s on {total['jobs']} processes.",
        "",
        "Median [interquartile range] over the solved runs of each cell. Makespan and idle "
        "times in simulated seconds (idle: mean over the arms, over the persons); idle share: of "
        "all agent-time; person share: the persons' part of the busy time; latency: the Task "
        "Manager's decision latency (ms, wall clock); ratio: median makespan / CP-SAT optimum.",
        "",
    ]
    head = ["scenario", "profile", "policy"]
    if len(config.utilities) > 1:
        head.append("utility")
    head += [
        "solved",
        "makespan (s)",
        "optimum (s)",
        "ratio",
        "arm idle (s)",
        "person idle (s)",
        "idle share",
        "person share",
        "stops",
        "re-plans",
        "declines",
        "latency median (ms)",
        "latency p95 (ms)",
    ]
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "---|" * len(head))
    for c in cells:
        row = [c["scenario"], c["profile"], c["policy"]]
        if len(config.utilities) > 1:
            row.append(c["utility"])
        row += [
            f"{c['solved']}/{c['runs']}",
            fig(c, "makespan_s"),
            "–" if c["optimum_s"] is None else f"{c['optimum_s']:.3g}",
            "–" if c["makespan_ratio"] is None else f"{c['makespan_ratio']:.3f}",
            fig(c, "arm_idle_s"),
            fig(c, "person_idle_s"),
            fig(c, "idle_share", "%", 100),
            fig(c, "person_share", "%", 100),
            fig(c, "stops"),
            fig(c, "replans"),
            fig(c, "declines"),
            fig(c, "latency_median_ms"),
            fig(c, "latency_p95_ms"),
        ]
        lines.append("| " + " | ".join(str(x) for x in row) + " |")
    if notes:
        lines += ["", "Notes:", ""] + [f"- {n}" for n in notes]
    lines += [
        "",
        "Files: runs.csv (one row per run), summary.csv, makespan.png, idle.png, experiment.json.",
        "",
    ]
    return "\n".join(lines)


# ------------------------------------------------------------------------------ the call ----
@dataclass
class ExperimentReport:
    """What :func:`run_experiment` did: the ``rows`` (one per run), the ``cells`` (the
    summary), the ``reference`` (each scenario's optimum), ``notes``, the output folder
    ``out`` and ``json`` (what ``experiment.json`` holds and ``--json`` prints)."""

    rows: list[dict[str, Any]]
    cells: list[dict[str, Any]]
    reference: dict[str, dict[str, Any]]
    notes: list[str]
    out: Path
    json: dict[str, Any]

    @property
    def text(self) -> str:
        j = self.json
        return (
            f"{j['runs']} runs, {j['solved']} solved, {j['errors']} errors in "
            f"{j['wall_s']:.1f} s ({j['jobs']} processes); wrote "
            + ", ".join(str(self.out / f) for f in j["files"])
        )


def check_out_dir(out: str | Path, *, force: bool) -> Path:
    """The output folder, checked before the work: it is created if it does not exist (its
    parent must); an existing one must be a folder, empty unless ``force``."""
    from flexhrc.files import OutputPathError

    p = Path(out)
    if str(out).strip() == "":
        raise OutputPathError("-o: empty path")
    if p.exists():
        if not p.is_dir():
            raise OutputPathError(f"-o {p}: exists and is not a folder")
        if any(p.iterdir()) and not force:
            raise OutputPathError(
                f"-o {p}: folder is not empty (use --force to write into it, or another -o)"
            )
        if not os.access(p, os.W_OK):
            raise OutputPathError(f"-o {p}: cannot write in the folder")
    else:
        parent = p.parent if str(p.parent) else Path(".")
        if not parent.is_dir():
            raise OutputPathError(f"-o {p}: folder {parent} does not exist")
        if not os.access(parent, os.W_OK):
            raise OutputPathError(f"-o {p}: cannot create it in {parent}")
    return p


def run_experiment(
    config: ExperimentConfig | str | Path,
    out: str | Path | None = None,
    *,
    jobs: int | None = None,
    force: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> ExperimentReport:
    """Run every run of the design ``config`` (a config or its file) in ``jobs`` processes
    (default: the CPU count; 1: in this process), write the outputs into ``out`` (default
    ``experiment-NAME``) and return the report. ``progress(done, total)`` is called as runs
    end."""
    from flexhrc.cell.replay import need_matplotlib
    from flexhrc.files import atomic_write_text

    if not isinstance(config, ExperimentConfig):
        config = read_config(config)
    cpus = os.cpu_count() or 1
    jobs = cpus if jobs is None else jobs
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= 256:
        raise FlexhrcError(f"--jobs must be a whole number in 1..256, got {jobs!r}")
    folder = check_out_dir(out if out is not None else f"experiment-{config.name}", force=force)
    need_matplotlib("experiment plots (makespan.png, idle.png)")
    sources = _load_sources(config)  # a scenario that cannot be loaded: its config line
    folder.mkdir(exist_ok=True)
    sources.update(_write_generated(config, folder))
    design = itertools.product(
        config.scenarios, config.profiles, config.policies, config.utilities.items(), config.seeds
    )
    tasks = [
        RunTask(
            i, sc.label, sources[sc.label], profile, policy, uname, ublock, seed, config.simulator
        )
        for i, (sc, profile, policy, (uname, ublock), seed) in enumerate(design, 1)
    ]
    solvable = can_solve()
    refs = [
        ReferenceTask(
            sc.label,
            sources[sc.label],
            config.objective,
            config.time_limit_s,
            config.simulator,
            config.seeds[0],
        )
        for sc in config.scenarios
        if solvable
    ]
    t0 = time.perf_counter()
    rows, solved_refs = _execute(tasks, refs, jobs, progress)
    wall = time.perf_counter() - t0
    rows.sort(key=lambda r: r["run"])
    notes: list[str] = []
    reference: dict[str, dict[str, Any]] = {}
    for ref in solved_refs:
        if "error" in ref:
            notes.append(f"{ref['scenario']}: no CP-SAT optimum ({ref['error']})")
        else:
            reference[ref["scenario"]] = ref
            if ref.get("status") != "optimal":
                notes.append(
                    f"{ref['scenario']}: the reference is {ref.get('status')} (not proven "
                    f"optimal in {config.time_limit_s:g} s; bound {ref.get('bound')})"
                )
    if not solvable:
        notes.append(
            "no CP-SAT optimum drawn: flexhrc.planning.solve is not available here (OR-tools, "
            "the plan extra: pip install 'flexhrc[plan]')"
        )
    failed = [r for r in rows if r["outcome"] != "solved"]
    for r in failed[:20]:
        notes.append(
            f"run {r['run']} ({r['scenario']}, {r['profile']}, {r['policy']}, seed "
            f"{r['seed']}): {r['outcome']}: {r['error']}"
        )
    if len(failed) > 20:
        notes.append(f"... and {len(failed) - 20} more runs not solved (runs.csv)")
    cells = summarise(rows, config, reference)
    below = sorted({c["scenario"] for c in cells if (c["makespan_ratio"] or 1.0) < 0.999})
    if below:
        notes.append(
            f"runs faster than the CP-SAT reference ({', '.join(below)}): the plan's action "
            "times are not the ones the runs simulate (a model gap of flexhrc.planning, not a "
            "better schedule than the optimum)"
        )
    total = {
        "runs": len(rows),
        "solved": sum(1 for r in rows if r["outcome"] == "solved"),
        "errors": sum(1 for r in rows if r["outcome"] == "error"),
        "wall_s": round(wall, 3),
        "jobs": jobs,
    }
    from flexhrc.app.experiment_plot import plot_box

    plot_box(rows, config, reference, "makespan", folder / "makespan.png")
    plot_box(rows, config, reference, "idle", folder / "idle.png")
    atomic_write_text(folder / "runs.csv", _csv(rows, RUN_COLUMNS))
    summary_cols = list(cells[0]) if cells else list(CELL_KEYS)
    atomic_write_text(folder / "summary.csv", _csv(cells, summary_cols))
    atomic_write_text(folder / "summary.md", _summary_md(cells, config, notes, total))
    doc: dict[str, Any] = {
        "experiment": FORMAT_VERSION,
        "name": config.name,
        "config": str(config.path) if config.path else None,
        "design": {
            "scenarios": [
                {"label": s.label, "source": sources[s.label], "generate": s.generate}
                for s in config.scenarios
            ],
            "profiles": list(config.profiles),
            "policies": list(config.policies),
            "utilities": dict(config.utilities),
            "seeds": list(config.seeds),
            "simulator": config.simulator,
        },
        **total,
        "files": list(OUTPUT_FILES),
        "reference": reference,
        "notes": notes,
        "cells": cells,
    }
    atomic_write_text(folder / "experiment.json", json.dumps(doc, indent=2) + "\n")
    return ExperimentReport(rows, cells, reference, notes, folder, doc)


def _load_sources(config: ExperimentConfig) -> dict[str, str]:
    """Each file or shipped scenario loaded once here, so a bad one is its config line."""
    out: dict[str, str] = {}
    for sc in config.scenarios:
        if sc.source is None:
            continue
        try:
            _scenario(sc.source)
        except FlexhrcError as exc:
            raise FormatError(f"scenario {sc.label!r}: {exc}", config.path, sc.line) from None
        out[sc.label] = sc.source
    return out


def _write_generated(config: ExperimentConfig, folder: Path) -> dict[str, str]:
    """The generated tasks, written to ``folder/scenarios/LABEL.yaml``."""
    from flexhrc.files import atomic_write_text
    from flexhrc.scenario.generate import generate

    out: dict[str, str] = {}
    for sc in config.scenarios:
        if sc.generate is None:
            continue
        target = folder / "scenarios" / f"{sc.label}.yaml"
        target.parent.mkdir(exist_ok=True)
        atomic_write_text(target, generate(**sc.generate))
        out[sc.label] = str(target)
    return out


def _execute(
    tasks: Sequence[RunTask],
    refs: Sequence[ReferenceTask],
    jobs: int,
    progress: Callable[[int, int], None] | None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Every run and every reference, in ``jobs`` processes (1: here)."""
    total = len(tasks) + len(refs)
    done = 0
    rows: list[dict[str, Any]] = []
    solved: list[dict[str, Any]] = []

    def tick() -> None:
        nonlocal done
        done += 1
        if progress is not None:
            progress(done, total)

    if progress is not None:
        progress(0, total)
    if jobs == 1:
        for ref in refs:
            solved.append(solve_one(ref))
            tick()
        for task in tasks:
            rows.append(run_one(task))
            tick()
        return rows, solved
    import multiprocessing
    from concurrent.futures import Future, ProcessPoolExecutor, as_completed

    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=jobs, mp_context=ctx) as pool:
        futures: dict[Future[dict[str, Any]], Any] = {}
        for ref in refs:  # the long solves first, while the runs fill the other processes
            futures[pool.submit(solve_one, ref)] = ref
        for task in tasks:
            futures[pool.submit(run_one, task)] = task
        try:
            for fut in as_completed(futures):
                item = futures[fut]
                try:
                    result = fut.result()
                except Exception as exc:  # a worker that died: its row says so
                    result = _lost(item, exc)
                (solved if isinstance(item, ReferenceTask) else rows).append(result)
                tick()
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    return rows, solved


def _lost(item: RunTask | ReferenceTask, exc: BaseException) -> dict[str, Any]:
    if isinstance(item, ReferenceTask):
        return {"scenario": item.scenario, "error": f"{type(exc).__name__}: {exc}"}
    row = item.row()
    row.update(outcome="error", error=f"the worker process died: {type(exc).__name__}: {exc}")
    return row


class ProgressBar:
    """A one-line progress bar on a stream (stderr): redrawn in place on a terminal, a line
    every tenth of the way (and at the end) otherwise."""

    def __init__(self, stream: Any = None, width: int = 30, label: str = "runs") -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.label = label
        self.t0 = time.perf_counter()
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_tenth = -1

    def __call__(self, done: int, total: int) -> None:
        frac = done / total if total else 1.0
        elapsed = time.perf_counter() - self.t0
        eta = elapsed / done * (total - done) if done else 0.0
        filled = round(frac * self.width)
        bar = "#" * filled + "-" * (self.width - filled)
        line = f"{self.label} [{bar}] {done}/{total} {frac:4.0%} {_clock(elapsed)} elapsed" + (
            f", {_clock(eta)} left" if done < total else ""
        )
        if self.tty:
            self.stream.write("\r" + line + ("\n" if done >= total else ""))
            self.stream.flush()
            return
        tenth = int(frac * 10)
        if tenth != self._last_tenth or done >= total:
            self._last_tenth = tenth
            self.stream.write(line + "\n")
            self.stream.flush()


def _clock(s: float) -> str:
    m, s = divmod(round(s), 60)
    return f"{m}:{s:02d}"
