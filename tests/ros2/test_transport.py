"""The ROS 2 transport: the Transport contract, JSON on std_msgs/String, liveliness by
heartbeats (a SIGKILLed process is noticed within its lease), bad input dropped."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import time

import pytest

from flexhrc.errors import FlexhrcError
from flexhrc.ros2.transport import Ros2Transport, Ros2TransportError, key_matches, ros_topic
from flexhrc.transport import Transport
from tests.ros2.conftest import wait_for


@pytest.fixture
def pair(domain_id: int, cell_name: str):
    a = Ros2Transport(prefix=f"flexhrc/{cell_name}", domain_id=domain_id)
    b = Ros2Transport(prefix=f"flexhrc/{cell_name}", domain_id=domain_id)
    yield a, b
    a.close()
    b.close()


def test_topic_names_map_under_the_prefix_and_bad_names_are_refused():
    assert ros_topic("flexhrc/c1", "cmd/left") == "/flexhrc/c1/cmd/left"
    assert ros_topic("", "ack") == "/ack"
    for bad in ("cmd/left-arm", "", "cmd//x", "1st", "a b"):
        with pytest.raises(Ros2TransportError, match=r"ROS 2 name|non-empty"):
            ros_topic("flexhrc/c1", bad)
    assert issubclass(Ros2TransportError, FlexhrcError)


def test_key_expressions_match_like_zenoh():
    assert key_matches("alive/*", "alive/left")
    assert not key_matches("alive/*", "alive/left/x")
    assert key_matches("alive/**", "alive/left/x")
    assert key_matches("**", "anything/at/all")
    assert not key_matches("alive/left", "alive/right")


def test_bad_settings_are_one_clear_error(domain_id: int):
    with pytest.raises(Ros2TransportError, match="heartbeat_s"):
        Ros2Transport(domain_id=domain_id, lease_s=0.1, heartbeat_s=0.5)
    with pytest.raises(Ros2TransportError, match="domain id"):
        Ros2Transport(domain_id=999)
    with pytest.raises(Ros2TransportError, match="domain id"):
        Ros2Transport(domain_id="abc")
    with pytest.raises(ValueError, match="deliver"):
        Ros2Transport(domain_id=domain_id, deliver="later")  # type: ignore[arg-type]


def test_json_payloads_cross_between_two_participants_in_order(pair):
    a, b = pair
    assert isinstance(a, Transport)
    got: list[object] = []
    b.subscribe("state", got.append)
    # DDS delivers only to subscribers it has discovered: wait for the match (not a sleep)
    assert a.wait_matched("state", minimum=1, timeout=5.0)
    msgs = [{"v": 1, "n": i, "text": "é"} for i in range(20)]
    for m in msgs:
        a.publish("state", m)
    assert wait_for(lambda: len(got) == 20, 5.0, b.flush)
    assert got == msgs
    assert a.published == 20 and b.delivered == 20


def test_malformed_payloads_are_dropped_and_never_reach_a_callback(pair):
    a, b = pair
    got: list[object] = []
    drops: list[tuple[str, bytes]] = []
    b.on_drop = lambda topic, data, exc: drops.append((topic, data))
    b.subscribe("ack", got.append)
    assert a.wait_matched("ack", minimum=1, timeout=5.0)
    for junk in (b"{not json", b"NaN", b"\xff\xfe", b""):
        a.publish_bytes("ack", junk)
    a.publish("ack", {"ok": True})
    assert wait_for(lambda: got == [{"ok": True}], 5.0, b.flush)
    assert b.dropped == 4 and len(drops) == 4 and drops[0] == ("ack", b"{not json")
    with pytest.raises(ValueError):
        a.publish("ack", {"x": float("nan")})


def test_unsubscribe_stops_deliveries_and_close_is_final(pair):
    a, b = pair
    got: list[object] = []
    witness: list[object] = []  # stays subscribed: shows when a message has arrived at b
    b.subscribe("t", witness.append)
    sub = b.subscribe("t", got.append)
    assert a.wait_matched("t", minimum=1, timeout=5.0)
    a.publish("t", 1)
    assert wait_for(lambda: got == [1], 5.0, b.flush)
    sub.cancel()
    a.publish("t", 2)
    assert wait_for(lambda: witness == [1, 2], 5.0, b.flush)  # 2 reached b ...
    assert got == [1]  # ... and not the cancelled subscription
    a.close()
    a.close()
    with pytest.raises(Ros2TransportError, match="closed"):
        a.publish("t", 3)


def test_thread_delivery_calls_back_on_the_executor_thread(domain_id: int, cell_name: str):
    with (
        Ros2Transport(prefix=cell_name, domain_id=domain_id, deliver="thread") as a,
        Ros2Transport(prefix=cell_name, domain_id=domain_id) as b,
    ):
        got: list[object] = []
        a.subscribe("t", got.append)
        assert b.wait_matched("t", minimum=1, timeout=5.0)
        b.publish("t", "x")
        assert wait_for(lambda: got == ["x"], 5.0)
        assert a.flush() == 0 and a.wait(0.01) is False


def test_liveliness_token_seen_and_withdrawn(domain_id: int, cell_name: str):
    # a lease far longer than the test: the token can only go by its explicit withdrawal
    with (
        Ros2Transport(prefix=f"flexhrc/{cell_name}", domain_id=domain_id, lease_s=600.0) as a,
        Ros2Transport(prefix=f"flexhrc/{cell_name}", domain_id=domain_id, lease_s=600.0) as b,
    ):
        _seen_and_withdrawn(a, b)


def _seen_and_withdrawn(a: Ros2Transport, b: Ros2Transport) -> None:
    events: list[tuple[str, bool]] = []
    b.watch_liveliness("alive/*", lambda k, alive: events.append((k, alive)))
    token = a.declare_token("alive/left")
    a.declare_token("other/x")  # does not match the watch
    assert wait_for(lambda: events == [("alive/left", True)], 5.0, b.flush)
    assert b.alive("alive/*") == ["alive/left"]
    token.undeclare()
    token.undeclare()
    assert wait_for(lambda: events[-1] == ("alive/left", False), 30.0, b.flush)
    assert events.count(("alive/left", True)) == 1  # heartbeats do not repeat the event


def test_history_false_ignores_tokens_already_alive(pair):
    a, b = pair
    a.declare_token("alive/old")
    seen: list[str] = []
    b.watch_liveliness("alive/*", lambda k, alive: seen.append(k))
    assert wait_for(lambda: seen == ["alive/old"], 5.0, b.flush)
    late: list[str] = []
    b.watch_liveliness("alive/*", lambda k, alive: late.append(k), history=False)
    time.sleep(b.lease_s + 0.2)
    b.flush()
    assert late == []
    a.declare_token("alive/new")
    assert wait_for(lambda: late == ["alive/new"], 5.0, b.flush)


_AGENT = textwrap.dedent(
    """
    import sys, time
    from flexhrc.ros2.transport import Ros2Transport
    t = Ros2Transport(prefix=sys.argv[1])
    t.subscribe("cmd", lambda p: t.publish("ack", {"id": p["id"], "status": "done"}))
    t.subscribe("late", lambda p: None)  # published to only after this process is killed
    t.declare_token("alive/echo")
    print("ready", flush=True)
    while True:
        t.wait(0.1)
        t.flush()
    """
)


@pytest.mark.slow
def test_another_process_answers_and_its_sigkill_is_noticed_within_the_lease(
    domain_id: int, cell_name: str, ros_env: dict[str, str]
):
    with Ros2Transport(prefix=cell_name, domain_id=domain_id) as bus:
        events: list[tuple[str, bool, float]] = []
        acks: list[dict] = []
        bus.watch_liveliness("alive/*", lambda k, a: events.append((k, a, time.monotonic())))
        bus.subscribe("ack", acks.append)
        proc = subprocess.Popen(
            [sys.executable, "-c", _AGENT, cell_name], env=ros_env, stdout=subprocess.PIPE
        )
        try:
            assert wait_for(lambda: any(e[1] for e in events), 20.0, bus.flush), "no heartbeat"
            bus.publish("cmd", {"id": 7})
            assert wait_for(lambda: acks == [{"id": 7, "status": "done"}], 5.0, bus.flush)
            assert bus.liveliness_holders("alive/*") == ["alive/echo"]
            proc.send_signal(signal.SIGKILL)
            killed = time.monotonic()
            assert wait_for(lambda: events[-1][1] is False, 5.0, bus.flush)
            assert events[-1][0] == "alive/echo"
            # a new process may take the name now: DDS still lists the killed writer, but it
            # is not asserted and its heartbeats stopped
            assert bus.liveliness_holders("alive/*", timeout=0.0) == []
            assert events[-1][2] - killed < bus.lease_s + 0.5
            # DDS still lists the dead process's subscriber (until its 20 s lease); Fast DDS
            # matches a new publisher with it from its discovery data, so publishing to it
            # never blocks on the match
            assert bus.node.count_subscribers(bus.ros_name("late")) == 1
            waits: list[str] = []
            real_wait = bus.wait_matched
            bus.wait_matched = lambda topic, **kw: waits.append(topic) or real_wait(topic, **kw)  # type: ignore[method-assign]
            for i in range(5):
                bus.publish("late", {"n": i})
            assert len(waits) <= 1
        finally:
            proc.kill()
            proc.wait(5)


def _plain_node(domain_id: int, name: str) -> tuple[object, object, object]:
    """A node of plain rclpy (no flexhrc code): any process on the host could run it."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    node = rclpy.create_node(name, context=ctx)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)
    return ctx, node, executor


