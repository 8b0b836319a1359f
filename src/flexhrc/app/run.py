"""A cooperation run end to end, as one call: :class:`RunConfig` in, :class:`RunReport` out.

This is what ``flexhrc run FILE|NAME`` and ``flexhrc demo table`` do, without the command line:
load the scenario (a file of either format, a shipped name, a :class:`~flexhrc.scenario.Scenario`
or the table a :class:`TableDemo` describes), check every option against it before any work,
choose the simulators, the operators' wrist sensor and — with ``perception="scene"`` — the
head camera in the loop (:func:`flexhrc.sensing.setup.perceived_run`), stream the event log,
run the one loop (:func:`flexhrc.scenario.prepare`), draw the timeline and summarise.

A field of :class:`RunConfig` is the option of ``flexhrc run`` of the same name, with the same
default; an error names that option (``--fail 'x:0': N must be at least 1 ...``), so the command
line and a program get the same words. ``flexhrc run`` and ``flexhrc demo table`` translate their
arguments into a config, call :func:`run_scenario`, print :attr:`RunReport.text` (or
:attr:`RunReport.json` under ``--json``) and exit with :attr:`RunReport.exit_code`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import signal
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.cell.local import InjectedFailure, Observer, RunResult
from flexhrc.cell.replay import PLOT_SUFFIXES, need_matplotlib
from flexhrc.errors import FlexhrcError
from flexhrc.events import DECISION_POLICIES, PROFILES, TRACE_TYPES
from flexhrc.scenario.model import Scenario
from flexhrc.scenario.simulators import CHOICES as SIMULATOR_CHOICES
from flexhrc.scenario.simulators import TIMING_CHOICES, choose_simulator, resolve_simulator_name
from flexhrc.taskmanager.manager import FAILURE_POLICIES, REACTIONS
from flexhrc.taskmanager.replay import outcome_line, plural, table_i

HUMAN_SENSING = ("injected", "har", "har-real")
PERCEPTION = ("given", "scene")
DISTURBANCES = ("blocked_path", "slow_arm", "push")
#: ``--disturb push``: how far (m) and when (s into the hold) the held object is pushed
PUSH_OFFSET_M = (0.03, 0.0, 0.0)
PUSH_AT_S = 0.3
MAX_SEED = 2**32 - 1
#: The exit code of a run a signal stopped (the shell's 128 + signal number).
EXIT_SIGNAL = {signal.SIGINT: 130, signal.SIGTERM: 143}
#: The live trace's line of the event types that need no more than their fields
#: (:func:`trace_line`; the others are spelled out there).
TRACE_LINES = {
    "abort": "stop {element}: {reason}",
    "action_failed": "FAILED {element} ({status}): {reason}",
    "infeasible": "{element} infeasible: {reason}",
    "recognised": "human did {action} -> follows {element}",
    "human_action_unmatched": "human did {action}: it advances no feasible hyper-arc",
    "human_sensed": "wrist sensor: {performed} -> recognised {recognised} "
    "(confidence {confidence:.2f}, {samples} samples)",
    "human_sensing_missed": "wrist sensor missed {action}: the manager is not told",
    "false_report": "wrist sensor reports {action} (false)",
    "inconsistent": "INCONSISTENT: {reason}",
    "consistent_again": "consistent again: {object} ({why})",
    "repaired": "repaired {object} by {by}",
    "operator_answers": "operator: {answer} ({question})",
    "operator_nudges": "operator moves {part} by {offset}",
    "stop": "STOP {agent}: {reason}",
    "process_ended": "{process} ended ({reason}); {node} can be met",
    "precondition_failed": "{element}: {reason} at dispatch; re-planning",
    "waiting": "waiting: {reason}",
}


@dataclass(frozen=True)
class TableDemo:
    """The table of ``flexhrc demo table`` (:func:`flexhrc.scenario.table_assembly`): ``legs``,
    the ``tabletop`` (``large``, ``small`` or ``WxD`` in metres), the ``leg_length`` (``long``
    or ``short``), bolts no arm reaches, and whether a person works with the robot
    (``--no-human`` is ``human=False``). As :attr:`RunConfig.scenario`, its summary speaks of
    legs and bolts (``--human-takes K`` is bolt K) and its JSON has no ``scenario`` key."""

    legs: int = 4
    tabletop: str = "large"
    leg_length: str = "long"
    unreachable_bolts: tuple[int, ...] = ()
    human: bool = True


@dataclass(frozen=True)
class RunConfig:
    """Everything one run needs; the fields are the options of ``flexhrc run`` (see the module
    docstring), checked when the config is made (one :class:`~flexhrc.errors.FlexhrcError`).

    ``scenario`` is a file (``flexhrc: 1`` or an older ``scenario:`` file), a shipped name, a
    :class:`~flexhrc.scenario.Scenario` or a :class:`TableDemo`. ``human`` overrides every
    operator's profile; ``human_takes`` scripts the operator (the K-th cooperation step it
    could do); ``fail`` are ``ACTION[:N]`` failures, ``disturb`` ``KIND[:ACTION[:N]]``
    disturbances of the kinematic simulator; ``on_failure`` what a failed robot action does to
    its hyper-arc (``retry``, ``paper``; None: the scenario's ``on_failure``, else ``retry``);
    ``simulator`` None is the scenario's choice, as is ``timing`` None (``default`` or
    ``paper``: how simulated actions are timed, :data:`~flexhrc.taskmanager.kinds.TIMINGS`).
    ``log`` streams the event log (JSON lines), ``plot`` draws the timeline; ``quiet`` drops
    the progress lines; ``realtime`` paces the simulated clock (SPEED times real time).
    ``operators`` is an operator model file (``flexhrc learn``, ``docs/operators.md``): the Task
    Manager times each person's steps by what that person took before. ``policy`` is how the
    Task Manager decides (``paper``, ``lookahead``: :mod:`flexhrc.planning`; None: the
    scenario's ``policy``, else ``paper``).
    """

    scenario: str | Path | Scenario | TableDemo = "table_assembly"
    segments: str | None = None
    human: str | None = None
    seed: int = 0
    human_takes: tuple[int, ...] | None = None
    fail: tuple[str, ...] = ()
    reaction: str = "conflicts"
    on_failure: str | None = None
    answer_timeout: float | None = None
    simulator: str | None = None
    timing: str | None = None
    disturb: tuple[str, ...] = ()
    human_sensing: str = "injected"
    hmp: str | Path | None = None
    perception: str = "given"
    repair: bool = False
    har_model: str | Path | None = None
    log: str | Path | None = None
    plot: str | Path | None = None
    quiet: bool = False
    realtime: float | None = None
    operators: str | Path | None = None
    policy: str | None = None

    def __post_init__(self) -> None:
        for option, value, choices in (
            ("--human", self.human, (None, *PROFILES)),
            ("--reaction", self.reaction, REACTIONS),
            ("--on-failure", self.on_failure, (None, *FAILURE_POLICIES)),
            ("--simulator", self.simulator, (None, *SIMULATOR_CHOICES)),
            ("--timing", self.timing, (None, *TIMING_CHOICES)),
            ("--human-sensing", self.human_sensing, HUMAN_SENSING),
            ("--perception", self.perception, PERCEPTION),
            ("--policy", self.policy, (None, *DECISION_POLICIES)),
        ):
            if value not in choices:
                names = ", ".join(c for c in choices if c is not None)
                raise FlexhrcError(f"{option} {value!r}: choose one of {names}")
        if not (isinstance(self.seed, int) and 0 <= self.seed <= MAX_SEED):
            raise FlexhrcError(f"--seed must be a whole number in [0, {MAX_SEED}], got {self.seed}")
        if self.realtime is not None and not (math.isfinite(self.realtime) and self.realtime > 0):
            raise FlexhrcError(f"--realtime must be a finite number > 0, got {self.realtime}")
        # perception and human sensing: the combinations that cannot work
        real = self.human_sensing == "har-real"
        if real and not self.hmp:
            raise FlexhrcError("--human-sensing har-real needs --hmp DIR (the HMP dataset folder)")
        if self.hmp and not real:
            raise FlexhrcError("--hmp goes with --human-sensing har-real")
        if self.hmp and not Path(self.hmp).is_dir():
            raise FlexhrcError(f"--hmp {self.hmp}: not a directory")
        if real and self.har_model:
            raise FlexhrcError(
                "--har-model goes with --human-sensing har (har-real trains its own model on "
                "other volunteers than those it replays)"
            )
        if self.policy == "lookahead" and self.perception == "scene":
            raise FlexhrcError("--policy lookahead goes with --perception given (not scene yet)")
        if self.repair and self.perception != "scene":
            raise FlexhrcError("--repair needs --perception scene (only perception notices)")
        if self.har_model and self.human_sensing == "injected":
            raise FlexhrcError("--har-model goes with --human-sensing har")


@dataclass
class RunReport:
    """How a run ended: ``json`` (what ``flexhrc run --json`` prints: the summary, with
    ``scenario`` first, except for a :class:`TableDemo`), ``text`` (Table I and the outcome
    line), ``warnings`` (failures that never happened), the run's ``result`` (the whole event
    log) and ``signal``, the signal that stopped it (None if it ran to its end)."""

    json: dict[str, Any]
    text: str
    result: RunResult
    warnings: list[str] = field(default_factory=list)
    signal: int | None = None

    @property
    def decision_latency(self) -> dict[str, Any]:
        """The Task Manager's decision latency in this run, measured in the engine (wall
        seconds to answer each input that made a decision, :class:`~flexhrc.cell.supervisor.
        Cell`): ``n``, ``median_s``, ``p95_s``, ``max_s`` (None when nothing was decided).
        Not in :attr:`json`, which holds what the cooperation did, the same on every machine
        but for its compute times."""
        from flexhrc.cell.supervisor import latency_figures

        return latency_figures(self.result.decision_latency_s)

    @property
    def exit_code(self) -> int:
        """0 solved, 1 not solved, 130/143 stopped by SIGINT/SIGTERM."""
        if self.signal is not None:
            return EXIT_SIGNAL[signal.Signals(self.signal)]
        return 0 if self.result.outcome == "solved" else 1


@dataclass
class _Job:
    """A config's scenario, loaded: ``table`` for the table's words (a :class:`TableDemo` or an
    older table file), ``where`` the file line that says ``human:``."""

    scenario: Scenario
    path: Path | None
    table: bool = False
    profile: str | None = None
    where: str = ""


def run_scenario(
    config: RunConfig,
    *,
    trace: Observer | None = None,
    progress: Callable[[str], None] | None = None,
) -> RunReport:
    """Run the cooperation ``config`` describes to its end (see the module docstring).

    ``trace`` sees every event of the log as it happens; ``progress`` gets the lines that say
    what takes long before the run (training a recogniser, setting up the camera) unless
    ``config.quiet``. In the main thread, SIGINT and SIGTERM stop the run at its next event
    (outcome ``interrupted``, :attr:`RunReport.signal`); a second one stops it at once.
    """
    from flexhrc.files import EventLogWriter, check_output
    from flexhrc.scenario import prepare

    def say(line: str) -> None:
        if progress is not None and not config.quiet:
            progress(line)

    job = _job(config)
    sc = job.scenario
    import flexhrc.planning.policies  # noqa: F401  (registers the lookahead policy)

    takes = list(config.human_takes) if config.human_takes else None
    if not job.table:
        name = job.path or sc.name
        for given, option in ((config.human, f"--human {config.human}"), (takes, "--human-takes")):
            if given and not sc.humans:
                raise FlexhrcError(f"{option} needs an operator, but {name} has no humans")
        # a step is a node some hyper-arc reaches: no more steps than hyper-arcs
        most = sc.graph.stats()["instantiated_hyperarcs"]
        assert isinstance(most, int)
        for k in takes or []:
            if k < 1:
                raise FlexhrcError(f"--human-takes {k}: steps are counted from 1")
            if k > most:
                raise FlexhrcError(
                    f"--human-takes {k}: {sc.name} has at most {most} steps (one per node a "
                    "hyper-arc reaches)"
                )
    robot_actions = _robot_actions(sc)
    failures = _failures(config.fail, robot_actions)
    legs = sum(1 for o in sc.world().objects.values() if o.type == "leg")
    if job.table and takes:
        for k in takes:
            if not 1 <= k <= legs:
                raise FlexhrcError(f"--human-takes {k}: not one of the bolts 1..{legs}")
        if not sc.humans:
            raise FlexhrcError(f"--human-takes needs a human, but {job.where}human: false")
    inputs = [p for p in (job.path, config.har_model, config.operators) if p is not None]
    if config.log is not None:
        check_output(config.log, option="--log", inputs=inputs)
    if config.plot is not None:
        check_output(config.plot, option="--plot", suffixes=PLOT_SUFFIXES, inputs=inputs)
        if config.log is not None and Path(config.plot).resolve() == Path(config.log).resolve():
            raise FlexhrcError(f"--plot {config.plot}: also given to --log; use two files")
        need_matplotlib()
    timing = config.timing or sc.timing
    simulator = _simulator(
        config.simulator or ("auto" if job.table else sc.simulator),
        config.disturb,
        robot_actions,
        timing,
        _holds(sc),
    )
    if config.operators is not None:  # the person as measured, not the scenario's figures
        from flexhrc.taskmanager.operator_model import OperatorModelSimulator, read_model

        simulator = OperatorModelSimulator(simulator, read_model(config.operators))
    sensing = _human_sensing(config, say)
    # the table's --human-takes K is bolt K: the K-th step of the legs fix alone, else its node
    steps: list[Any] | None = takes
    if job.table and takes and sc.segments != ("legs",):
        steps = [f"connected_{k}" for k in takes]
    writer = EventLogWriter(config.log) if config.log else None
    try:
        run = prepare(
            sc,
            profile=job.profile or config.human,
            seed=config.seed,
            simulator=simulator,
            execution=simulator,
            reaction=config.reaction,
            on_failure=config.on_failure,
            answer_timeout=config.answer_timeout,
            policy=config.policy,
            trace=trace,
            sink=writer.write if writer is not None else None,
            failures=failures,
            human_takes=steps,
            human_sensing=sensing,
            realtime=config.realtime or 0.0,
        )
        if config.perception == "scene":
            run = _perceived(config, run, steps, say)
        with _stop_on_signals(run) as caught:
            result = run.run()
    finally:
        if writer is not None:
            writer.close()
    if job.table:
        who = f"human takes bolts {takes}" if takes else f"human {job.profile}"
        title = f"table assembly, {plural(legs, 'leg')}, {who}, seed {config.seed}"
        data, subject = dict(result.summary), ""
    else:
        who = ", ".join(f"{n} {p}" for n, p in run.operator_profiles()) or "no operator"
        title = f"{sc.name}, {who}, seed {config.seed}"
        data, subject = {"scenario": sc.name, **result.summary}, f"{sc.name}: "
    data = _with_sensing(data, config)
    if timing != "default":  # the default keeps the JSON as it was
        data["timing_profile"] = timing
    if config.operators is not None:
        data["operator_model"] = {
            "file": str(config.operators),
            "learned_steps": simulator.replaced,
        }
    if config.plot:
        from flexhrc.files import atomic_output
        from flexhrc.taskmanager.timeline import plot_timeline

        with atomic_output(config.plot) as tmp:
            plot_timeline(result.events, tmp, title)
    warnings = [
        f"warning: --fail {f.action}:{f.nth} never happened: the run had "
        f"{plural(run.executions_of(f.action), f.action + ' action')}"
        for f in run.unfired_failures()
    ]
    text = ["", table_i(data), "", outcome_line(data, subject, simulated=True)]
    text += [f"event log: {config.log}"] if config.log else []
    text += [f"timeline: {config.plot}"] if config.plot else []
    return RunReport(data, "\n".join(text), result, warnings, caught[0] if caught else None)


def _job(config: RunConfig) -> _Job:
    """The scenario of ``config``, loaded as ``flexhrc run`` loads it."""
    from flexhrc import scenario as scenario_mod
    from flexhrc.scenario.legacy import from_legacy, is_legacy, read_document
    from flexhrc.scenario.source import NAMES

    given = config.scenario
    if isinstance(given, TableDemo):
        return _table(config, given)
    if isinstance(given, Scenario):
        return _Job(given, given.path)
    if str(given) in NAMES and not Path(given).exists():  # as `cell`, `ros2` ...
        sc = scenario_mod.load_scenario(given, seed=config.seed, segments=config.segments)
        return _Job(sc, sc.path or Path(given))
    path = scenario_mod.resolve(given)
    doc = read_document(path)
    if not is_legacy(doc):
        if config.segments is not None:  # parts of a task, alike in every command
            sc = scenario_mod.load_scenario(path, seed=config.seed, segments=config.segments)
            return _Job(sc, path)
        return _Job(scenario_mod.load(path), path)
    # the older files: the legs fix of one table (unless --segments says otherwise) or a
    # parallel assembly, translated by flexhrc.scenario.legacy
    lines: dict[str, int] = getattr(doc, "lines", {})
    sc = from_legacy(path, doc, seed=config.seed, segments=config.segments)
    if sc.name != "table_assembly":
        return _Job(sc, path)
    if config.human is not None and not sc.humans and config.human != "passive":
        raise FlexhrcError(
            f"--human {config.human} needs a human, but {path}:{lines.get('human')}: human: false"
        )
    where = f"{path}:{lines.get('human')}: " if "human" in doc else ""
    profile = sc.humans[0].profile if sc.humans else "passive"
    return _Job(sc, path, table=True, profile=config.human or profile, where=where)


def _table(config: RunConfig, demo: TableDemo) -> _Job:
    """The table of ``flexhrc demo table``; its errors in the words of the demo's options."""
    from flexhrc.scenario.builtin.table import ScenarioError, TableLayout, table_assembly

    table = {**dataclasses.asdict(demo), "seed": config.seed}  # TableLayout's keywords
    try:
        TableLayout(**table)  # the table's errors in the words of the options, first
        if not demo.human and config.human_takes:
            raise FlexhrcError("--human-takes needs a human: drop --no-human")
        if not demo.human and config.human is not None:
            raise FlexhrcError(f"--human {config.human} needs a human: drop --no-human")
        if config.perception == "scene":
            table = _bodies_apart(table)
        sc = table_assembly(**table, segments=config.segments or "all")
    except ScenarioError as exc:  # a setting of the table -> the demo's option
        flag = "--unreachable-bolt" if exc.key == "unreachable_bolts" else f"--{exc.key}"
        text = f"{flag.replace('_', '-')} {exc.detail}"
        if exc.fix is not None:  # a bigger tabletop
            text += f"; --{exc.fix[0]} {exc.fix[1]} holds them"
        raise FlexhrcError(text) from None
    return _Job(sc, None, table=True, profile=config.human or "passive")


