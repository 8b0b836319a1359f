"""Message transports: an in-process bus (default) and, later, Zenoh for several processes or
hosts. Everything that talks through a transport uses only :class:`Transport`."""

from flexhrc.transport.base import Clock, SimClock, Subscription, Transport
from flexhrc.transport.inprocess import InProcessBus

__all__ = ["Clock", "InProcessBus", "SimClock", "Subscription", "Transport"]