def test_r2p2_a_goodbye_from_a_node_that_does_not_hold_the_token_has_no_effect(
    domain_id: int, cell_name: str
):
    from std_msgs.msg import String

    prefix = f"flexhrc/{cell_name}"
    # the manager's lease is far longer than the test: a token goes only when withdrawn
    with (
        Ros2Transport(prefix=prefix, domain_id=domain_id) as arm,
        Ros2Transport(prefix=prefix, domain_id=domain_id, lease_s=600.0) as manager,
    ):
        events: list[tuple[str, bool]] = []
        manager.watch_liveliness("alive/*", lambda k, alive: events.append((k, alive)))
        arm.declare_token("alive/left")
        assert wait_for(lambda: events == [("alive/left", True)], 10.0, manager.flush)
        ctx, node, _ = _plain_node(domain_id, "spoof")
        try:
            pub = node.create_publisher(String, f"/{prefix}/liveliness", 10)  # type: ignore[attr-defined]
            assert wait_for(lambda: pub.get_subscription_count() >= 2, 10.0)
            for _ in range(3):
                pub.publish(String(data='{"key": "alive/left", "alive": false}'))
            # a witness behind the goodbyes on the same writer: once it is seen, they were read
            pub.publish(String(data='{"key": "alive/witness", "alive": true, "lease_s": 600}'))
            assert wait_for(lambda: ("alive/witness", True) in events, 10.0, manager.flush)
            # ... and the witness's own goodbye, from the writer that holds it, is taken
            pub.publish(String(data='{"key": "alive/witness", "alive": false}'))
            assert wait_for(lambda: ("alive/witness", False) in events, 10.0, manager.flush)
        finally:
            node.destroy_node()  # type: ignore[attr-defined]
            ctx.try_shutdown()  # type: ignore[attr-defined]
        assert [e for e in events if e[0] == "alive/left"] == [("alive/left", True)]
        assert manager.alive("alive/*") == ["alive/left"]


