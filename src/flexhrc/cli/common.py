"""Helpers shared by the sub-command modules."""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

from flexhrc.errors import FlexhrcError

#: The largest seed any command accepts (numpy's generators take 0 .. 2**32 - 1).
MAX_SEED = 2**32 - 1


#: ``--on-failure`` of every command that runs a cooperation (``run``, ``demo table``, ``cell``,
#: ``ros2 cell``): the field ``on_failure`` of its config.
ON_FAILURE_OPTION: dict[str, Any] = dict(
    choices=["retry", "paper"],
    default=None,
    help="when a robot action fails or times out: retry its hyper-arc with the other "
    "groundings (retry, default: a passing fault) or mark the hyper-arc infeasible and move to "
    "the next feasible state of least cost (paper, V-A: a lasting fault); default: the "
    "scenario's on_failure, else retry",
)


#: ``--policy`` of every command that runs a cooperation (``run``, ``demo table``, ``cell``,
#: ``ros2 cell``): the field ``policy`` of its config.
POLICY_OPTION: dict[str, Any] = dict(
    choices=["paper", "lookahead"],
    default=None,
    help="how the Task Manager decides: paper (the paper's greedy choice, default) or "
    "lookahead (follow a CP-SAT schedule of the remaining task, re-solved at each decision; "
    "needs the plan extra, docs/planning.md); default: the scenario's policy, else paper",
)


def add_cell_options(
    p: argparse.ArgumentParser,
    *,
    wait_s: float,
    waits_for: str,
    simulator_help: str,
    realtime_type: Callable[[str], float] | None = None,
) -> None:
    """The options every command that runs the cell's loop shares (``flexhrc cell``,
    ``flexhrc ros2 cell``): the store and resume, the pace, the branch simulator, the failure
    policy, how long to wait for the agents."""
    p.add_argument("--store", metavar="FILE.db", help="event store (SQLite) to write")
    p.add_argument("--resume", action="store_true", help="continue the cooperation kept in --store")
    p.add_argument(
        "--realtime",
        type=realtime_type or float_range(0),  # a finite number >= 0
        default=0.0,
        metavar="SPEED",
        help="0 (default): as fast as the agents answer; SPEED > 0: actions take their "
        "simulated time divided by SPEED",
    )
    add_simulator_option(p, simulator_help)
    p.add_argument("--on-failure", **ON_FAILURE_OPTION)
    p.add_argument("--policy", **POLICY_OPTION)
    p.add_argument("--answer-timeout", **ANSWER_TIMEOUT_OPTION)
    p.add_argument(
        "--wait",
        type=float,
        default=wait_s,
        metavar="S",
        help=f"how long to wait for {waits_for} to appear (default {wait_s:g} s)",
    )


def add_transport_options(p: argparse.ArgumentParser, *, default: str = "inprocess") -> None:
    """``--transport`` (unless Zenoh is the only one), ``--listen``, ``--connect``, ``--cell``:
    how a cell (``flexhrc cell``) or an agent process (``flexhrc agent``) reaches the others."""
    from flexhrc.cell.serve import DEFAULT_LISTEN

    if default == "inprocess":
        p.add_argument(
            "--transport",
            choices=["inprocess", "zenoh"],
            default="inprocess",
            help="message transport (default inprocess; zenoh for several processes)",
        )
    p.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help=f"Zenoh endpoint to listen on (repeatable; default {DEFAULT_LISTEN} for the cell, "
        "a random loopback port for an agent)",
    )
    p.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="Zenoh endpoint to connect to (a router or the cell; repeatable)",
    )
    p.add_argument(
        "--cell",
        default="default",
        metavar="NAME",
        help="cell name: keys live under flexhrc/NAME/ (default 'default')",
    )
    p.add_argument(
        "--zenoh-config",
        metavar="FILE",
        help="a Zenoh configuration file (json5, passed to Zenoh as is): TLS certificates, "
        "access control (`flexhrc certs DIR` writes one per agent; docs/cell.md, "
        '"Securing a cell"); --listen/--connect replace its endpoints',
    )


def add_simulator_option(p: argparse.ArgumentParser, help: str) -> None:
    """``--simulator auto|analytic|kinematic`` (default ``auto``: the scenario's choice)."""
    from flexhrc.cell.serve import SIMULATORS

    p.add_argument("--simulator", choices=SIMULATORS, default="auto", help=help)


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json", action="store_true", help="print one machine-readable JSON document on stdout"
    )


def add_segments_option(parser: argparse.ArgumentParser) -> None:
    """``--segments``: the parts of a task split in segments, alike in every command that takes
    a scenario (``flexhrc.scenario.load_scenario(..., segments=...)``)."""
    parser.add_argument(
        "--segments",
        default=None,
        metavar="all|NAME[,NAME]",
        help="parts of a task that comes in segments (default all). table_assembly: tabletop "
        "(both arms place it), legs (the legs fix, paper Figs. 9-12), check (the operator's); "
        "e.g. --segments legs",
    )


def config_of(cls: Any, args: argparse.Namespace, **given: Any) -> Any:
    """The config (a dataclass) the arguments describe: each field not ``given`` is the option of
    the same name, a repeated option's list as a tuple (a config is frozen)."""
    for f in dataclasses.fields(cls):
        if f.name not in given:
            value = getattr(args, f.name)
            given[f.name] = tuple(value) if isinstance(value, list) else value
    return cls(**given)


def emit(args: argparse.Namespace, data: Any, text: Callable[[], str] | str | None = None) -> None:
    """Print ``data`` as JSON when ``--json`` was given, else the human-readable ``text``."""
    if getattr(args, "json", False) or text is None:
        from flexhrc.files import json_default

        json.dump(data, sys.stdout, indent=2, default=json_default)
        sys.stdout.write("\n")
        return
    sys.stdout.write((text() if callable(text) else text).rstrip("\n") + "\n")


