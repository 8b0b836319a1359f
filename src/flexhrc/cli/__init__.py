"""The ``flexhrc`` command line.

Each part of flexhrc contributes its own sub-commands from a module of this package exposing
``register(subparsers)``; the parser is assembled lazily so ``flexhrc --help`` stays fast and an
optional extra that is not installed only disables its own commands.

Conventions shared by every command (see :mod:`flexhrc.cli.common`):

* ``--json`` prints one machine-readable JSON document on stdout and nothing else there;
* bad input (a :class:`~flexhrc.errors.FlexhrcError`) prints ``error: <file>:<line>: <message>``
  on stderr and exits with code 2 — never a traceback;
* progress goes to stderr; live traces too when ``--json`` is given;
* numeric options are checked where they are parsed (:func:`~flexhrc.cli.common.int_range`,
  :func:`~flexhrc.cli.common.float_range`: NaN, infinities, negative and absurdly large
  values are refused, naming the option), options given without their companion flag are
  refused (:func:`~flexhrc.cli.common.needs`), and every output path is checked before the
  work starts (:func:`~flexhrc.cli.common.check_outputs`) and written atomically.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import NoReturn

from flexhrc import __version__
from flexhrc.errors import FlexhrcError

# Module names under flexhrc.cli that register sub-commands, in help order.
COMMAND_MODULES: tuple[str, ...] = (
    "graph",
    "demo",
    "plan",
    "scenario",
    "behave",
    "sim",
    "har",
    "scene",
    "cell",
    "learn",
    "experiment",
    "agent",
    "certs",
    "panel",
    "ros2",
)


class _Parser(argparse.ArgumentParser):
    """argparse, with its errors as one ``error:`` line like every other flexhrc error (the
    usage is a ``--help`` away). Sub-command parsers inherit the class."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"error: {self.prog}: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="flexhrc",
        description="Flexible human-robot collaboration: AND/OR graphs, task manager, "
        "perception, control and behaviour networks.",
    )
    parser.add_argument("--version", action="version", version=f"flexhrc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(f"flexhrc.cli.{name}")
        except ModuleNotFoundError as exc:  # a part not built yet, or an extra missing
            if exc.name and exc.name.startswith(f"flexhrc.cli.{name}"):
                continue
            raise
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(list(argv) if argv is not None else None)
    except SystemExit as exc:  # argparse has printed usage and "error: argument --x: ..."
        return exc.code if isinstance(exc.code, int) else 2
    func = getattr(args, "func", None)
    if func is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(func(args) or 0)
    except FlexhrcError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. `flexhrc ... | head`
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
