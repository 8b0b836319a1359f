"""The panel's backend contract and the validation of what a browser sends.

The web app (:mod:`flexhrc.web.app`) knows nothing about Task Managers, transports or stores: it
talks to a :class:`PanelBackend`, a contract of five methods written down here (the same shape
as :mod:`flexhrc.transport.base`: small). Its implementation is
:class:`flexhrc.web.live.CellPanel` over the cell's loop, whether the cell runs in this process
(``flexhrc panel``, :mod:`flexhrc.web.local`) or drives agent processes (``flexhrc cell --web``).

* :meth:`PanelBackend.snapshot` — a JSON-able dict of the whole state the page shows (keys in
  ``docs/panel.md``; ``outcome``, ``suggestions``, ``agents`` and ``events`` at least);
* :meth:`PanelBackend.subscribe` — ``callback()`` is called, from any thread, after each change;
  it must return at once (the app only sets a flag and takes a snapshot on its own loop);
* :meth:`PanelBackend.submit` — one validated human input, ``{"action": "<ground action>"}`` (the
  person did it), ``{"take": "<hyper-arc>"}`` (the person will do it) or ``{"reply":
  "decline"|"cannot"|"start"|"give_back"}`` (with ``"reason"`` for ``cannot``: the person's
  answer to their open request, ``docs/protocol.md`` "Operator answers"); raises
  :class:`PanelInputError` and changes nothing when the input is unknown or not possible now;
* :meth:`PanelBackend.stop_robot` / :meth:`PanelBackend.resume_robot` — the operator's stop.

Security lives at this boundary: bodies are parsed with a size limit and a fixed grammar
(:func:`parse_human_body`), names are checked against the task by the backend, and nothing
sent is ever evaluated or executed — a ground action is only compared with the actions the Task
Manager itself can offer.
"""

from __future__ import annotations

import ipaddress
import json
import math
import re
from collections.abc import Callable, Mapping
from typing import Any, Protocol, runtime_checkable

from flexhrc.errors import FlexhrcError
from flexhrc.events import REPLIES

#: largest request body accepted, in bytes (a ground action is a few dozen)
MAX_BODY_BYTES = 4096
#: longest name or ground action accepted
MAX_NAME_CHARS = 200

_NAME = r"[A-Za-z_][A-Za-z0-9_.\-]*"
_NAME_RE = re.compile(rf"^{_NAME}$")
# a qualified element name: graph-instance path segments joined by "/"
_ELEMENT_RE = re.compile(rf"^{_NAME}(?:/{_NAME})*$")
_ACTION_RE = re.compile(rf"^\s*({_NAME})\s*\(\s*((?:{_NAME}\s*(?:,\s*{_NAME}\s*)*)?)\)\s*$")


