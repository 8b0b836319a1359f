"""The cell protocol (``docs/protocol.md``): key expressions and JSON messages, version 1.

Every key lives under ``flexhrc/<cell>/`` (the transport's prefix). Topics, relative to it:

==================  ==================  ====================================================
topic               from -> to          message ``type``
==================  ==================  ====================================================
``cmd/<agent>``     manager -> robot    ``command``, ``stop``
``ack``             robot -> manager    ``ack``
``suggest/<name>``  manager -> human    ``suggestion``
``human``           human -> manager    ``human_action``, ``answer`` (to a repair question)
``options/<name>``  manager -> human    ``options`` (what an operator may do on its own)
``intent``          human -> manager    ``operator`` (its profile), ``intent`` (its answer)
``percept``         perception -> mgr   ``percept``, ``looked`` (a watcher has looked)
``state``           manager -> all      ``state`` (the cell snapshot), ``end``
``alive/<agent>``   liveliness tokens   (``alive/manager`` for the manager)
==================  ==================  ====================================================

Every message is a JSON object with ``"v": 1`` and ``"type"``. :func:`parse` checks one against
its schema and raises :class:`ProtocolError` (a one-line reason) for anything malformed; the
receiver logs it and drops it, never stops.
"""

from __future__ import annotations

import math
from typing import Any

from flexhrc.errors import FlexhrcError

VERSION = 1
MANAGER = "manager"


class ProtocolError(FlexhrcError):
    """A message that does not follow the protocol (dropped by the receiver)."""


def cmd_topic(agent: str) -> str:
    return f"cmd/{agent}"


def suggest_topic(human: str) -> str:
    return f"suggest/{human}"


def options_topic(human: str) -> str:
    return f"options/{human}"


ACK_TOPIC = "ack"
HUMAN_TOPIC = "human"
PERCEPT_TOPIC = "percept"
INTENT_TOPIC = "intent"
STATE_TOPIC = "state"
ALIVE_PREFIX = "alive"


def alive_key(agent: str) -> str:
    return f"{ALIVE_PREFIX}/{agent}"


# field -> (types, required); numbers must be finite
_NUM = (int, float)
SCHEMAS: dict[str, dict[str, tuple[tuple[type, ...], bool]]] = {
    "command": {
        "id": ((int,), True),
        "agents": ((list,), True),
        "action": ((str,), True),
        "element": ((str, type(None)), False),
        "t": (_NUM, True),
        "expected_s": (_NUM, False),
        "world": ((dict,), False),
        "realtime": (_NUM, False),
        "process": ((bool,), False),
    },
    "stop": {"id": ((int,), True), "reason": ((str, type(None)), False), "t": (_NUM, False)},
    "ack": {
        "id": ((int,), True),
        "agent": ((str,), True),
        "status": ((str,), True),
        "reason": ((str, type(None)), False),
        "t": (_NUM, True),
        "duration": (_NUM, False),
        "positions": ((dict,), False),
    },
    "suggestion": {
        "id": ((str,), True),
        "element": ((str,), True),
        "actions": ((list,), True),
        "cost": (_NUM, False),
        "t": (_NUM, True),
        "world": ((dict,), False),
        "realtime": (_NUM, False),
        "step": ((int,), False),
        "own": ((bool,), False),  # the operator's own plan (its intent), not the manager's ask
    },
    "human_action": {
        "id": ((str,), True),
        "agent": ((str,), True),
        "action": ((str,), True),
        "suggestion": ((str, type(None)), False),
        "step": ((int,), False),
        "start": (_NUM, False),
        "t": (_NUM, True),
        "positions": ((dict,), False),
        # a wearable sensor's report: false when it missed the action (the manager is not
        # told); ``sensed`` holds the sensor's figures
        "recognised": ((bool,), False),
        "sensed": ((dict,), False),
    },
    "percept": {
        "id": ((str,), True),
        "object": ((str,), True),
        "object_type": ((str,), True),
        "pose": ((list,), True),
        "size": ((dict, list, type(None)), False),
        "t": (_NUM, False),
        "why": ((str,), False),  # what the look followed (``after transport(...)``)
        "moved": ((bool,), False),  # re-anchored away from where the manager believed it
        "contradicts": ((str, type(None)), False),  # the belief it contradicts, and why
    },
    # the operator's answer to "did you do what was reported?" (a repair, paper 000 III):
    # ``report`` is the id of the human_action asked about
    "answer": {
        "id": ((str,), True),
        "agent": ((str,), True),
        "report": ((str,), True),
        "object": ((str,), True),
        "question": ((str,), True),
        "answer": ((str,), True),
        "t": (_NUM, True),
    },
    # a perception agent the ordered loop waits for: it has looked at the world as the
    # ``state`` with ``upto`` stored events showed it; ``at``: when it looks next by itself
    "looked": {
        "agent": ((str,), True),
        "upto": ((int,), True),
        "t": (_NUM, True),
        "at": (_NUM, False),
    },
    # an operator that acts on its own: what it may do (steps -> hyper-arcs -> ground branches)
    "options": {
        "id": ((str,), True),
        "t": (_NUM, True),
        "steps": ((list,), True),
        "world": ((dict,), False),
    },
    "operator": {"agent": ((str,), True), "profile": ((str,), True)},
    "intent": {
        "id": ((str,), True),
        "agent": ((str,), True),
        "options": ((str,), True),
        "act": ((bool,), True),
        "decided": ((list,), True),
        "t": (_NUM, True),
        "step": ((str,), False),
        "hyperarc": ((str,), False),
        "actions": ((list,), False),
        "delay": (_NUM, False),
    },
    "state": {},
    "end": {"outcome": ((str,), True)},
}
ACK_STATUSES = ("done", "failed", "timed_out")


