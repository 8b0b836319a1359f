"""The messages nodes exchange (paper 002, Sec. III-C) and the topics they travel on.

* :class:`ActivationMsg` — *activation spreading* message, parent → child: sender and the
  activation level the parent gives the child (Algorithms 2–4). With ``hold=True`` the level is
  latched (re-applied every tick until the next message; :class:`ActivationRelease` lets it
  decay) — see :attr:`~flexhrc.behavior.params.NetworkParams.latched`.
* :class:`StateMsg` — *state* message, child → parent: the child's state, activation level,
  activation potential (bottom-up, Algorithms 5–8) and whether its sub-task has started
  (``progress``: a behaviour in it is running or done — how an OR learns that "a pathway became
  active") and whether anything in it may still act (``engaged``: the node or a descendant is
  active or running, or was just given activation — how an OR knows an alternative it switched
  away from has gone quiet).
* :class:`MutexRequest` / :class:`MutexRelease` / :class:`MutexReply` — the arm mutex protocol
  (lock request with a bid = activation potential; grant or denial after the bidding window);
  a *standing* request holds until a :class:`MutexWithdraw`.
* :class:`LogEvent` — trace records every node publishes on :data:`LOG_TOPIC`.

All are ``NamedTuple`` records of plain values so any transport can serialise them with
:func:`to_wire` / :func:`from_wire` (JSON-compatible dictionaries).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, NamedTuple


class ActivationMsg(NamedTuple):
    sender: str
    level: float
    #: Latched: the receiver re-applies ``level`` at every update loop until the next message on
    #: its activation topic — exactly as if the parent sent it again every tick.
    hold: bool = False


class ActivationRelease(NamedTuple):
    """Ends a held activation: the level the receiver has now decays from here (α per tick)."""

    sender: str


class StateMsg(NamedTuple):
    sender: str
    state: str
    level: float
    potential: float
    progress: bool
    engaged: bool
    tick: int


class MutexRequest(NamedTuple):
    sender: str
    potential: float
    #: A standing bid counts at every tick until replaced or withdrawn (:class:`MutexWithdraw`),
    #: exactly as if it were sent again every tick.
    standing: bool = False


class MutexWithdraw(NamedTuple):
    """Withdraws a standing bid (sent on the mutex's request topic)."""

    sender: str


class MutexRelease(NamedTuple):
    sender: str


class MutexReply(NamedTuple):
    mutex: str
    granted: bool


class LogEvent(NamedTuple):
    tick: int
    t: float
    source: str
    kind: str
    data: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {
            "tick": self.tick,
            "t": self.t,
            "source": self.source,
            "kind": self.kind,
            **self.data,
        }


LOG_TOPIC = "bn/log"
_TYPES = {
    c.__name__: c
    for c in (
        ActivationMsg,
        ActivationRelease,
        StateMsg,
        MutexRequest,
        MutexWithdraw,
        MutexRelease,
        MutexReply,
        LogEvent,
    )
}


def activation_topic(node: str) -> str:
    return f"bn/{node}/activation"


def state_topic(node: str) -> str:
    return f"bn/{node}/state"


def reply_topic(node: str) -> str:
    return f"bn/{node}/mutex"


def request_topic(mutex: str) -> str:
    return f"mutex/{mutex}/request"


def release_topic(mutex: str) -> str:
    return f"mutex/{mutex}/release"


def to_wire(msg: NamedTuple) -> dict[str, Any]:
    """A JSON-compatible dictionary for network transports."""
    return {"type": type(msg).__name__, **msg._asdict()}


def from_wire(data: Any, types: Mapping[str, type] = _TYPES) -> Any:
    """A message from its JSON form (:func:`to_wire`), one of ``types`` (by class name);
    ``ValueError`` for anything else."""
    if not isinstance(data, dict):
        raise ValueError("a message is a JSON object")
    cls = types.get(str(data.get("type")))
    if cls is None:
        raise ValueError(f"unknown message type {data.get('type')!r}")
    try:
        return cls(**{k: v for k, v in data.items() if k != "type"})
    except TypeError:  # a field missing or one too many
        fields = ", ".join(getattr(cls, "_fields", ()))
        raise ValueError(f"{cls.__name__}: expected fields {fields}") from None