def _robot_actions(scenario: Scenario) -> list[str]:
    """The actions a robot agent of the scenario may carry out (what --fail and --disturb
    name)."""
    domain = scenario.domain
    return sorted(
        name
        for name, schema in domain.actions.items()
        if any(not a.is_human for a in domain.capable(schema))
    )


def _action_and_nth(
    spec: str, option: str, action: str, n: str, actions: list[str], bad_n: str
) -> tuple[str, int]:
    """The robot action and N (from 1) of a ``--fail`` or ``--disturb`` spec."""
    where = f"{option} {spec!r}"
    if action not in actions:
        raise FlexhrcError(f"{where}: unknown robot action {action!r}; one of {', '.join(actions)}")
    try:
        nth = int(n) if n else 1
    except ValueError:
        raise FlexhrcError(f"{where}: {bad_n}") from None
    if not 1 <= nth <= 1_000_000:
        got = f", got {nth}" if option == "--disturb" else ""
        raise FlexhrcError(f"{where}: N must be at least 1 (the first time is 1){got}")
    return action, nth


def _failures(specs: tuple[str, ...], actions: list[str]) -> list[InjectedFailure]:
    """``--fail ACTION[:N]``: the N-th execution of the robot ACTION fails."""
    out = []
    for spec in specs:
        action, sep, n = spec.partition(":")
        usage = "expected ACTION or ACTION:N"
        if not action or ":" in n or (sep and not n):
            raise FlexhrcError(f"--fail {spec!r}: {usage}")
        out.append(InjectedFailure(*_action_and_nth(spec, "--fail", action, n, actions, usage)))
    return out


