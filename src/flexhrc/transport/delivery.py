"""Delivery of received payloads, shared by the transports whose middleware calls back on its
own threads (Zenoh, ROS 2).

``deliver="thread"`` hands a payload to its callback on the middleware's thread at once;
``deliver="flush"`` queues it until the owner calls :meth:`QueuedDelivery.flush` on its own
thread — the deterministic choice for a single-threaded loop such as the cell's. Undecodable
payloads are counted, logged and passed to ``on_drop``; they never reach a callback.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable
from typing import Any, Literal

from flexhrc.transport.base import Subscription

DropCallback = Callable[[str, bytes, Exception], None]


class QueuedDelivery:
    """Mixin: the receiving side of a transport (counters, queue, ``flush``/``wait``)."""

    deliver: Literal["flush", "thread"]
    on_drop: DropCallback | None
    delivered: int
    dropped: int
    _closed: bool

    def _init_delivery(
        self,
        deliver: Literal["flush", "thread"],
        on_drop: DropCallback | None,
        log: logging.Logger,
    ) -> None:
        self._log = log
        self.deliver = deliver
        self.on_drop = on_drop
        self.delivered = 0
        self.dropped = 0
        self._cond = threading.Condition()
        self._queue: deque[tuple[Subscription, Any]] = deque()

    def _hand(self, sub: Subscription, payload: Any) -> None:
        if not sub.active:
            return
        if self.deliver == "thread":
            self.delivered += 1
            try:
                sub.callback(payload)
            except Exception:  # never let a callback kill the middleware's thread
                self._log.exception("callback for %s raised", sub.topic)
            return
        with self._cond:
            self._queue.append((sub, payload))
            self._cond.notify_all()

    def _drop(self, topic: str, data: bytes, exc: Exception) -> None:
        self.dropped += 1
        self._log.warning(
            "dropped an undecodable payload on %s (%d bytes): %s", topic, len(data), exc
        )
        if self.on_drop is not None:
            try:
                self.on_drop(topic, data, exc)
            except Exception:
                self._log.exception("on_drop raised")

    def pending(self) -> int:
        """Payloads received and waiting for the next :meth:`flush` (``deliver="flush"``)."""
        with self._cond:
            return len(self._queue)

    def wait(self, timeout: float | None = None) -> bool:
        """Block until a payload is waiting for :meth:`flush` or ``timeout`` seconds pass;
        returns whether one is waiting. Always ``False`` with ``deliver="thread"``."""
        if self.deliver == "thread":
            return False
        with self._cond:
            if not self._queue and not self._closed:
                self._cond.wait(timeout)
            return bool(self._queue)

    def flush(self) -> int:
        """Deliver, on this thread and in arrival order, the payloads received before the call."""
        if self.deliver == "thread":
            return 0
        with self._cond:
            batch = list(self._queue)
            self._queue.clear()
        count = handed = 0
        try:
            for sub, payload in batch:
                handed += 1
                if sub.active:
                    count += 1
                    sub.callback(payload)
        except BaseException:
            # a callback that raises loses no message behind its own: they go back to the
            # front of the queue for the next flush
            with self._cond:
                self._queue.extendleft(reversed(batch[handed:]))
            raise
        finally:
            self.delivered += count
        return count
