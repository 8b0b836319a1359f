"""The arm mutex won by bidding (paper 002, Sec. III-D).

"When the mutex receives a lock request, a timer is started to allow other behaviours to bid for
control. When the timer ends, the mutex grants the lock to the node that bid with the highest
activation potential and denies all other behaviours. The denied behaviours will continue to
request a lock until it is acquired."

:class:`ArmMutex` is a node of its own that talks only through the transport: lock requests
(carrying the bid) on ``mutex/<arm>/request``, releases on ``mutex/<arm>/release``, grants and
denials on each requester's ``bn/<node>/mutex`` topic. While the lock is held, requests are
ignored (the requesters keep asking). At the end of the window only bids received in that last
tick count: waiting behaviours re-bid every tick, so a behaviour that lost its activation during
the window has dropped out. Equal bids go to the smallest node name (deterministic).

One mutex per arm lets two arms run two behaviours in parallel.
"""

from __future__ import annotations

from flexhrc.behavior.messages import (
    LOG_TOPIC,
    LogEvent,
    MutexRelease,
    MutexReply,
    MutexRequest,
    release_topic,
    reply_topic,
    request_topic,
)
from flexhrc.behavior.params import NetworkParams
from flexhrc.transport.base import Transport


class ArmMutex:
    """Exclusive access to one arm, granted to the highest bidder after a bidding window."""

    kind = "MUTEX"

    def __init__(self, arm: str, transport: Transport, params: NetworkParams) -> None:
        self.name = arm
        self.holder: str | None = None
        self.window_ticks = params.window_ticks
        self._transport = transport
        self._requests: list[MutexRequest] = []
        self._releases: list[MutexRelease] = []
        self._window_close: int | None = None
        self._grant = MutexReply(arm, True)
        self._deny = MutexReply(arm, False)
        transport.subscribe(request_topic(arm), self._requests.append)
        transport.subscribe(release_topic(arm), self._releases.append)

    def update(self, tick: int, now: float) -> None:
        for rel in self._releases:
            if rel.sender == self.holder:
                self.holder = None
                self._log(tick, now, "release", by=rel.sender)
        self._releases.clear()
        bids: dict[str, float] = {}
        for req in self._requests:
            bids[req.sender] = req.potential  # latest bid per sender
        self._requests.clear()
        if self.holder is not None:
            return
        if self._window_close is None:
            if bids:
                self._window_close = tick + self.window_ticks
                self._log(tick, now, "window", closes=self._window_close, bidders=sorted(bids))
            return
        if tick < self._window_close:
            return
        self._window_close = None
        if not bids:
            return
        winner = min(bids, key=lambda n: (-bids[n], n))
        self.holder = winner
        publish = self._transport.publish
        publish(reply_topic(winner), self._grant)
        for name in bids:
            if name != winner:
                publish(reply_topic(name), self._deny)
        self._log(
            tick,
            now,
            "grant",
            to=winner,
            bid=round(bids[winner], 6),
            bids={n: round(b, 6) for n, b in sorted(bids.items())},
        )

    def _log(self, tick: int, now: float, kind: str, **data: object) -> None:
        self._transport.publish(LOG_TOPIC, LogEvent(tick, now, f"mutex:{self.name}", kind, data))

    def snapshot(self) -> dict[str, object]:
        return {"name": self.name, "kind": self.kind, "holder": self.holder}