def _holds(scenario: Scenario) -> dict[str, str]:
    """The robot processes and actions that hold an object with the controller (what
    ``--disturb push`` may name), each with its action kind."""
    from flexhrc.taskmanager.kinds import kind_of

    domain = scenario.domain
    return {
        name: schema.kind
        for name, schema in (*domain.processes.items(), *domain.actions.items())
        if any(step.action == "hold" for step in kind_of(schema).motion)
        and any(not a.is_human for a in domain.capable(schema))
    }


def _simulator(
    name: str,
    disturb: tuple[str, ...],
    actions: list[str],
    timing: str = "default",
    holds: Mapping[str, str] | None = None,
) -> Any:
    """The branch simulator, which also plays the real world, timed by the profile ``timing``,
    with ``disturb``'s disturbances scheduled (kinematic only; checked before anything is
    built). ``push`` names a process or action of ``holds`` (default: the first): the held
    object is pushed :data:`PUSH_OFFSET_M` :data:`PUSH_AT_S` s into its N-th hold."""
    name = resolve_simulator_name(name)
    holds = holds or {}
    if name == "analytic" and disturb:
        raise FlexhrcError("--disturb needs --simulator kinematic (use --fail with analytic)")
    specs = []
    for spec in disturb:
        kind, _, rest = spec.partition(":")
        if kind not in DISTURBANCES:
            raise FlexhrcError(f"--disturb {spec!r}: KIND is blocked_path, slow_arm or push")
        action, _, n = rest.partition(":")
        if kind == "push":
            if not holds:
                raise FlexhrcError(
                    f"--disturb {spec!r}: nothing in this scenario holds an object (a process "
                    "or action of kind hold)"
                )
            action, nth = _action_and_nth(
                spec, "--disturb", action or next(iter(holds)), n, sorted(holds),
                "N must be a whole number",
            )  # fmt: skip
            push = {"kind": kind, "once": True, "at_s": PUSH_AT_S, "offset": PUSH_OFFSET_M}
            specs.append((holds[action], nth, push))
            continue
        action, nth = _action_and_nth(
            spec, "--disturb", action or "transport", n, actions, "N must be a whole number"
        )
        params: dict[str, Any] = {"kind": kind, "once": True, "at_s": 0.3}
        if kind == "slow_arm":
            params.update(factor=0.2, at_s=None)
        specs.append((action, nth, params))
    _, sim = choose_simulator(name, timing=timing)
    for action, nth, params in specs:
        sim.schedule(action, nth, **params)
    return sim