def is_loopback(host: str) -> bool:
    """A name or address of this machine only (all of 127.0.0.0/8 is loopback, T15): what the
    panel without a token may listen on and answer."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class PanelInputError(FlexhrcError):
    """A panel request that is malformed (400), names something unknown (404) or is not
    possible in the current state (409). Nothing was changed."""

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


@runtime_checkable
class PanelBackend(Protocol):
    """What the panel needs from a running cooperation (see the module docstring)."""

    def snapshot(self) -> dict[str, Any]: ...

    def subscribe(self, callback: Callable[[], None]) -> Callable[[], None]:
        """Call ``callback()`` after every change; returns a function that unsubscribes."""
        ...

    def submit(self, body: Mapping[str, str]) -> dict[str, Any]: ...

    def stop_robot(self, name: str) -> dict[str, Any]: ...

    def resume_robot(self, name: str) -> dict[str, Any]: ...


def parse_action(text: str) -> tuple[str, tuple[str, ...]]:
    """``"pick_up(human, leg2)"`` -> ``("pick_up", ("human", "leg2"))``; names only, no
    expressions: anything else is a :class:`PanelInputError`."""
    m = _ACTION_RE.match(text)
    if m is None:
        raise PanelInputError(
            f"'action' must read name(arg, ...) with plain names, got {_clip(text)!r}"
        )
    args = tuple(a.strip() for a in m.group(2).split(",")) if m.group(2).strip() else ()
    return m.group(1), args


def _json_body(raw: bytes) -> dict[str, Any]:
    if len(raw) > MAX_BODY_BYTES:
        raise PanelInputError(
            f"request body too large ({len(raw)} bytes; at most {MAX_BODY_BYTES})", 413
        )
    if not raw.strip():
        raise PanelInputError("empty request body; send a JSON object")
    try:
        data = json.loads(raw.decode("utf-8"), parse_constant=_no_constant)
    except UnicodeDecodeError:
        raise PanelInputError("request body is not UTF-8") from None
    except (ValueError, RecursionError) as exc:
        raise PanelInputError(f"request body is not JSON: {exc}") from None
    if not isinstance(data, dict):
        raise PanelInputError(f"request body must be a JSON object, got {type(data).__name__}")
    return data


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not allowed")


def _string(data: Mapping[str, Any], key: str) -> str:
    value = data[key]
    if not isinstance(value, str):
        raise PanelInputError(f"'{key}' must be a string, got {type(value).__name__}")
    if not value.strip():
        raise PanelInputError(f"'{key}' is empty")
    if len(value) > MAX_NAME_CHARS:
        raise PanelInputError(f"'{key}' is longer than {MAX_NAME_CHARS} characters")
    return value.strip()


def parse_human_body(raw: bytes) -> dict[str, str]:
    """Validate a ``POST /api/human`` body: exactly one of ``action`` (a ground action),
    ``take`` (a hyper-arc name) or ``reply`` (one of :data:`~flexhrc.events.REPLIES`, with an
    optional ``reason``), strings in the grammar of names. Returns it normalised."""
    data = _json_body(raw)
    keys = set(data)
    allowed = {"action", "take", "reply", "reason"}
    if keys - allowed:
        raise PanelInputError(
            f"unknown key(s) {', '.join(sorted(map(repr, keys - allowed)))}; send "
            '{"action": "<ground action>"}, {"take": "<hyper-arc>"} or {"reply": "decline"}'
        )
    if "reply" in data and keys <= {"reply", "reason"}:
        reply = _string(data, "reply")
        if reply not in REPLIES:
            raise PanelInputError(
                f"'reply' must be one of {', '.join(REPLIES)}, got {_clip(reply)!r}"
            )
        if "reason" in data:
            return {"reply": reply, "reason": _clip(_string(data, "reason"), MAX_NAME_CHARS)}
        return {"reply": reply}
    if len(keys) != 1 or "reason" in keys:
        raise PanelInputError(
            'send exactly one of {"action": ...}, {"take": ...} or {"reply": ...}'
        )
    if "action" in data:
        text = _string(data, "action")
        name, args = parse_action(text)
        return {"action": f"{name}({', '.join(args)})"}
    text = _string(data, "take")
    if not _ELEMENT_RE.match(text):
        raise PanelInputError(f"'take' must be a hyper-arc name, got {_clip(text)!r}")
    return {"take": text}


def parse_what_if_body(raw: bytes) -> dict[str, str]:
    """Validate a ``POST /api/whatif`` body: exactly one of ``action`` (the step the person
    would do) or ``take`` (a part they would take), as in ``POST /api/human``."""
    body = parse_human_body(raw)
    if "reply" in body:
        raise PanelInputError('a what-if asks about a step: send {"action": ...} or {"take": ...}')
    return body


def parse_robot_body(raw: bytes) -> str:
    """Validate a ``POST /api/stop`` or ``/api/resume`` body ``{"robot": "<agent>"}``."""
    data = _json_body(raw)
    if set(data) != {"robot"}:
        raise PanelInputError('send {"robot": "<robot agent name>"}')
    name = _string(data, "robot")
    if not _NAME_RE.match(name):
        raise PanelInputError(f"'robot' must be an agent name, got {_clip(name)!r}")
    return name


def _clip(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[: n - 1] + "…"


def json_safe(value: Any) -> Any:
    """Replace non-finite floats (costs of blocked elements) by None so the JSON is standard."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    return value


__all__ = [
    "MAX_BODY_BYTES",
    "MAX_NAME_CHARS",
    "PanelBackend",
    "PanelInputError",
    "is_loopback",
    "json_safe",
    "parse_action",
    "parse_human_body",
    "parse_robot_body",
]