def test_a_plain_rclpy_writer_with_a_liveliness_lease_is_a_token(domain_id: int, cell_name: str):
    # the DDS way for a program of its own (docs/ros2.md): a publisher with a liveliness
    # lease on /<prefix>/liveliness/<key>; it is there while the writer is, no heartbeats
    from rclpy.duration import Duration
    from rclpy.qos import LivelinessPolicy, QoSProfile
    from std_msgs.msg import String

    prefix = f"flexhrc/{cell_name}"
    with Ros2Transport(prefix=prefix, domain_id=domain_id) as manager:
        events: list[tuple[str, bool]] = []
        manager.watch_liveliness("alive/*", lambda k, alive: events.append((k, alive)))
        ctx, node, executor = _plain_node(domain_id, "plain_operator")
        try:
            qos = QoSProfile(
                depth=1,
                liveliness=LivelinessPolicy.AUTOMATIC,
                liveliness_lease_duration=Duration(seconds=1.0),
            )
            pub = node.create_publisher(String, f"/{prefix}/liveliness/alive/human", qos)  # type: ignore[attr-defined]
            assert wait_for(lambda: events == [("alive/human", True)], 10.0, manager.flush)
            node.destroy_publisher(pub)  # type: ignore[attr-defined]
            assert wait_for(lambda: events[-1] == ("alive/human", False), 10.0, manager.flush)
        finally:
            executor.shutdown()  # type: ignore[attr-defined]
            node.destroy_node()  # type: ignore[attr-defined]
            ctx.try_shutdown()  # type: ignore[attr-defined]
        assert events == [("alive/human", True), ("alive/human", False)]