def _human_sensing(config: RunConfig, say: Callable[[str], None]) -> Any:
    """The operators' wrist sensor (None: the manager is told what the operator did)."""
    if config.human_sensing == "injected":
        return None
    try:
        from flexhrc.perception.human import GMMGMRRecognizer
        from flexhrc.perception.human.sensing import WearableHumanSensor
        from flexhrc.sensing.har_real import HmpReplaySensor
    except ImportError as exc:
        raise FlexhrcError(
            f"--human-sensing {config.human_sensing} needs the perception extra ({exc.name} is "
            "missing): pip install 'flexhrc[perception]'"
        ) from None
    if config.human_sensing == "har-real":
        say("training the wrist-motion recogniser on HMP volunteers ...")
        return HmpReplaySensor(str(config.hmp), seed=config.seed)
    model = GMMGMRRecognizer.load(config.har_model) if config.har_model else None
    if model is None:
        say("training the wrist-motion recogniser on synthetic motions ...")
    return WearableHumanSensor(model, seed=config.seed)


def _bodies_apart(table: dict[str, Any]) -> dict[str, Any]:
    """With perception the legs are bodies the camera sees, not points: when the demo's
    placement (``table``: the options of :class:`TableLayout`) puts them too close to lie side
    by side, they are laid out clear of each other (seeded, beside the tabletop)."""
    from flexhrc.scenario.builtin.table import LEG_LENGTHS, TableLayout
    from flexhrc.sensing.loop import lying_layout
    from flexhrc.sensing.world import SimulatedWorkspace

    layout = TableLayout(**table)
    with contextlib.suppress(FlexhrcError):  # they lie apart as they are
        SimulatedWorkspace.from_knowledge(layout.world())
        return table
    try:
        positions = lying_layout(
            layout.legs,
            layout.seed,
            tabletop_depth=layout.size[1],
            length=LEG_LENGTHS[layout.leg_length],
        )
    except FlexhrcError:
        raise FlexhrcError(
            f"--perception scene: {plural(layout.legs, 'leg')} do not fit beside the tabletop "
            "as bodies the camera can tell apart; use fewer --legs"
        ) from None
    return {**table, "leg_positions": positions}


