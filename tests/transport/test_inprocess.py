from flexhrc.transport import InProcessBus, SimClock, Transport


def test_bus_is_a_transport_and_delivers_on_flush_in_publish_order():
    bus = InProcessBus()
    assert isinstance(bus, Transport)
    got: list[tuple[str, int]] = []
    bus.subscribe("a", lambda p: got.append(("a", p)))
    bus.subscribe("b", lambda p: got.append(("b", p)))
    bus.publish("a", 1)
    bus.publish("b", 2)
    bus.publish("a", 3)
    bus.publish("nobody", 4)
    assert got == []  # queued until the end of the tick
    assert bus.pending() == 4
    assert bus.flush() == 3
    assert got == [("a", 1), ("b", 2), ("a", 3)]


def test_payloads_published_by_callbacks_wait_for_the_next_flush():
    bus = InProcessBus()
    got: list[int] = []
    bus.subscribe("ping", lambda p: bus.publish("pong", p + 1))
    bus.subscribe("pong", got.append)
    bus.publish("ping", 1)
    bus.flush()
    assert got == []  # one flush = one hop
    bus.flush()
    assert got == [2]


def test_unsubscribe_and_cancel_stop_deliveries():
    bus = InProcessBus()
    got: list[int] = []
    sub = bus.subscribe("t", got.append)
    other = bus.subscribe("t", lambda p: got.append(-p))
    bus.publish("t", 1)
    bus.flush()
    sub.cancel()
    sub.cancel()  # idempotent
    bus.publish("t", 2)
    bus.flush()
    bus.unsubscribe(other)
    bus.publish("t", 3)
    bus.flush()
    assert got == [1, -1, -2]


def test_immediate_mode_delivers_synchronously():
    bus = InProcessBus(immediate=True)
    got: list[str] = []
    bus.subscribe("t", got.append)
    bus.publish("t", "x")
    assert got == ["x"]


def test_sim_clock_time_is_tick_times_period_without_drift():
    clock = SimClock(0.1)
    for _ in range(10_000):
        clock.advance()
    assert clock.tick == 10_000
    assert clock.now() == 1000.0