def message(kind: str, **fields: Any) -> dict[str, Any]:
    """A message of ``kind`` (validated, so a bug on the sending side fails loudly)."""
    msg = {"v": VERSION, "type": kind, **fields}
    parse(msg, expect=kind)
    return msg


def parse(data: Any, *, expect: str | tuple[str, ...] | None = None) -> dict[str, Any]:
    """Check a received message; returns it, or raises :class:`ProtocolError` saying why."""
    if not isinstance(data, dict):
        raise ProtocolError(f"a message must be a JSON object, not {type(data).__name__}")
    v = data.get("v")
    if v != VERSION or isinstance(v, bool):
        raise ProtocolError(f"unsupported protocol version {v!r} (this cell speaks v{VERSION})")
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in SCHEMAS:
        raise ProtocolError(f"unknown message type {kind!r}")
    if expect is not None:
        allowed = (expect,) if isinstance(expect, str) else expect
        if kind not in allowed:
            raise ProtocolError(f"a {kind!r} message is not expected here")
    for name, (types, required) in SCHEMAS[kind].items():
        if name not in data:
            if required:
                raise ProtocolError(f"{kind}: missing field {name!r}")
            continue
        value = data[name]
        if (isinstance(value, bool) and bool not in types) or not isinstance(value, types):
            want = " or ".join("null" if t is type(None) else t.__name__ for t in types)
            raise ProtocolError(f"{kind}: field {name!r} must be {want}, not {value!r:.40}")
        if isinstance(value, float) and not math.isfinite(value):
            raise ProtocolError(f"{kind}: field {name!r} must be finite")
        numeric = name in ("t", "duration", "expected_s", "start", "realtime", "delay")
        numeric = numeric or name == "step"
        if numeric and isinstance(value, int | float) and value < 0:
            raise ProtocolError(f"{kind}: field {name!r} must be >= 0, not {value}")
    if kind == "answer" and data["answer"] not in ("yes", "no"):
        raise ProtocolError("answer: 'answer' must be 'yes' or 'no'")
    if kind == "ack" and data["status"] not in ACK_STATUSES:
        raise ProtocolError(f"ack: status must be one of {', '.join(ACK_STATUSES)}")
    if kind in ("command", "suggestion"):
        key = "agents" if kind == "command" else "actions"
        if not data[key] or not all(isinstance(a, str) for a in data[key]):
            raise ProtocolError(f"{kind}: {key!r} must be a non-empty list of strings")
    if kind == "intent":
        if not all(isinstance(x, str) for x in data["decided"]):
            raise ProtocolError("intent: 'decided' must be a list of step names")
        if data["act"]:
            for key in ("step", "hyperarc", "actions"):
                if key not in data:
                    raise ProtocolError(f"intent: an intent to act needs {key!r}")
            actions = data["actions"]
            if not actions or not all(isinstance(a, str) for a in actions):
                raise ProtocolError("intent: 'actions' must be a non-empty list of strings")
    if kind == "options":
        for st in data["steps"]:
            if not (
                isinstance(st, dict)
                and isinstance(st.get("step"), str)
                and isinstance(st.get("arcs"), list)
                and all(
                    isinstance(a, dict)
                    and isinstance(a.get("hyperarc"), str)
                    and isinstance(a.get("cost"), _NUM)
                    and isinstance(a.get("branches"), list)
                    and all(
                        isinstance(b, list) and b and all(isinstance(x, str) for x in b)
                        for b in a["branches"]
                    )
                    for a in st["arcs"]
                )
            ):
                raise ProtocolError(
                    "options: each step must be {step, arcs: [{hyperarc, cost, branches}]}"
                )
    if kind == "percept":
        pose = data["pose"]
        if not 3 <= len(pose) <= 7 or not all(
            isinstance(x, _NUM) and not isinstance(x, bool) and math.isfinite(x) for x in pose
        ):
            raise ProtocolError("percept: 'pose' must be [x, y, z] (+ a quaternion), finite")
        size = data.get("size")
        values = list(size.values()) if isinstance(size, dict) else (size or [])
        if not all(
            isinstance(x, _NUM) and not isinstance(x, bool) and math.isfinite(x) and x >= 0
            for x in values
        ):
            raise ProtocolError("percept: 'size' values must be finite numbers >= 0")
    if kind in ("ack", "human_action") and "positions" in data:
        for obj, p in data["positions"].items():
            if (
                not isinstance(p, list)
                or len(p) != 3
                or not all(isinstance(x, _NUM) and not isinstance(x, bool) for x in p)
                or not all(math.isfinite(x) for x in p)
            ):
                raise ProtocolError(f"{kind}: position of {obj!r} must be [x, y, z] finite numbers")
    return data