def _perceived(config: RunConfig, run: Any, steps: Any, say: Callable[[str], None]) -> Any:
    """The perceived twin of a prepared run (same graph, domain, world, simulator, operators
    and options), as a configuration of the cell: the head camera, the scene pipeline and
    anchoring in the loop; the manager is given no position of the parts."""
    from flexhrc.sensing.setup import perceived_run  # (it names the extras it misses)

    say("perception: head camera, scene pipeline, anchoring ...")
    cell = run.cell  # a LocalCell: the cell's in-process configuration
    return perceived_run(
        cell.graph,
        cell.domain,
        cell.kb,
        repair=config.repair,
        simulator=cell.tm.simulator,
        execution=run.injection.inner,
        seed=config.seed,
        failures=run.injection.failures,
        observers=cell.observers[1:],  # the streamed log and the trace, not its own list
        realtime=cell.realtime,
        human_takes=steps,
        human_sensing=run.human_sensing,
        humans=run.operator_profiles(),
        reaction=cell.tm.reaction,
        on_failure=cell.tm.on_failure,
        name=str(run.scenario.name),
    )


def _with_sensing(data: dict[str, Any], config: RunConfig) -> dict[str, Any]:
    """The ``mode`` of the ``perception`` (with ``--perception scene``) and ``human_sensing``
    (with it or a wrist sensor) figures, which only those cells put in their summaries."""
    if config.perception == "scene":
        data["perception"] = {"mode": "scene", **data["perception"]}
    if config.perception == "scene" or config.human_sensing != "injected":
        data["human_sensing"] = {"mode": config.human_sensing, **data["human_sensing"]}
    return data


