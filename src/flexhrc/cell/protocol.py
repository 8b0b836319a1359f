"""The cell protocol (``docs/protocol.md``): key expressions and JSON messages, version 1.

Every key lives under ``flexhrc/<cell>/`` (the transport's prefix). Topics, relative to it:

==================  ==================  ====================================================
topic               from -> to          message ``type``
==================  ==================  ====================================================
``cmd/<agent>``     manager -> robot    ``command``, ``stop``
``ack``             robot -> manager    ``ack``
``suggest/<name>``  manager -> human    ``suggestion``
``human``           human -> manager    ``human_action``, ``answer`` (to a repair question),
                                        ``reply`` (decline, cannot, start, give_back)
``options/<name>``  manager -> human    ``options`` (what an operator may do on its own)
``intent``          human -> manager    ``operator`` (its profile), ``intent`` (its answer)
``percept``         perception -> mgr   ``percept``, ``looked`` (a watcher has looked)
``state``           manager -> all      ``state`` (the cell snapshot), ``end``
``join``            agent -> manager    ``join`` (its name and scenario fingerprint)
``alive/<agent>``   liveliness tokens   (``alive/manager`` for the manager)
==================  ==================  ====================================================

Run identity (:mod:`flexhrc.cell.identity`): the manager's commands, stops, suggestions,
``options`` and ``end`` carry the run id as ``run`` (and the first three the scenario's
``fingerprint``); an agent's answers carry the ``run`` of what they answer.

Every message is a JSON object with ``"v": 1`` and ``"type"``. :func:`parse` checks one against
its schema in the catalogue (:data:`flexhrc.events.MESSAGES`) and raises :class:`ProtocolError`
(a one-line reason) for anything malformed; the receiver logs it and drops it, never stops.
"""

from __future__ import annotations

from typing import Any

from flexhrc.errors import FlexhrcError
from flexhrc.events import MESSAGES, MessageType

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
JOIN_TOPIC = "join"
ALIVE_PREFIX = "alive"


def alive_key(agent: str) -> str:
    return f"{ALIVE_PREFIX}/{agent}"


def message(kind: MessageType, **fields: Any) -> dict[str, Any]:
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
    if not isinstance(kind, str) or kind not in MESSAGES:
        raise ProtocolError(f"unknown message type {kind!r}")
    if expect is not None:
        allowed = (expect,) if isinstance(expect, str) else expect
        if kind not in allowed:
            raise ProtocolError(f"a {kind!r} message is not expected here")
    problem = MESSAGES[kind].problem(data)
    if problem is not None:
        raise ProtocolError(problem)
    return data


def parse_end(data: Any, *, run: Any = None) -> dict[str, Any]:
    """An ``end`` an agent may obey: a well-formed ``end`` of this protocol version (an agent
    never leaves on ``{"v": 99, "type": "end"}``) of the agent's run ``run`` once it knows one
    (an end without a run is then refused: probe P15); raises :class:`ProtocolError` saying
    why not. The caller takes it only from the ``state`` key of its own cell's manager (the
    transport's prefix names the cell)."""
    msg = parse(data, expect="end")
    if run is not None and msg.get("run") != run:  # the manager's own end names the run (P15)
        raise ProtocolError(f"an 'end' of run {msg.get('run')!r}, not of this run {run!r}")
    return msg
