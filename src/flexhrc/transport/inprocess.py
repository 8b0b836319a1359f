"""Deterministic in-process message bus (the default transport).

Payloads published during a tick are queued and delivered, in publish order, when the owner calls
:meth:`InProcessBus.flush` — normally once at the end of every tick of a simulated clock. This
models the one-message latency of a real distributed system (a ROS or Zenoh hop) while staying
fully deterministic: the order in which nodes run inside a tick cannot change what any node sees,
because everything it receives was sent in an earlier tick.

Set ``immediate=True`` to deliver synchronously inside :meth:`publish` instead (handy for small
tests of request/response code).
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from flexhrc.transport.base import Callback, Subscription, Transport


class InProcessBus(Transport):
    """Single-threaded publish/subscribe bus with queued, ordered delivery."""

    def __init__(self, immediate: bool = False) -> None:
        self.immediate = immediate
        self._subs: dict[str, list[Subscription]] = defaultdict(list)
        self._pending: list[tuple[str, Any]] = []
        self.published = 0  # counters for benchmarks and diagnostics
        self.delivered = 0

    def publish(self, topic: str, payload: Any) -> None:
        self.published += 1
        if self.immediate:
            self._deliver(topic, payload)
        else:
            self._pending.append((topic, payload))

    def subscribe(self, topic: str, callback: Callback) -> Subscription:
        sub = Subscription(topic, callback, self)
        self._subs[topic].append(sub)
        return sub

    def unsubscribe(self, subscription: Subscription) -> None:
        subs = self._subs.get(subscription.topic)
        if subs and subscription in subs:
            subs.remove(subscription)
        subscription.active = False

    def pending(self) -> int:
        """Number of payloads waiting for the next :meth:`flush`."""
        return len(self._pending)

    def flush(self) -> int:
        """Deliver everything published before this call; payloads published by the callbacks
        themselves wait for the next flush (so one flush is exactly one network hop)."""
        batch, self._pending = self._pending, []
        count = handed = 0
        subs = self._subs
        try:
            for topic, payload in batch:
                handed += 1
                targets = subs.get(topic)
                if targets:
                    for sub in targets:
                        sub.callback(payload)
                    count += len(targets)
        except BaseException:
            # a callback that raises loses no payload behind its own: they wait for the next
            # flush, ahead of what the callbacks published
            self._pending[:0] = batch[handed:]
            raise
        finally:
            self.delivered += count
        return count

    def _deliver(self, topic: str, payload: Any) -> None:
        for sub in list(self._subs.get(topic, ())):
            sub.callback(payload)
            self.delivered += 1