def test_a_token_whose_heartbeats_stop_stays_while_its_writer_lives(pair):
    # a busy process whose Python falls silent sends no heartbeats; the middleware still
    # asserts its token's writer, so it is not taken for lost (issue 20, no false alarm)
    a, b = pair
    events: list[tuple[str, bool]] = []
    b.watch_liveliness("alive/*", lambda k, alive: events.append((k, alive)))
    token = a.declare_token("alive/left")
    watch = b._watches[0]
    assert wait_for(lambda: "alive/left" in watch.beats, 10.0, b.flush)  # heartbeats heard
    a._timer.cancel()  # its heartbeats stop
    assert wait_for(lambda: "alive/left" not in watch.beats, 10.0, b.flush)  # and lapsed
    b.flush()
    assert events == [("alive/left", True)] and b.alive("alive/*") == ["alive/left"]
    token.undeclare()  # its writer goes: now both witnesses agree
    assert wait_for(lambda: events[-1] == ("alive/left", False), 10.0, b.flush)


def test_liveliness_holders_name_the_tokens_of_other_transports(pair):
    # what `ros2 arm` and `ros2 cell` ask before they declare their token (K08, K09)
    a, b = pair
    assert b.liveliness_holders("alive/left", timeout=0.0) == []
    token = a.declare_token("alive/left")
    assert wait_for(lambda: b.liveliness_holders("alive/*", timeout=0.0) == ["alive/left"], 10.0)
    assert b.liveliness_holders("alive/left") == ["alive/left"]
    assert b.liveliness_holders("alive/right", timeout=0.0) == []
    assert a.liveliness_holders("alive/left", timeout=0.0) == []  # not its own
    token.undeclare()
    assert wait_for(lambda: b.liveliness_holders("alive/*", timeout=0.0) == [], 10.0)


def test_r2p4_a_heartbeat_that_claims_an_hour_holds_a_key_for_one_lease(
    domain_id: int, cell_name: str
):
    from std_msgs.msg import String

    prefix = f"flexhrc/{cell_name}"
    with Ros2Transport(prefix=prefix, domain_id=domain_id) as manager:
        events: list[tuple[str, bool]] = []
        manager.watch_liveliness("alive/*", lambda k, alive: events.append((k, alive)))
        ctx, node, _ = _plain_node(domain_id, "spoof")
        try:
            pub = node.create_publisher(String, f"/{prefix}/liveliness", 10)  # type: ignore[attr-defined]
            assert wait_for(lambda: pub.get_subscription_count() >= 1, 10.0)
            pub.publish(String(data='{"key": "alive/right", "alive": true, "lease_s": 3500}'))
            assert wait_for(lambda: ("alive/right", True) in events, 10.0, manager.flush)
            # one heartbeat and silence: gone after the manager's lease (1 s), not 3500 s
            assert wait_for(lambda: ("alive/right", False) in events, 30.0, manager.flush)
        finally:
            node.destroy_node()  # type: ignore[attr-defined]
            ctx.try_shutdown()  # type: ignore[attr-defined]
        assert events == [("alive/right", True), ("alive/right", False)]


@pytest.mark.parametrize("value", ["soon", "-1", "nan", "1e9"])
def test_a_bad_discovery_time_from_the_environment_is_one_error_naming_it(
    value: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("FLEXHRC_ROS2_DISCOVERY_S", value)
    with pytest.raises(Ros2TransportError, match="FLEXHRC_ROS2_DISCOVERY_S="):
        Ros2Transport(prefix="flexhrc/disc")


def test_the_discovery_time_comes_from_the_environment_unless_given(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("FLEXHRC_ROS2_DISCOVERY_S", "12.5")
    with Ros2Transport(prefix="flexhrc/disc") as bus:
        assert bus.discovery_s == 12.5
    with Ros2Transport(prefix="flexhrc/disc", discovery_s=0.5) as bus:
        assert bus.discovery_s == 0.5
    monkeypatch.delenv("FLEXHRC_ROS2_DISCOVERY_S")
    with Ros2Transport(prefix="flexhrc/disc") as bus:
        assert bus.discovery_s == 3.0
