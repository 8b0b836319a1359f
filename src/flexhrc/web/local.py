"""``flexhrc panel``: a cooperation in this process, the person at the browser panel.

The panel runs the one loop, :class:`flexhrc.cell.Cell`, in one configuration: the in-process
bus (:class:`~flexhrc.transport.InProcessBus`), a simulated arm
(:class:`~flexhrc.cell.RobotAgent`) for each robot agent of the scenario, and — instead of a
simulated operator — the person at the page, through :class:`~flexhrc.web.live.CellPanel`. The
clock is the wall clock: ``speed`` simulated seconds per second, for the cell and for the arms,
which answer a command once its simulated duration has passed; the cell handles the answers as
they come, as a real cell does, so the arms go on while the operator is asked.

* :class:`PanelConfig` — what to run and where to serve it;
* :class:`LocalPanel` — that cell, its arms and its panel, the cell's loop on a thread of its own
  (a :class:`~flexhrc.web.backend.PanelBackend` itself, by delegation to the
  :class:`~flexhrc.web.live.CellPanel`);
* :func:`serve_panel` — a config in, a running :class:`LocalPanel` serving the page out;
  :meth:`LocalPanel.report` is the end's report (``flexhrc panel`` translates its arguments into
  a config and prints the report, nothing more).

Every input of the person is a stored input of the cell (``human_action``, ``human_take``,
``agent_down``/``agent_up`` with ``"by": "operator"``), so ``store=`` gives a file
``flexhrc replay`` reads like any cell's.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Mapping
from concurrent.futures import Future
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from flexhrc.errors import FlexhrcError
from flexhrc.web.live import CellPanel, drained
from flexhrc.web.server import DEFAULT_HOST, DEFAULT_PORT, PanelServer, check_bind
from flexhrc.web.snapshot import TIMELINE_LIMIT

T = TypeVar("T")

SIMULATORS = ("auto", "analytic", "kinematic")
CALL_TIMEOUT_S = 10.0  # a call waits this long for the cell's loop to run it


def check_speed(speed: float, option: str = "speed") -> float:
    """``speed`` as a finite positive float, or one :class:`FlexhrcError` naming ``option``."""
    if not (speed > 0 and speed < float("inf")):
        raise FlexhrcError(f"{option} must be a positive number, got {speed}")
    return float(speed)


@dataclass(frozen=True)
class PanelConfig:
    """What :func:`serve_panel` runs and where it serves it.

    ``scenario`` is a name or a file, as ``flexhrc run`` and ``flexhrc cell`` take it
    (:func:`flexhrc.scenario.load_scenario`), or a scenario already loaded. ``speed`` is simulated
    seconds per wall second; ``simulator`` the branch simulator and the arms' simulated world
    (``auto``: the scenario's choice). ``port`` 0 takes any free port (the server binds it and
    :attr:`LocalPanel.url` says which). An address other than loopback needs ``token``.
    ``store`` keeps every event in a SQLite file (``flexhrc replay FILE.db``). ``segments``
    selects parts of a task that comes in segments, as ``--segments`` in every command.
    """

    scenario: str | Path | Any = "table_assembly"
    seed: int = 0
    segments: str | None = None
    speed: float = 1.0
    simulator: str = "auto"
    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT
    token: str | None = None
    store: str | Path | None = None
    name: str = "panel"


@dataclass
class PanelReport:
    """How the cooperation ended: ``outcome`` (``running`` if it had not), ``reason``, the
    number of stored ``events``, the page's ``url`` and the cell's ``summary`` (the keys of
    ``flexhrc cell --json``; empty if it had not ended)."""

    outcome: str
    reason: str | None
    events: int
    url: str | None = None
    summary: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """``flexhrc panel --json``: the cell's summary with ``outcome``, ``reason``,
        ``events`` (stored) and ``url``."""
        return {
            **self.summary,
            "outcome": self.outcome,
            "reason": self.reason,
            "events": self.events,
            "url": self.url,
        }


class LocalPanel:
    """A :class:`~flexhrc.cell.Cell` in this process with simulated arms on the wall clock and
    the person at the panel as its only operator (see the module docstring).

    :meth:`start` runs the cell's loop on a thread; :meth:`wait` blocks until the cooperation
    ends; :meth:`close` stops the loop (at any time). The five methods of the
    :class:`~flexhrc.web.backend.PanelBackend` go to :attr:`backend`, the
    :class:`~flexhrc.web.live.CellPanel` the loop polls, so this object can be served as it is.
    """

    def __init__(
        self,
        scenario: str | Path | Any = "table_assembly",
        *,
        seed: int = 0,
        speed: float = 1.0,
        simulator: str = "auto",
        store: str | Path | None = None,
        name: str = "panel",
        trace: Callable[[dict[str, Any]], None] | None = None,
        segments: str | None = None,
    ) -> None:
        from flexhrc.cell import Cell, EventStore, RobotAgent
        from flexhrc.cell.components import execution_model
        from flexhrc.scenario import load_scenario
        from flexhrc.transport import InProcessBus

        self.speed = check_speed(speed)
        if simulator not in SIMULATORS:
            raise FlexhrcError(f"simulator {simulator!r}: choose one of {', '.join(SIMULATORS)}")
        if isinstance(scenario, str | Path):
            scenario = load_scenario(str(scenario), seed=seed, segments=segments)
        self.scenario = scenario
        self.store = EventStore(store) if store is not None else None
        self.bus = InProcessBus()
        # the scenario's model of the world: the manager simulates branches on it (as `flexhrc
        # cell --simulator` does), the arms execute on it
        branches: Any = execution_model(simulator, scenario)
        self.cell = Cell(
            scenario,
            self.bus,
            store=self.store,
            realtime=self.speed,
            ordered=False,  # the wall clock: answers are handled as they come
            agent_speed=self.speed,  # the arms take the simulated time, paced
            simulator=branches,
            liveliness=False,  # every agent is in this process
            publish_state=False,  # the page gets the state from the panel, not from the bus
            name=name,
            trace=trace,
            seed=seed,
        )
        self.arms = [
            RobotAgent(a.name, scenario, self.bus, execution=execution_model(simulator, scenario))
            for a in scenario.domain.agents.values()
            if not a.is_human
        ]
        self._wake = threading.Event()
        self.backend = CellPanel(self.cell, on_input=self._wake.set)
        self.server: PanelServer | None = None
        self._calls: queue.SimpleQueue[tuple[Callable[[], Any], Future[Any]]] = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._closing = False
        self._ended = threading.Event()  # the cell's run returned (or raised)
        self._error: BaseException | None = None
        self._summary: dict[str, Any] = {}

    # -- the backend contract (any thread) ------------------------------------------------------
    def snapshot(self) -> dict[str, Any]:
        return self.backend.snapshot()

    def subscribe(self, callback: Callable[[], None]) -> Callable[[], None]:
        return self.backend.subscribe(callback)

    def submit(self, body: Mapping[str, str]) -> dict[str, Any]:
        return self.backend.submit(body)

    def what_if(self, body: Mapping[str, str]) -> dict[str, Any]:
        return self.backend.what_if(body)

    def stop_robot(self, name: str) -> dict[str, Any]:
        return self.backend.stop_robot(name)

    def resume_robot(self, name: str) -> dict[str, Any]:
        return self.backend.resume_robot(name)

    # -- life cycle -----------------------------------------------------------------------------
    @property
    def url(self) -> str | None:
        """The page's address when served (:func:`serve_panel`), with the real port."""
        return self.server.url if self.server is not None else None

    @property
    def done(self) -> bool:
        return bool(self.cell.tm.done)

    def start(self) -> LocalPanel:
        """Start the cooperation: the cell's loop on a thread of its own."""
        if self._thread is None:
            self._thread = threading.Thread(
                target=self._main, name="flexhrc-panel-cell", daemon=True
            )
            self._thread.start()
        return self

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the cooperation ends (at most ``timeout`` seconds); True if it ended.
        An error of the cell's loop is raised here."""
        ended = self._ended.wait(timeout)
        if self._error is not None:
            raise self._error
        return ended and self.done

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn()`` on the cell's thread (the cell is single-threaded) and return its
        result; before :meth:`start`, at once."""
        if self._thread is None or not self._thread.is_alive():
            return fn()
        answer: Future[T] = Future()
        self._calls.put((fn, answer))
        self._wake.set()
        return answer.result(timeout=CALL_TIMEOUT_S)

    def set_speed(self, speed: float) -> None:
        """Change the pace from now on (the arms take it with their next command)."""
        speed = check_speed(speed)

        def apply() -> None:
            self.speed = speed
            self.cell.set_realtime(speed, agent_speed=speed)

        self.call(apply)

    def report(self) -> PanelReport:
        snap = self.backend.snapshot()
        return PanelReport(
            outcome=str(self.cell.tm.outcome),
            reason=self.cell.tm.reason,
            events=int(snap["events"]),
            url=self.url,
            summary=dict(self._summary),
        )

    def close(self) -> None:
        """End the cooperation if it still runs (outcome ``interrupted``, stored), answer what
        the page still waits for, stop serving, close the store."""
        ended = self.done
        self.cell.request_stop("the panel was closed")
        self._closing = True
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
        if self.server is not None:
            self.server.stop(grace=0.3 if ended else 0.0)  # the page gets the end first
        self.backend.close()
        for arm in self.arms:
            arm.close()
        self.cell.close()
        if self.store is not None:
            self.store.close()
        self.bus.close()

    def __enter__(self) -> LocalPanel:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- on the cell's thread -------------------------------------------------------------------
    def _main(self) -> None:
        try:
            self._summary = self.cell.run(pump=self._pump, max_wall_s=float("inf"))
        except BaseException as exc:  # surfaced by wait(); the page keeps the last state
            self._error = exc
        finally:
            self._ended.set()
        # the end stays visible and inputs get their answer ("the cooperation has ended")
        while not self._closing:
            self._wake.clear()
            self._serve_calls()
            self.backend.poll()
            self._wake.wait(0.5)
        self._serve_calls()

    def _serve_calls(self) -> None:
        for fn, answer in drained(self._calls):
            try:
                answer.set_result(fn())
            except Exception as exc:
                answer.set_exception(exc)

    def _pump(self, timeout: float) -> None:
        """Deliver the bus, let the arms finish what is due, carry out the page's inputs; with
        nothing to do, sleep until the next arm is due or an input comes (at most
        ``timeout``)."""
        self._wake.clear()
        self._serve_calls()
        delivered = self.bus.flush()
        for arm in self.arms:
            arm.poll()
        self.backend.poll()
        if delivered or self.bus.pending():
            return
        due = [d for d in (arm.next_due() for arm in self.arms) if d is not None]
        wait = min([timeout, *(max(0.0, d - time.monotonic()) for d in due)])
        if wait > 0:
            self._wake.wait(wait)


def serve_panel(config: PanelConfig) -> LocalPanel:
    """Load the scenario, serve the panel and start the cooperation: ``flexhrc panel`` as a
    function. The address is checked before any work (an address other than loopback needs a
    token); the returned :class:`LocalPanel` is running — :meth:`LocalPanel.wait` for the end,
    :meth:`LocalPanel.report`, then :meth:`LocalPanel.close`."""
    check_bind(config.host, config.token)
    panel = LocalPanel(
        config.scenario,
        seed=config.seed,
        speed=config.speed,
        simulator=config.simulator,
        store=config.store,
        name=config.name,
        segments=config.segments,
    )
    try:
        panel.server = PanelServer(panel, config.host, config.port, token=config.token).start()
    except BaseException:
        panel.close()
        raise
    return panel.start()


def table_legs(
    legs: int = 4,
    *,
    unreachable_bolts: tuple[int, ...] = (),
    seed: int = 0,
    human: bool = True,
    segments: str | None = None,
) -> Any:
    """The legs fix of the table (paper 000, VI-D, Figs. 9-12) — the task the older file
    ``scenario: table_assembly`` with ``legs`` and ``unreachable_bolts`` names in every command.
    No arm reaches a bolt in ``unreachable_bolts``: the robot asks the operator (Fig. 12).
    ``segments`` (default ``legs``) as :func:`flexhrc.scenario.builtin.table_assembly`."""
    from flexhrc.scenario.builtin.table import ScenarioError, table_assembly

    if legs < 1:
        raise FlexhrcError(f"--legs must be at least 1, got {legs}")
    for bolt in unreachable_bolts:
        if not 1 <= bolt <= legs:
            raise FlexhrcError(f"--unreachable-bolt {bolt}: choose a bolt 1..{legs}")
    try:
        return table_assembly(
            legs,
            seed=seed,
            unreachable_bolts=tuple(unreachable_bolts),
            human=human,
            segments=segments or "legs",
        )
    except ScenarioError as exc:
        raise FlexhrcError(f"--{exc.key.replace('_', '-')} {exc.detail}") from None


__all__ = [
    "SIMULATORS",
    "TIMELINE_LIMIT",
    "LocalPanel",
    "PanelConfig",
    "PanelReport",
    "serve_panel",
    "table_legs",
]
