"""The Zenoh transport: one session, then two real processes on loopback (no multicast)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest

pytest.importorskip("zenoh")

from flexhrc.transport import Transport
from flexhrc.transport.zenoh import (
    TransportError,
    ZenohTransport,
    json_decode,
    json_encode,
    loopback_config,
    normalise_endpoint,
    zenoh_config,
)

from ..conftest import subprocess_env

# A peer process: connects to the port given, echoes "t/ping" to "t/pong" (adding its pid) and
# declares a liveliness token — after its subscription, so whoever sees the token can reach it
# (Zenoh keeps one session's declarations in order) — until killed.
ECHO = textwrap.dedent(
    """
    import os, sys
    from flexhrc.transport.zenoh import ZenohTransport, loopback_config
    bus = ZenohTransport(loopback_config(connect=int(sys.argv[1])), prefix="test")
    bus.subscribe("t/ping", lambda p: bus.publish("t/pong", {"pid": os.getpid(), "n": p["n"]}))
    bus.declare_token("alive/echo")
    print("ready", flush=True)
    while True:
        bus.wait(0.5)
        bus.flush()
    """
)


def pump(bus: ZenohTransport, until: Callable[[], bool], timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while not until():
        if time.monotonic() > deadline:
            return False
        bus.wait(0.05)
        bus.flush()
    return True


# Every session here listens on port 0: the system gives it a port nobody else holds, and
# :meth:`ZenohTransport.locators` says which (never a port picked, closed and bound again).
ANY_PORT = ["tcp/127.0.0.1:0"]


def port_of(bus: ZenohTransport) -> int:
    (endpoint,) = bus.locators()
    return int(endpoint.rsplit(":", 1)[1])


@pytest.fixture
def bus() -> Any:
    b = ZenohTransport(zenoh_config(listen=ANY_PORT))
    yield b
    b.close()


def test_one_session_delivers_on_flush_in_arrival_order(bus: ZenohTransport) -> None:
    assert isinstance(bus, Transport)
    got: list[Any] = []
    bus.subscribe("a/x", got.append)
    for i in range(5):
        bus.publish("a/x", {"i": i})
    bus.publish("a/nobody", 1)
    assert pump(bus, lambda: len(got) == 5)
    assert got == [{"i": i} for i in range(5)]
    assert bus.published == 6


def test_undecodable_payload_is_dropped_and_reported(bus: ZenohTransport) -> None:
    got: list[Any] = []
    drops: list[tuple[str, bytes]] = []
    bus.on_drop = lambda topic, data, exc: drops.append((topic, data))
    bus.subscribe("a/x", got.append)
    raw: list[bytes] = []
    bus.subscribe("a/x", raw.append, raw=True)
    bus.publish_bytes("a/x", b"\xff\x00 not json")
    bus.publish_bytes("a/x", b"NaN")
    bus.publish("a/x", [1, 2])
    assert pump(bus, lambda: len(got) == 1 and len(raw) == 3)
    assert got == [[1, 2]]
    assert drops == [("a/x", b"\xff\x00 not json"), ("a/x", b"NaN")]
    assert bus.dropped == 2


def test_cancelled_subscription_gets_nothing(bus: ZenohTransport) -> None:
    got: list[Any] = []
    other: list[Any] = []
    sub = bus.subscribe("a/x", got.append)
    bus.subscribe("a/x", other.append)
    sub.cancel()
    bus.publish("a/x", 1)
    assert pump(bus, lambda: other == [1])
    assert got == []


def test_thread_delivery_calls_back_without_flush() -> None:
    with ZenohTransport(zenoh_config(listen=ANY_PORT), deliver="thread") as b:
        got: list[Any] = []
        arrived = threading.Event()

        def on_message(payload: Any) -> None:  # on Zenoh's thread
            got.append(payload)
            arrived.set()

        b.subscribe("a/x", on_message)
        b.publish("a/x", "hi")
        assert arrived.wait(5)
        assert got == ["hi"]
        assert b.flush() == 0


def test_prefix_and_local_liveliness(bus: ZenohTransport) -> None:
    seen: list[tuple[str, bool]] = []
    with ZenohTransport(session=bus.session, prefix="cellA") as a:
        a.watch_liveliness("alive/*", lambda k, alive: seen.append((k, alive)))
        token = a.declare_token("alive/left")
        assert pump(a, lambda: ("alive/left", True) in seen)
        token.undeclare()
        token.undeclare()  # idempotent
        assert pump(a, lambda: ("alive/left", False) in seen)


def test_bad_topics_endpoints_and_closed_use() -> None:
    with pytest.raises(TransportError, match="tcp/HOST:PORT"):
        zenoh_config(connect=["localhost"])
    with pytest.raises(TransportError, match="out of range"):
        zenoh_config(listen=["tcp/127.0.0.1:70000"])
    assert normalise_endpoint("127.0.0.1:7447") == "tcp/127.0.0.1:7447"
    assert normalise_endpoint("tcp/[::1]:7447") == "tcp/[::1]:7447"
    b = ZenohTransport(zenoh_config(listen=ANY_PORT))
    try:
        with pytest.raises(TransportError, match="cannot open"):
            ZenohTransport(loopback_config(port_of(b)))  # the port is taken
        for topic in ("", "a//b", "/a", "a/", "a/*", "a/$x"):
            with pytest.raises(ValueError):
                b.publish(topic, 1)
    finally:
        b.close()
    b.close()
    with pytest.raises(TransportError, match="closed"):
        b.publish("a", 1)


def test_a_listener_on_port_zero_reports_the_port_the_system_gave_it() -> None:
    with ZenohTransport(zenoh_config(listen=["tcp/127.0.0.1:0"])) as a:
        (endpoint,) = a.locators()
        assert endpoint.startswith("tcp/127.0.0.1:") and int(endpoint.rsplit(":", 1)[1]) > 0
        with ZenohTransport(zenoh_config(connect=[endpoint])) as b:
            got: list[Any] = []
            a.subscribe("a/x", got.append)
            deadline = time.monotonic() + 10
            while not got and time.monotonic() < deadline:
                b.publish("a/x", 1)  # the link comes up in its own time: send until one arrives
                pump(a, lambda: bool(got), 0.1)
            assert got and got[0] == 1
    with ZenohTransport(loopback_config(connect=1)) as c, pytest.raises(TransportError):
        c.locators()  # the admin space is on only for a session with a port-0 endpoint


def test_json_codec_is_strict() -> None:
    assert json_decode(json_encode({"a": [1, 2.5, None]})) == {"a": [1, 2.5, None]}
    with pytest.raises(ValueError):
        json_encode(float("nan"))
    for bad in (b"Infinity", b"\xfe", b"{"):
        with pytest.raises(ValueError):
            json_decode(bad)


def test_two_processes_round_trip_and_liveliness_on_sigkill() -> None:
    bus = ZenohTransport(zenoh_config(listen=ANY_PORT), prefix="test")
    port = port_of(bus)  # bound here before the child is told it
    alive: list[tuple[str, bool]] = []
    pongs: list[dict[str, Any]] = []
    bus.watch_liveliness("alive/*", lambda k, a: alive.append((k, a)))
    bus.subscribe("t/pong", pongs.append)
    proc = subprocess.Popen(
        [sys.executable, "-c", ECHO, str(port)],
        stdout=subprocess.PIPE,
        text=True,
        env=subprocess_env(),
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "ready"
        assert pump(bus, lambda: ("alive/echo", True) in alive)
        for n in range(20):
            bus.publish("t/ping", {"n": n})
        assert pump(bus, lambda: len(pongs) == 20)
        assert [p["n"] for p in pongs] == list(range(20))
        assert {p["pid"] for p in pongs} == {proc.pid}
        os.kill(proc.pid, signal.SIGKILL)
        # the token goes with the process (how fast: benchmarks/cell.py)
        assert pump(bus, lambda: ("alive/echo", False) in alive, timeout=10)
    finally:
        proc.kill()
        proc.wait(10)
        bus.close()