def log(args: argparse.Namespace, message: str) -> None:
    """A progress/trace line: stderr under ``--json`` (stdout stays pure JSON), else stdout."""
    stream = sys.stderr if getattr(args, "json", False) else sys.stdout
    print(message, file=stream, flush=True)


def trace_printer(
    args: argparse.Namespace, words: Callable[[dict[str, Any]], str | None]
) -> Callable[[dict[str, Any]], None] | None:
    """The live trace: each event's line (``words``; None: not shown) as :func:`log` prints it;
    None under ``--quiet``."""
    if args.quiet:
        return None

    def trace(ev: dict[str, Any]) -> None:
        line = words(ev)
        if line is not None:
            log(args, line)

    return trace


def progress(message: str) -> None:
    """A progress line ("training ...", "scene 3/10"): always stderr, so stdout holds results."""
    print(message, file=sys.stderr, flush=True)


def int_range(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """An argparse ``type=``: a whole number in ``[lo, hi]`` (argparse names the option)."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if (lo is not None and value < lo) or (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"must be {_bounds(lo, hi)}, got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def float_range(
    lo: float | None = None,
    hi: float | None = None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
) -> Callable[[str], float]:
    """An argparse ``type=``: a finite number in the range (``lo_open``: ``> lo``, not ``>=``).
    NaN and infinities are refused here, so no command sees them."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        bad = not math.isfinite(value)
        if lo is not None:
            bad = bad or (value <= lo if lo_open else value < lo)
        if hi is not None:
            bad = bad or (value >= hi if hi_open else value > hi)
        if bad:
            raise argparse.ArgumentTypeError(
                f"must be a finite number {_bounds(lo, hi, lo_open, hi_open)}, got {text}"
            )
        return value

    parse.__name__ = "number"
    return parse


def _bounds(
    lo: float | None, hi: float | None, lo_open: bool = False, hi_open: bool = False
) -> str:
    def f(v: float) -> str:
        return str(v) if isinstance(v, int) else f"{v:g}"

    if lo is not None and hi is not None:
        return f"in {'(' if lo_open else '['}{f(lo)}, {f(hi)}{')' if hi_open else ']'}"
    if lo is not None:
        return f"{'>' if lo_open else '>='} {f(lo)}"
    if hi is not None:
        return f"{'<' if hi_open else '<='} {f(hi)}"
    return "a number"


seed_type = int_range(0, MAX_SEED)


def add_seed_option(p: argparse.ArgumentParser, help: str = "random seed (default 0)") -> None:
    """``--seed N``, the same range in every command (0..MAX_SEED: what numpy's generators and
    the scenario builders take), so no command accepts a seed another refuses."""
    p.add_argument("--seed", type=seed_type, default=0, metavar="N", help=help)


def needs(args: argparse.Namespace, option: str, given: bool, companion: str, ok: bool) -> None:
    """Refuse ``option`` when its companion is missing (``--folds`` without ``--cv``) rather
    than ignoring it."""
    if given and not ok:
        raise FlexhrcError(f"{option} goes with {companion}; add {companion} or drop {option}")


def check_outputs(
    outputs: Iterable[tuple[str, str | Path | None, Iterable[str] | None]],
    inputs: Iterable[str | Path | None] = (),
) -> None:
    """Check every output of a command before the work: ``(option, path, suffixes)`` triples
    (``path`` None when the option was not given), never an input, never two the same."""
    from flexhrc.files import check_output

    ins = [i for i in inputs if i is not None]
    seen: dict[str, str] = {}
    for option, path, suffixes in outputs:
        if path is None:
            continue
        check_output(path, option=option, suffixes=suffixes, inputs=ins)
        key = str(Path(path).resolve())
        if key in seen:
            raise FlexhrcError(f"{option} {path}: also given to {seen[key]}; use two files")
        seen[key] = option


class TermFlag:
    """SIGTERM ends an agent's or node's loop (so its liveliness token is withdrawn on the way
    out) instead of killing the process: call it to ask whether the signal came."""

    def __init__(self) -> None:
        import signal

        self.requested = False
        signal.signal(signal.SIGTERM, self._handle)

    def _handle(self, signum: int, frame: Any) -> None:
        self.requested = True

    def __call__(self) -> bool:
        return self.requested


_Agent = TypeVar("_Agent")


def serve_agent(
    make: Callable[[], _Agent], transport: Any, say: Callable[[str], None], ready: str
) -> tuple[_Agent, str]:
    """:func:`flexhrc.cell.serve.serve_until_end` until the cell ends or SIGTERM comes
    (outcome ``stopped``)."""
    from flexhrc.cell.serve import serve_until_end

    return serve_until_end(make, transport, say=say, ready=ready, until=TermFlag())


def quiet_library_logs() -> None:
    """The command's trace already shows every dropped message: keep the library's warnings
    (flexhrc.cell, flexhrc.transport) from printing them a second time."""
    import logging

    for name in ("flexhrc.cell", "flexhrc.transport"):
        logging.getLogger(name).addHandler(logging.NullHandler())


#: ``--answer-timeout`` of every command that runs a cooperation: the field ``answer_timeout``
#: of its config (issue 22: a request unanswered for S seconds counts as declined).
ANSWER_TIMEOUT_OPTION: dict[str, Any] = dict(
    type=float_range(0.0, 1e6, lo_open=True),
    default=None,
    metavar="S",
    help="a request the person leaves unanswered for S seconds (no report, no start, no "
    "reply) counts as declined: the step goes back to the pool; default: the scenario's "
    "answer_timeout, else the manager waits",
)
