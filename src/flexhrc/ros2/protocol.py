"""The cell protocol as the ROS 2 bridge uses it: topic names and the agent-side messages.

The cell (``flexhrc.cell``, ``docs/protocol.md``) defines the protocol; the bridge carries it
unchanged on ROS 2 topics. This module names the pieces an agent needs (its command topic, the
ack topic, its liveliness key) and checks the messages an arm receives.
"""

from __future__ import annotations

from typing import Any

PROTOCOL_VERSION = 1

__all__ = [
    "PROTOCOL_VERSION",
    "ack_topic",
    "alive_key",
    "command_topic",
    "parse_agent_message",
]


def command_topic(agent: str) -> str:
    return f"cmd/{agent}"


def ack_topic() -> str:
    return "ack"


def alive_key(agent: str) -> str:
    return f"alive/{agent}"


def parse_agent_message(payload: Any) -> dict[str, Any]:
    """A ``command`` or ``stop`` message for an agent, checked; ``ValueError`` says what is
    wrong (the caller logs and drops it)."""
    if not isinstance(payload, dict):
        raise ValueError(f"a message must be a JSON object, not {type(payload).__name__}")
    if payload.get("v") != PROTOCOL_VERSION:
        raise ValueError(f"protocol version {payload.get('v')!r}, expected {PROTOCOL_VERSION}")
    kind = payload.get("kind")
    if kind not in ("command", "stop"):
        raise ValueError(f"unknown message kind {kind!r} for an agent")
    cid = payload.get("id")
    if not isinstance(cid, int | str) or isinstance(cid, bool) or cid == "":
        raise ValueError(f"{kind}: missing or invalid id {cid!r}")
    if kind == "command":
        action = payload.get("action")
        if not isinstance(action, str) or not action:
            raise ValueError(f"command {cid}: missing action")
        agents = payload.get("agents", [])
        if not isinstance(agents, list) or not all(isinstance(a, str) for a in agents):
            raise ValueError(f"command {cid}: agents must be a list of names")
    return payload
