"""Reading inputs and writing outputs the way every flexhrc command does.

One place for the rules a user relies on:

* an input that cannot be used (missing, a folder, unreadable, binary, not UTF-8) is one
  :class:`~flexhrc.errors.FormatError` naming the file — never a traceback;
* an output path is checked *before* the work starts (:func:`check_output`), so a long run is
  never lost to a typo in ``-o``; it is never one of the inputs, never a device or a folder, and
  no folder is created that the user did not ask for;
* a finished output is written atomically (:func:`atomic_output`): a temporary file beside the
  target, then ``os.replace``, so a reader sees the old file or the new one, never half of one;
* a log is streamed (:class:`EventLogWriter`): appended and flushed event by event under an
  exclusive lock, so a run killed with SIGKILL leaves every event it wrote, and a second run on
  the same path is refused while the first holds it.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import IO, Any

from flexhrc.errors import FlexhrcError, FormatError

__all__ = [
    "EventLogWriter",
    "OutputPathError",
    "atomic_output",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_output",
    "read_bytes",
    "read_text",
]


class OutputPathError(FlexhrcError):
    """An output path that cannot be written; the message names the option and the path."""


def read_bytes(path: str | Path) -> bytes:
    """The bytes of an input file, or one :class:`FormatError` saying why it cannot be read."""
    p = Path(path)
    try:
        return p.read_bytes()
    except FileNotFoundError:
        raise FormatError("no such file", p) from None
    except IsADirectoryError:
        raise FormatError("is a folder, not a file", p) from None
    except PermissionError:
        raise FormatError("cannot read: permission denied", p) from None
    except OSError as exc:
        raise FormatError(f"cannot read: {exc.strerror or exc}", p) from None


def read_text(path: str | Path) -> str:
    """The text of a UTF-8 input file (a leading byte-order mark dropped).

    Binary data (a NUL byte) and bytes that are not UTF-8 are reported as such, with the offset
    of the first bad byte — the content itself is never quoted, since it may not be ours to show.
    """
    p = Path(path)
    data = read_bytes(p)
    if b"\x00" in data:
        raise FormatError("not a text file (binary data)", p)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise FormatError(f"not UTF-8 text (byte 0x{data[exc.start]:02x})", p, line) from None
    return text.removeprefix("\ufeff")


def check_output(
    path: str | Path,
    *,
    option: str,
    suffixes: Iterable[str] | None = None,
    inputs: Iterable[str | Path] = (),
) -> Path:
    """Check that ``path`` can be written, before any work is done, and return it.

    ``option`` names the command-line option (``--log``, ``-o`` ...) in the error message;
    ``suffixes`` (``{".png", ".svg"}``) are the allowed extensions; ``inputs`` are files the
    command reads, which an output must never overwrite. Nothing is created here.
    """
    p = Path(path)
    where = f"{option} {p}"
    if str(path) == "":
        raise OutputPathError(f"{option}: empty path")
    if suffixes is not None:
        allowed = sorted({s.lower() for s in suffixes})
        if p.suffix.lower() not in allowed:
            raise OutputPathError(
                f"{where}: unsupported output format {p.suffix or '(none)'!r}; "
                f"use one of {', '.join(allowed)}"
            )
    try:
        st = p.stat()
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise OutputPathError(f"{where}: cannot write: {exc.strerror or exc}") from None
    if st is not None:
        if stat.S_ISDIR(st.st_mode):
            raise OutputPathError(f"{where}: is a folder; give a file name")
        if not stat.S_ISREG(st.st_mode):
            raise OutputPathError(f"{where}: not a regular file")
        for other in inputs:
            with contextlib.suppress(OSError):
                if os.path.samefile(p, other):
                    raise OutputPathError(
                        f"{where}: is an input of this command; refusing to overwrite it"
                    )
    parent = p.parent  # "." for a bare file name
    if not parent.exists():
        raise OutputPathError(f"{where}: folder {parent} does not exist")
    if not parent.is_dir():
        raise OutputPathError(f"{where}: {parent} is not a folder")
    # os.access is wrong for root (it ignores permission bits it would bypass anyway, but also
    # read-only mounts); creating and removing a probe file is the honest test.
    try:
        fd, probe = tempfile.mkstemp(prefix=".flexhrc-probe-", dir=parent)
    except OSError as exc:
        raise OutputPathError(f"{where}: cannot write in {parent}: {exc.strerror or exc}") from None
    os.close(fd)
    os.unlink(probe)
    if st is not None and not os.access(p, os.W_OK):
        raise OutputPathError(f"{where}: cannot write: permission denied")
    return p


@contextlib.contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same suffix); on success it replaces ``path``.

    For writers that want a file name (``savefig``, ``np.savez``, graphviz). On an exception the
    temporary file is removed and ``path`` is left as it was.
    """
    p = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=p.suffix, dir=p.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        try:
            mode = p.stat().st_mode & 0o777
        except FileNotFoundError:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o666 & ~umask
        os.chmod(tmp_path, mode)
        os.replace(tmp_path, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temporary file + rename)."""
    try:
        with atomic_output(path) as tmp, open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write: {exc.strerror or exc}") from None


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically (temporary file + rename)."""
    atomic_write_bytes(path, text.encode("utf-8"))


class EventLogWriter:
    """A JSON-lines log written event by event.

    The file is locked (``flock``, exclusive) for as long as the writer is open: a second writer
    on the same path gets :class:`OutputPathError` at once instead of silently overwriting the
    first run's log. Every :meth:`write` appends one line and flushes it to the operating system,
    so a process killed with SIGKILL leaves a log that is readable up to its last event.

    Use as a context manager, or call :meth:`close`.
    """

    def __init__(self, path: str | Path, *, option: str = "--log", append: bool = False):
        self.path = Path(path)
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT, 0o666)
        except OSError as exc:
            raise OutputPathError(
                f"{option} {self.path}: cannot write: {exc.strerror or exc}"
            ) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise OutputPathError(
                f"{option} {self.path}: in use by another flexhrc run (the file is locked); "
                "wait for it or choose another path"
            ) from None
        if append:
            os.lseek(fd, 0, os.SEEK_END)
        else:
            os.ftruncate(fd, 0)
        self._fh: IO[str] | None = os.fdopen(fd, "w", encoding="utf-8")
        self.events = 0

    def write(self, event: dict[str, Any]) -> None:
        """Append one event (a JSON object) and flush it."""
        if self._fh is None:
            raise FlexhrcError(f"{self.path}: log already closed")
        line = json.dumps(event, allow_nan=False, default=json_default)
        try:
            self._fh.write(line + "\n")
            self._fh.flush()
        except OSError as exc:
            raise OutputPathError(f"{self.path}: cannot write: {exc.strerror or exc}") from None
        self.events += 1

    def close(self) -> None:
        if self._fh is not None:
            try:
                self._fh.flush()
                os.fsync(self._fh.fileno())
            except OSError:
                pass
            finally:
                self._fh.close()  # closing the descriptor releases the lock
                self._fh = None

    @property
    def closed(self) -> bool:
        return self._fh is None

    def __enter__(self) -> EventLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def json_default(obj: Any) -> Any:
    """``json.dump(..., default=json_default)``: what flexhrc writes as JSON beyond the plain
    types (``to_dict()``, paths, sets, numpy scalars and arrays)."""
    if hasattr(obj, "to_dict"):
        return obj.to_dict()
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, set | frozenset):
        return sorted(obj)
    tolist = getattr(obj, "tolist", None)  # numpy scalars and arrays, without importing numpy
    if callable(tolist):
        return tolist()
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