def _terms_text(t: dict[str, Any]) -> str:
    """A branch's terms in the trace: time, the shaped utility's, an operator model's."""
    shown = [f"time {t['time']:.2f} s"]
    if "preference" in t:
        shown += [f"preference {t['preference']:g}", f"workload {t['workload']:.0%}"]
    if "p_decline" in t:
        shown += [f"declines {t['p_decline']:.0%}", f"cannot {t['p_cannot']:.0%}"]
    return ", ".join(shown)


def trace_line(event: dict[str, Any]) -> str | None:
    """The line of the live trace (``flexhrc run`` without ``--quiet``) for a log event, None
    for an event the trace leaves out (not in :data:`~flexhrc.events.TRACE_TYPES`)."""
    ev, kind = event, event["type"]
    if kind not in TRACE_TYPES:
        return None
    if kind == "human_sensed" and (ev.get("why") or ev.get("recognised") is None):
        # not sensed at all (why), or sensed and not recognised (the miss line follows)
        line = f"wrist sensor: {ev.get('why') or ev['performed'] + ' -> recognised nothing'}"
        if not ev.get("why"):
            line += f" ({ev['samples']} samples)"
    elif kind in TRACE_LINES:
        line = TRACE_LINES[kind].format_map(ev)
        if kind == "action_failed" and ev.get("kept"):
            line += f"; its result holds: {ev['element']} counts as solved"
    elif kind == "decision":
        line = f"decide {ev['element']} (cost {ev['cost']}): "
        line += f"{plural(len(ev['branches']), 'branch')} simulated"
        if ev.get("pruned"):  # eq. 20: failing pre(a) keeps a branch from the simulator
            first = ev["pruned"][0]["reason"]
            line += (
                f", {len(ev['pruned'])} pruned ({first}{', ...' if len(ev['pruned']) > 1 else ''})"
            )
        if ev["chosen"] is not None:
            b = ev["branches"][ev["chosen"]]
            grounding = ", ".join(f"{k}={v}" for k, v in sorted(b["grounding"].items()))
            line += f", best {grounding} J={b['utility']:.4f}"
            if "terms" in b:  # a shaped utility, an operator model (issue 22): J's terms
                line += f" ({_terms_text(b['terms'])})"
            # a person's branch an operator model marked down (expected utility): why it lost
            odds = [o for o in ev["branches"] if "p_decline" in o.get("terms", {}) and o is not b]
            if odds and "p_decline" not in b.get("terms", {}):
                o = max(odds, key=lambda o: o["utility"])
                who = "+".join(o["agents"])
                line += f"; {who}'s J={o['utility']:.4f} ({_terms_text(o['terms'])})"
        else:
            line += ", none succeeds"
    elif kind == "command":
        line = f"{'+'.join(ev['agents']):<6} {ev['action']}"
    elif kind == "suggestion":
        line = f"ask human: {ev['element']}: {'; '.join(ev['actions'])}"
    elif kind == "human_decides":
        line = f"{ev.get('agent', 'human')} goes for {ev['element']}: {'; '.join(ev['actions'])}"
    elif kind == "human_gives_up":
        what = ev.get("object") or ev.get("step")
        line = f"{ev.get('agent', 'human')} leaves {what}: the {ev['holder']} got there first"
    elif kind == "repair":
        line = f"repair: {ev['step']}" + (f" - {ev['question']}" if "question" in ev else "")
    elif kind == "process_activated":
        line = f"{ev['node']} reached: its processes start ({', '.join(ev['processes'])})"
    elif kind == "outcome":
        line = f"outcome: {ev['outcome'].upper()}" + (f" ({ev['reason']})" if ev["reason"] else "")
    else:  # a trace type this function does not know yet
        line = json.dumps(ev)
    return f"{ev['t']:7.2f}s  {line}"


@contextlib.contextmanager
def _stop_on_signals(run: Any) -> Iterator[list[int]]:
    """SIGINT/SIGTERM ask the run to stop at its next event (it then writes an ``outcome``
    event ``interrupted`` and the summary); a second signal stops at once."""
    caught: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield caught
        return

    def handler(signum: int, _frame: Any) -> None:
        if caught:
            raise KeyboardInterrupt
        caught.append(signum)
        run.request_stop(f"interrupted by {signal.Signals(signum).name}")

    old = {sig: signal.signal(sig, handler) for sig in EXIT_SIGNAL}
    try:
        yield caught
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)
