"""What every run of ``flexhrc behave`` shares: its config, the task it runs, its log, its words.

* :class:`BehaveConfig` — one run of a task (one robot, or a team of robots sharing it), checked
  when it is made: every error names the command-line option, as ``flexhrc behave`` prints it;
* :class:`LoadedTask` and :func:`load_target` — the task, its world and the behaviour types of its
  leaves, from an inline prefix task or a task file;
* :class:`BehaveReport` — what a command prints: the ``--json`` document, the text, the exit code;
* :func:`trace_line`, :func:`live_line`, :func:`summary_lines` — the words of the trace and of the
  end of a report, the same for a live run, a team and :func:`flexhrc.behavior.behave.replay`.

The runs themselves are :func:`flexhrc.behavior.behave.run_behave` (which hands a team to
:mod:`flexhrc.behavior.team`).
"""

from __future__ import annotations

import math
import signal
import sys
import time
from collections.abc import Callable, Iterable, Mapping
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from flexhrc.behavior.network import BehaviorNetwork
from flexhrc.behavior.task import Task, parse_prefix
from flexhrc.behavior.types import BehaviorFactory
from flexhrc.behavior.world import TabletopWorld, random_world
from flexhrc.errors import FlexhrcError, UnknownNameError

MAX_SEED = 2**63 - 1
MAX_TICKS = 10**9
TASK_SUFFIXES = (".yaml", ".yml", ".txt")
PLOT_SUFFIXES = (".png", ".svg", ".pdf")
TRANSPORTS = ("inprocess", "zenoh")
RENDERINGS = ("ascii", "dot")
#: Simulated seconds per wall second of the robots of a team over Zenoh (``--realtime``).
DEFAULT_TEAM_SPEED = 10.0

#: One line of a report or of the live trace (stdout, or stderr under ``--json``).
LineSink = Callable[[str], None]


def check_task(target: object, seed: int = 0) -> None:
    """One error for an empty task argument (``behave ""``) or a seed out of range."""
    if target == "":
        raise FlexhrcError(
            "TASK_OR_SCENARIO is empty: give a scenario name (table-setting, "
            "table-setting-robustness, abstract), a task file or an inline task such as "
            "'(THEN a (AND b c))'"
        )
    if not 0 <= seed <= MAX_SEED:
        raise FlexhrcError(f"--seed must be an integer in 0..2**63-1, got {seed}")


@dataclass(frozen=True)
class LoadedTask:
    """A task ready to run: its ``label`` in reports, the task, its world, and the factories of
    the leaves a task file gives a ``type:`` (see :mod:`flexhrc.behavior.types`)."""

    label: str
    task: Task
    world: TabletopWorld
    behaviors: Mapping[str, BehaviorFactory] = field(default_factory=dict)


@dataclass(frozen=True)
class BehaveConfig:
    """One run of ``flexhrc behave TASK`` (the defaults are the command's).

    ``target`` is an inline task such as ``"(THEN a (AND b c))"``, a task file, or a
    :class:`LoadedTask` (the command line turns a scenario name into one). ``arms`` (1 or 2)
    shapes a generated world; ``max_ticks`` defaults to
    :func:`~flexhrc.behavior.network.default_max_ticks`; ``realtime`` runs at that many times
    wall-clock time and reports state changes as they happen; ``log`` streams the event log
    (JSON lines), ``plot`` draws the Gantt chart; ``render`` (``ascii`` or ``dot``) only prints
    the network. ``types`` are modules that register behaviour types (imported first).

    ``robots`` (1..4) robots share the task, each with one arm, all in this process
    (``transport`` ``inprocess``) or one process per robot over Zenoh (``zenoh``); ``robot`` and
    ``peer_port`` make this process one robot of such a team (``peer_port`` 0: the first robot
    listens on a port the system picks and writes it as JSON to ``ready_file``, so no port is
    chosen for it that another process could take first). Over Zenoh the robot processes load
    the task themselves from ``child_args`` (``flexhrc behave`` arguments; by default the target,
    which must then be text).
    """

    target: str | LoadedTask
    arms: int | None = None
    seed: int = 0
    max_ticks: int | None = None
    realtime: float | None = None
    log: str | None = None
    plot: str | None = None
    render: str | None = None
    types: tuple[str, ...] = ()
    robots: int = 1
    transport: str | None = None
    robot: str | None = None
    peer_port: int | None = None
    ready_file: str | None = None
    child_args: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        check_task(self.target, self.seed)
        if self.max_ticks is not None and not 1 <= self.max_ticks <= MAX_TICKS:
            raise FlexhrcError(f"--max-ticks must be in 1..{MAX_TICKS}, got {self.max_ticks}")
        if self.realtime is not None and not (math.isfinite(self.realtime) and self.realtime > 0):
            raise FlexhrcError(f"--realtime SPEED must be a finite number > 0, got {self.realtime}")
        if self.arms not in (None, 1, 2):
            raise FlexhrcError(f"--arms must be 1 or 2, got {self.arms}")
        if self.render not in (None, *RENDERINGS):
            raise FlexhrcError(f"--render must be ascii or dot, got {self.render!r}")
        if not 1 <= self.robots <= 4:
            raise FlexhrcError(f"--robots must be in 1..4, got {self.robots}")
        if self.transport is not None and self.transport not in TRANSPORTS:
            raise FlexhrcError(f"--transport must be inprocess or zenoh, got {self.transport!r}")
        if self.transport is not None and not self.team:
            raise FlexhrcError("--transport needs --robots 2 (or more)")
        if (self.robot is not None or self.peer_port is not None) and self.transport != "zenoh":
            raise FlexhrcError("--robot and --peer-port are for --robots N --transport zenoh")
        if self.robot is not None and self.peer_port is None:
            raise FlexhrcError("--robot needs --peer-port")
        if self.peer_port is not None and not 0 <= self.peer_port <= 65535:
            raise FlexhrcError(f"--peer-port must be in 0..65535, got {self.peer_port}")
        if self.ready_file is not None and self.robot is None:
            raise FlexhrcError("--ready-file is for --robot (the robot that listens)")
        if self.peer_port == 0 and self.robot is not None and self.robot != "robot1":
            raise FlexhrcError(
                "--peer-port 0 is for robot1 (it listens where the system lets it and says where"
                " in --ready-file); the others connect to that port"
            )
        if self.team:
            for flag, team_value in (("--arms", self.arms), ("--render", self.render)):
                if team_value is not None:
                    raise FlexhrcError(
                        f"{flag} does not apply with --robots (each robot has one arm)"
                    )
        if self.render is not None:
            given: dict[str, object] = {"--log": self.log, "--plot": self.plot}
            given.update({"--max-ticks": self.max_ticks, "--realtime": self.realtime})
            for flag, given_value in given.items():
                if given_value is not None:
                    raise FlexhrcError(
                        f"{flag} does not apply with --render (it prints the network and exits)"
                    )

    @property
    def team(self) -> bool:
        """Several robots share the task."""
        return self.robots > 1


