"""Message transports: a deterministic in-process bus (default) and Zenoh for several processes or
hosts (:mod:`flexhrc.transport.zenoh`, the ``zenoh`` extra; imported on demand so the core stays
light). Everything that talks through a transport uses only :class:`Transport`."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from flexhrc.transport.base import Clock, SimClock, Subscription, Transport
from flexhrc.transport.inprocess import InProcessBus

if TYPE_CHECKING:
    from flexhrc.transport.zenoh import ZenohTransport

__all__ = ["Clock", "InProcessBus", "SimClock", "Subscription", "Transport", "ZenohTransport"]


def __getattr__(name: str) -> Any:
    # Lazy: `import flexhrc.transport` must not load Zenoh (nor fail without the extra).
    if name == "ZenohTransport":
        from flexhrc.transport.zenoh import ZenohTransport

        return ZenohTransport
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
