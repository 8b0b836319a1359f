"""The transport interface: topics carry payloads from publishers to subscribers.

A transport is the only way two parts of a distributed controller talk to each other. The
behaviour network of paper 002 (Fraser et al., Sec. III-C) runs every node as its own process
over ROS publish/subscribe; flexhrc keeps the same shape behind this small interface so that the
default deterministic in-process bus (:mod:`flexhrc.transport.inprocess`) and a later Zenoh
transport are interchangeable.

The contract is deliberately tiny:

* :meth:`Transport.publish` hands a payload to every subscriber of exactly that topic (no
  wildcards, no retained messages);
* :meth:`Transport.subscribe` returns a :class:`Subscription` handle that can be cancelled;
* :meth:`Transport.flush` delivers whatever is pending and returns how many deliveries it made.
  An asynchronous transport (threads, Zenoh) delivers on its own and may return 0.

Payloads are plain values or ``NamedTuple`` records of plain values, so a network transport can
serialise them (see :func:`flexhrc.behavior.messages.to_wire`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

Callback = Callable[[Any], None]


@dataclass(eq=False)
class Subscription:
    """Handle returned by :meth:`Transport.subscribe`; ``cancel()`` stops the deliveries."""

    topic: str
    callback: Callback
    transport: Transport = field(repr=False)
    active: bool = True

    def cancel(self) -> None:
        if self.active:
            self.transport.unsubscribe(self)
            self.active = False


class Transport(ABC):
    """Publish/subscribe by exact topic name."""

    @abstractmethod
    def publish(self, topic: str, payload: Any) -> None:
        """Send ``payload`` to every current subscriber of ``topic``."""

    @abstractmethod
    def subscribe(self, topic: str, callback: Callback) -> Subscription:
        """Call ``callback(payload)`` for every payload later published on ``topic``."""

    @abstractmethod
    def unsubscribe(self, subscription: Subscription) -> None:
        """Stop delivering to ``subscription`` (idempotent)."""

    def flush(self) -> int:
        """Deliver pending payloads; returns the number of deliveries (0 if asynchronous)."""
        return 0

    def close(self) -> None:  # noqa: B027 - optional hook, a no-op by default
        """Release resources (threads, sockets). The in-process bus has none."""


class Clock(ABC):
    """Source of time for sans-IO logic: simulated in tests and scenarios, wall time on a robot."""

    @abstractmethod
    def now(self) -> float:
        """Seconds since the start of the run."""


class SimClock(Clock):
    """A simulated clock that advances by a fixed tick period when told to.

    Time is computed as ``tick * period`` (not by summing floats) so it never drifts and the same
    tick always has the same time stamp.
    """

    def __init__(self, period: float = 0.1) -> None:
        if not period > 0:
            raise ValueError("tick period must be > 0")
        self.period = float(period)
        self.tick = 0

    def now(self) -> float:
        return round(self.tick * self.period, 9)

    def advance(self) -> float:
        self.tick += 1
        return self.now()