@dataclass
class BehaveReport:
    """What a ``flexhrc behave`` command prints: ``data`` is its ``--json`` document,
    :meth:`text` the human-readable report."""

    data: dict[str, Any]
    _text: Callable[[], str] | str = field(default="", repr=False)

    @property
    def exit_code(self) -> int:
        """The command's: 0 when the task was achieved without a constraint violation (or only
        drawn, compiled), else 1."""
        data = self.data
        return 0 if data.get("outcome", "done") == "done" and not data.get("violations") else 1

    @property
    def plot(self) -> str | None:
        """The Gantt chart written, if any."""
        return self.data.get("plot")

    def text(self) -> str:
        return self._text() if callable(self._text) else self._text


# ----------------------------------------------------------------------------- the task


def input_files(*paths: object) -> tuple[str, ...]:
    """Those of ``paths`` that are existing files: an output may not overwrite them."""
    files = []
    for path in paths:
        with suppress(OSError):  # e.g. an inline task longer than a file name may be
            if isinstance(path, str) and path and Path(path).is_file():
                files.append(path)
    return tuple(files)


def is_task_text(target: str) -> bool:
    """Whether :func:`load_target` reads ``target`` (an inline task or a task file) rather than
    taking it for the name of something else."""
    if target.lstrip().startswith("("):
        return True
    path = Path(target)
    try:
        return path.suffix.lower() in TASK_SUFFIXES or path.exists()
    except OSError:
        return False


def load_target(target: str | LoadedTask, arms: int | None = None, seed: int = 0) -> LoadedTask:
    """The task of an inline prefix string or a task file (a :class:`LoadedTask` as it is). A
    task without a world gets :func:`~flexhrc.behavior.world.random_world` with ``seed`` and
    ``arms`` (default 1)."""
    from flexhrc.behavior.taskfile import load_task_document
    from flexhrc.files import read_text

    if isinstance(target, LoadedTask):
        return target
    if target.lstrip().startswith("("):
        task = parse_prefix(target, "<inline task>")
        return LoadedTask("inline task", task, random_world(task.behaviors, seed, arms or 1))
    if not is_task_text(target):
        raise UnknownNameError(
            f"no task file {target!r}: give a task file (.yaml/.txt) or an inline task such as "
            "'(THEN a (AND b c))'"
        )
    text = read_text(target)
    stripped = "\n".join(line.split("#", 1)[0] for line in text.splitlines()).strip()
    if stripped.startswith("("):
        task, world, behaviors = parse_prefix(text, target), None, {}
    else:
        doc = load_task_document(text, target, arms)
        task, world, behaviors = doc.task, doc.world, doc.behaviors
    if world is None:
        world = random_world(task.behaviors, seed, arms or 1)
    return LoadedTask(target, task, world, behaviors)


