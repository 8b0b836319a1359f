"""Exception hierarchy shared by every part of flexhrc.

Every error a user can cause (a malformed file, an unknown name, an impossible request) is a
:class:`FlexhrcError`. The command line turns it into one readable line and exit code 2, so no
user ever sees a traceback for bad input. Errors about files carry the file and line.
"""

from __future__ import annotations

from pathlib import Path


class FlexhrcError(Exception):
    """Base class of every error flexhrc raises on purpose."""


class FormatError(FlexhrcError, ValueError):
    """A file (or string) could not be read: names the source and, when known, the line.

    ``str(err)`` reads ``file:line: message`` like a compiler diagnostic.
    """

    def __init__(self, message: str, source: str | Path | None = None, line: int | None = None):
        self.message = message
        self.source = str(source) if source is not None else None
        self.line = line
        super().__init__(self._render())

    def _render(self) -> str:
        where = self.source or "<input>"
        if self.line is not None:
            where = f"{where}:{self.line}"
        return f"{where}: {self.message}"


class UnknownNameError(FlexhrcError, KeyError):
    """A name (node, hyper-arc, scenario, behaviour, agent...) that does not exist."""

    def __str__(self) -> str:  # KeyError quotes its argument; we want the plain sentence.
        return str(self.args[0]) if self.args else "unknown name"


class OptionalDependencyError(FlexhrcError, ImportError):
    """A feature needs an optional extra that is not installed."""

    def __init__(self, feature: str, extra: str, module: str):
        super().__init__(
            f"{feature} needs the optional dependency '{module}'; "
            f"install it with: pip install 'flexhrc[{extra}]'"
        )
