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

A *standing* request (the latched protocol, :attr:`NetworkParams.latched`) counts as a bid at
every tick until its sender replaces or withdraws it — exactly the per-tick re-bidding, without
the messages. A ``window``/``grant`` log event keeps the :data:`LOGGED_BIDS` highest bids (and
``count``, the number of bidders, when there are more), so a log stays linear in the run for
an AND of thousands of behaviours.

One mutex per arm lets two arms run two behaviours in parallel.
"""

from __future__ import annotations

from flexhrc.behavior.messages import (
    LOG_TOPIC,
    LogEvent,
    MutexRelease,
    MutexReply,
    MutexRequest,
    MutexWithdraw,
    release_topic,
    reply_topic,
    request_topic,
)
from flexhrc.behavior.params import NetworkParams
from flexhrc.transport.base import Transport

#: Bids recorded in a ``window``/``grant`` log event (the highest; ``bidders`` counts them all).
LOGGED_BIDS = 32


class ArmMutex:
    """Exclusive access to one arm, granted to the highest bidder after a bidding window."""

    kind = "MUTEX"

    def __init__(self, arm: str, transport: Transport, params: NetworkParams) -> None:
        self.name = arm
        self.holder: str | None = None
        self.window_ticks = params.window_ticks
        self._transport = transport
        self._requests: list[MutexRequest] = []
        self._standing: dict[str, float] = {}
        self._releases: list[MutexRelease] = []
        self._window_close: int | None = None
        self._grant = MutexReply(arm, True)
        self._deny = MutexReply(arm, False)
        transport.subscribe(request_topic(arm), self._on_request)
        transport.subscribe(release_topic(arm), self._releases.append)

    def _on_request(self, msg: MutexRequest | MutexWithdraw) -> None:
        if isinstance(msg, MutexWithdraw):
            self._standing.pop(msg.sender, None)
        elif msg.standing:
            self._standing[msg.sender] = msg.potential
        else:
            self._requests.append(msg)

    def _bids(self) -> dict[str, float]:
        """The bids of this tick: standing ones, and the per-tick requests received last tick."""
        bids = dict(self._standing)
        for req in self._requests:
            bids[req.sender] = req.potential  # latest bid per sender
        self._requests.clear()
        return bids

    def update(self, tick: int, now: float) -> None:
        for rel in self._releases:
            if rel.sender == self.holder:
                self.holder = None
                self._log(tick, now, "release", by=rel.sender)
        self._releases.clear()
        closes = self._window_close
        if self.holder is not None or (closes is not None and tick < closes):
            self._requests.clear()  # ignored while locked; only the last tick counts in a window
            return
        if not self._requests and not self._standing:
            self._window_close = None  # a window closing with no fresh bid grants nothing
            return
        bids = self._bids()
        count = {} if len(bids) <= LOGGED_BIDS else {"count": len(bids)}
        if self._window_close is None:
            self._window_close = tick + self.window_ticks
            self._log(tick, now, "window", closes=self._window_close, bidders=_top(bids), **count)
            return
        self._window_close = None
        winner = min(bids, key=lambda n: (-bids[n], n))
        self.holder = winner
        publish = self._transport.publish
        publish(reply_topic(winner), self._grant)
        for name in bids:
            if name != winner:
                publish(reply_topic(name), self._deny)
        logged = {n: round(bids[n], 6) for n in _top(bids)}
        self._log(tick, now, "grant", to=winner, bid=round(bids[winner], 6), bids=logged, **count)

    def _log(self, tick: int, now: float, kind: str, **data: object) -> None:
        self._transport.publish(LOG_TOPIC, LogEvent(tick, now, f"mutex:{self.name}", kind, data))


def _top(bids: dict[str, float]) -> list[str]:
    """The names of the :data:`LOGGED_BIDS` highest bids (all, when there are no more), sorted
    by name."""
    if len(bids) <= LOGGED_BIDS:
        return sorted(bids)
    import heapq

    return sorted(heapq.nsmallest(LOGGED_BIDS, bids, key=lambda n: (-bids[n], n)))