def import_types(modules: Iterable[str]) -> None:
    """Import the ``--types`` modules (a name, or a path to a ``.py`` file): they register
    behaviour types when imported."""
    import importlib
    import importlib.util

    for name in modules:
        try:
            if name.endswith(".py") or "/" in name:
                path = Path(name)
                if not path.is_file():
                    raise FlexhrcError(f"--types {name}: no such file")
                spec = importlib.util.spec_from_file_location(f"flexhrc_types_{path.stem}", path)
                if spec is None or spec.loader is None:
                    raise FlexhrcError(f"--types {name}: not a Python module")
                module = importlib.util.module_from_spec(spec)
                sys.modules[spec.name] = module
                spec.loader.exec_module(module)
            else:
                importlib.import_module(name)
        except FlexhrcError:
            raise
        except Exception as exc:  # the user's module failed: say which and how
            raise FlexhrcError(f"--types {name}: {type(exc).__name__}: {exc}") from None


def check_plot(path: str | None, inputs: tuple[str, ...] = ()) -> None:
    """Refuse a bad ``--plot`` path, or a missing plotting extra, before the run starts."""
    if path is None:
        return
    from flexhrc.behavior.plot import _pyplot
    from flexhrc.files import check_output

    check_output(path, option="--plot", suffixes=PLOT_SUFFIXES, inputs=inputs)
    _pyplot()  # a missing extra is reported before the run, not after it


# ----------------------------------------------------------------------------- observers


def tick_loop(
    net: BehaviorNetwork,
    max_ticks: int | None = None,
    realtime: float | None = None,
    before_tick: Callable[[], None] | None = None,
) -> None:
    """Tick ``net`` to the end (``max_ticks`` default
    :func:`~flexhrc.behavior.network.default_max_ticks`); with ``realtime`` keep simulated time
    at SPEED x wall time; ``before_tick`` runs before every tick. SIGTERM (in the main thread)
    stops the loop as Ctrl-C does, with :class:`KeyboardInterrupt`, so the caller can write the
    log's last line."""
    from flexhrc.behavior.network import default_max_ticks

    limit = max_ticks if max_ticks is not None else default_max_ticks(net.task)
    try:
        previous = signal.signal(signal.SIGTERM, signal.default_int_handler)
    except ValueError:  # not the main thread (an embedding application): leave it alone
        previous = None
    try:
        start = time.monotonic()
        while not net.finished and net.clock.tick < limit:
            if before_tick is not None:
                before_tick()
            net.tick()
            if realtime is not None:
                delay = start + net.clock.now() / realtime - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def live_trace(net: BehaviorNetwork, on_line: LineSink, prefix: str = "") -> None:
    """Report ``net``'s trace lines and behaviour state changes as they happen (``--realtime``)."""
    behaviors = set(net.task.behaviors)

    def live(ev: Any) -> None:
        line = live_line(ev, behaviors)
        if line:
            on_line(prefix + line)

    net.listeners.append(live)


# ----------------------------------------------------------------------------- words


def trace_line(ev: Any) -> str | None:
    """One line of the run's trace for a start, done, reset, move or choice; else None."""
    d = ev.data
    t = f"{ev.t:7.1f}s"
    if ev.kind == "start":
        return f"{t}  start  {ev.source:<10} on {d['arm']} ({d.get('duration', 0):.1f} s)"
    if ev.kind == "done":
        return f"{t}  done   {ev.source:<10} on {d['arm']}"
    if ev.kind == "reset":
        return (
            f"{t}  RESET  {ev.source:<10} on {d['arm']}: {d.get('reason', '')} "
            f"{d.get('moved', 0):.2f} m, mutex released"
        )
    if ev.kind == "move":
        to = [round(x, 3) for x in d["to"]]
        return f"{t}  move   {d['object']:<10} moved by the experimenter to {to}"
    if ev.kind == "choose":
        return f"{t}  choose {ev.source:<10} activates {d['child']}"
    return None


def live_line(ev: Any, behaviors: set[str]) -> str | None:
    """A trace line, or a state change of a behaviour (``--realtime``)."""
    line = trace_line(ev)
    if (
        line is None
        and ev.kind == "state"
        and ev.source in behaviors
        and ev.data.get("to") in ("active", "inactive")
        and not ev.data.get("reset")
    ):
        line = f"{ev.t:7.1f}s  state  {ev.source:<10} {ev.data.get('frm')} -> {ev.data['to']}"
    return line


def summary_lines(data: Mapping[str, Any]) -> list[str]:
    """The end of a report, from its document (``outcome``, ``time``, ``ticks``, ``order``,
    ``runs``, ``violations``, ``plot``): the same for a live run, a team and a replay."""
    resets = sum(1 for r in data["runs"] if r["outcome"] == "reset")
    lines = [
        f"outcome: {data['outcome']} after {data['time']:.1f} s ({data['ticks']} ticks), "
        f"resets: {resets}",
        f"order: {', '.join(data['order'])}",
    ]
    if data["violations"]:
        lines.append("constraint violations:")
        lines += [f"  - {v}" for v in data["violations"]]
    else:
        lines.append(
            "constraints: respected (THEN order, every AND child, one alternative per OR, "
            "one behaviour per arm)"
        )
    if data.get("plot"):
        lines.append(f"gantt chart: {data['plot']}")
    return lines
