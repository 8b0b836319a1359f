"""A :class:`~flexhrc.transport.Transport` over ROS 2 topics (``std_msgs/String``, JSON payloads).

The cell's components talk through :class:`~flexhrc.transport.Transport` only; this
implementation carries the same JSON payloads as the Zenoh transport
(:mod:`flexhrc.transport.zenoh`) on ROS 2 topics, so the cell's manager loop and its agents run
unchanged as ROS 2 nodes, and any ROS 2 program (``ros2 topic echo``, an ``rclpy`` or ``rclcpp``
node) can watch and drive a cell. The API mirrors :class:`~flexhrc.transport.zenoh.ZenohTransport`
method for method, so code written for one runs on the other:

* ``Ros2Transport(prefix="flexhrc/cell1", ...)``: topic ``cmd/left`` is the ROS 2 topic
  ``/flexhrc/cell1/cmd/left`` (type ``std_msgs/msg/String``; ``data`` holds compact JSON);
* ``deliver="flush"`` (default): payloads received on the ROS executor thread are queued and
  handed to the callbacks inside :meth:`Ros2Transport.flush`, on the caller's thread, in arrival
  order (:meth:`Ros2Transport.wait` blocks until something is queued); ``deliver="thread"`` calls
  the callbacks on the executor thread at once;
* :meth:`Ros2Transport.declare_token` / :meth:`Ros2Transport.watch_liveliness`: liveliness
  tokens. ROS 2 has no liveliness tokens of Zenoh's kind, but DDS has liveliness QoS: a token
  ``KEY`` is a DDS writer of its own on ``/<prefix>/liveliness/KEY`` (``LivelinessPolicy.
  AUTOMATIC``, ``liveliness_lease_duration`` = ``lease_s``, 1 s by default). The middleware
  asserts it (a busy Python process stays alive), withdrawing the token destroys the writer,
  and a process killed with SIGKILL stops asserting it: a watcher finds the token topics in
  the ROS graph, reads each with the same lease and counts its writers alive from the
  subscription's liveliness-changed events (``QoSLivelinessChangedInfo.alive_count``). No
  message of another process can withdraw a writer that is not its own (R2P2). Beside it, for
  ROS 2 tools and clients of plain rclpy, the declaring transport keeps publishing heartbeats
  ``{"key": KEY, "alive": true, "lease_s": L}`` every ``heartbeat_s`` on ``/<prefix>/liveliness``
  and ``{"alive": false}`` when it withdraws. A watcher takes a key's heartbeats only from the
  DDS writer that began them (the message info's ``publisher_gid``) until they stop — a goodbye
  from any other writer is ignored and logged — and declares them stopped after ``lease_s``
  of silence. A token is there while its writer is alive or its heartbeats come, and goes
  once both say so. A watcher judges heartbeats only by what it had the chance to hear: every
  tick it also sends a beat of its own (``origin``, ``sent``; a ``probe`` when it holds no
  token) and takes heartbeats as stopped only when one of its own beats sent after their
  deadline has come back — so a process starved of CPU never takes its peers for dead;
  :meth:`Ros2Transport.liveliness_holders` names the tokens of other transports alive now
  (the cell's one-holder rule for an agent's name and a cell's manager, K08/K09);
* a payload that is not strict JSON is dropped and logged, counted in ``dropped``, and handed to
  ``on_drop(topic, data, error)``; it never reaches a callback.

Discovery: DDS matches a new publisher to existing subscribers asynchronously (milliseconds on
one host), and a message published before the match is lost. :meth:`publish` therefore waits —
at most ``match_timeout_s`` — until every subscriber the ROS graph already knows for that topic
is matched, so a command sent right after an agent announced itself reaches it. It waits again
only when more subscribers are known than at its last wait: one that died unannounced (DDS keeps
it in the graph until its lease ends) costs one wait, not one per message.

QoS: reliable, volatile, keep-last ``depth`` (100) — compatible with a ROS 2 tool's defaults
(``ros2 topic pub``, a default ``create_subscription``). Needs the ``ros2`` extra; importing this
module without ``rclpy`` raises :class:`~flexhrc.errors.OptionalDependencyError`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import re
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from typing import Any, Literal

from flexhrc.errors import FlexhrcError
from flexhrc.ros2._deps import require
from flexhrc.transport.base import Callback, Subscription, Transport
from flexhrc.transport.delivery import DropCallback, QueuedDelivery

rclpy = require("rclpy")
_String = require("std_msgs.msg", "the ROS 2 bridge").String
_qos = require("rclpy.qos")
_executors = require("rclpy.executors")
_signals = require("rclpy.signals")
_Duration = require("rclpy.duration").Duration
_events = require("rclpy.event_handler")

__all__ = [
    "LIVELINESS_TOPIC",
    "Ros2Transport",
    "Ros2TransportError",
    "check_exposure",
    "domain_id_from_env",
    "json_decode",
    "json_encode",
    "key_matches",
    "ros_topic",
]

log = logging.getLogger("flexhrc.ros2.transport")

LIVELINESS_TOPIC = "liveliness"
LivelinessCallback = Callable[[str, bool], None]

_TOKEN = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class Ros2TransportError(FlexhrcError):
    """A ROS 2 transport that cannot be set up or used: a bad topic name, a closed transport."""


#: How long a node looks for another holder of its name at start-up, by default (s).
DISCOVERY_S = 3.0
DISCOVERY_ENV = "FLEXHRC_ROS2_DISCOVERY_S"


def _discovery_from_env() -> float:
    """``FLEXHRC_ROS2_DISCOVERY_S``, or :data:`DISCOVERY_S`: DDS has no "discovery finished",
    so a name is taken as free after this long without a holder; a loaded host where DDS takes
    longer to show a running node needs more (one error naming the variable otherwise)."""
    text = os.environ.get(DISCOVERY_ENV, "").strip()
    if not text:
        return DISCOVERY_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and 0 <= value < 3600):
        raise Ros2TransportError(
            f"{DISCOVERY_ENV}={text!r:.40}: give the seconds to look for a name's holder, "
            "a number in [0, 3600)"
        )
    return value


def json_encode(payload: Any) -> str:
    """Compact JSON; NaN and infinity are refused (they are not JSON)."""
    return json.dumps(payload, separators=(",", ":"), allow_nan=False)


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def json_decode(data: str) -> Any:
    """Inverse of :func:`json_encode`; raises ``ValueError`` on anything that is not strict JSON."""
    return json.loads(data, parse_constant=_refuse_constant)


def ros_topic(prefix: str, topic: str) -> str:
    """The absolute ROS 2 topic name of ``topic`` under ``prefix``: ``("flexhrc/c1", "ack")`` ->
    ``"/flexhrc/c1/ack"``. Every ``/``-separated part must be a ROS name token (letters, digits,
    underscores; not starting with a digit); a bad name raises :class:`Ros2TransportError`."""
    if not isinstance(topic, str) or not topic.strip("/"):
        raise Ros2TransportError(f"topic must be a non-empty string, not {topic!r}")
    parts = [p for p in prefix.strip("/").split("/") if p] + topic.strip("/").split("/")
    for part in parts:
        if not _TOKEN.match(part):
            raise Ros2TransportError(
                f"topic {topic!r} (prefix {prefix!r}): {part!r} is not a valid ROS 2 name part "
                "(letters, digits and '_', not starting with a digit)"
            )
    return "/" + "/".join(parts)


def key_matches(pattern: str, key: str) -> bool:
    """Zenoh-style key expression match: ``*`` is one chunk, ``**`` any number of chunks."""
    return _match(pattern.strip("/").split("/"), key.strip("/").split("/"))


def _match(pat: list[str], key: list[str]) -> bool:
    if not pat:
        return not key
    head, rest = pat[0], pat[1:]
    if head == "**":
        return any(_match(rest, key[i:]) for i in range(len(key) + 1))
    if not key:
        return False
    return (head == "*" or head == key[0]) and _match(rest, key[1:])


def domain_id_from_env(value: str | int | None = None) -> int:
    """The ROS domain id: ``value`` when given, else ``$ROS_DOMAIN_ID``, else 0. Must be 0..232
    (the range DDS maps onto UDP ports)."""
    raw: str | int | None = value if value is not None else os.environ.get("ROS_DOMAIN_ID")
    if raw is None or raw == "":
        return 0
    try:
        n = int(raw)
    except (TypeError, ValueError):
        raise Ros2TransportError(f"ROS domain id must be an integer 0..232, not {raw!r}") from None
    if not 0 <= n <= 232:
        raise Ros2TransportError(f"ROS domain id must be in 0..232, got {n}")
    return n


def check_exposure(environ: Mapping[str, str] | None = None) -> None:
    """Refuse a ROS 2 node of a cell that other hosts' nodes can reach unauthenticated — the
    rule of a Zenoh cell's ``--listen`` (``docs/cell.md``, "Securing a cell"). DDS discovery
    stays on this host with ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (or ``OFF``; or, unset,
    the older ``ROS_LOCALHOST_ONLY=1``) and no ``ROS_STATIC_PEERS`` beyond loopback; else SROS2
    must be enforced (``ROS_SECURITY_ENABLE=true``, ``ROS_SECURITY_STRATEGY=Enforce``): signed,
    encrypted traffic and per-topic permissions. Raises one :class:`Ros2TransportError`."""
    env = os.environ if environ is None else environ
    if env.get("ROS_SECURITY_ENABLE", "").lower() == "true" and (
        env.get("ROS_SECURITY_STRATEGY") == "Enforce"
    ):
        return
    scope = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    local = scope in ("LOCALHOST", "OFF") or (
        scope in ("", "SYSTEM_DEFAULT") and env.get("ROS_LOCALHOST_ONLY") == "1"
    )
    peers = [p.strip() for p in env.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    remote = [p for p in peers if p not in ("localhost", "::1") and not p.startswith("127.")]
    if local and not remote:
        return
    if local:
        why = f"ROS_STATIC_PEERS names {remote[0]}"
    elif scope:
        why = f"ROS_AUTOMATIC_DISCOVERY_RANGE={scope}"
    else:
        why = "ROS_AUTOMATIC_DISCOVERY_RANGE is unset: SUBNET, ROS 2's default"
    raise Ros2TransportError(
        f"ROS 2 discovery reaches other hosts ({why}) and SROS2 is not enforced: any node "
        "there could drive the cell; on one host export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, "
        "across hosts enforce SROS2 (ROS_SECURITY_ENABLE=true, ROS_SECURITY_STRATEGY=Enforce, "
        'ROS_SECURITY_KEYSTORE; docs/cell.md, "Securing a cell")'
    )


class _Token:
    """A declared liveliness token; ``undeclare()`` withdraws it (idempotent). ``publisher``:
    the DDS writer whose liveliness is the token's (:meth:`Ros2Transport.declare_token`)."""

    def __init__(self, key: str, owner: Ros2Transport, publisher: Any) -> None:
        self.key = key
        self._owner = owner
        self.publisher = publisher
        self.active = True

    def undeclare(self) -> None:
        if self.active:
            self.active = False
            self._owner._withdraw(self)


class _Watch:
    def __init__(self, pattern: str, sub: Subscription, history: bool, started: float) -> None:
        self.pattern = pattern
        self.sub = sub
        self.history = history
        self.started = started
        self.alive: set[str] = set()  # the keys reported alive
        self.beats: dict[str, float] = {}  # key -> deadline of its heartbeats (monotonic)
        self.holder: dict[str, bytes] = {}  # key -> the DDS writer whose heartbeats hold it
        self.silent: set[str] = set()  # alive before the watch began, history=False


class Ros2Transport(QueuedDelivery, Transport):
    """Publish/subscribe over ROS 2 topics (see the module docstring for the full API)."""

    def __init__(
        self,
        *,
        prefix: str = "",
        node_name: str | None = None,
        domain_id: int | str | None = None,
        encode: Callable[[Any], str] = json_encode,
        decode: Callable[[str], Any] = json_decode,
        deliver: Literal["flush", "thread"] = "flush",
        on_drop: DropCallback | None = None,
        lease_s: float = 1.0,
        heartbeat_s: float = 0.1,
        match_timeout_s: float = 2.0,
        depth: int = 100,
        discovery_s: float | None = None,
    ) -> None:
        if discovery_s is None:  # a host busier than DDS's usual 2 s may give it longer
            discovery_s = _discovery_from_env()
        if deliver not in ("flush", "thread"):
            raise ValueError(f"deliver must be 'flush' or 'thread', not {deliver!r}")
        for name, value in (("lease_s", lease_s), ("heartbeat_s", heartbeat_s)):
            if not (isinstance(value, int | float) and 0 < value < 3600):
                raise Ros2TransportError(
                    f"{name} must be a positive number of seconds, not {value!r}"
                )
        if heartbeat_s >= lease_s:
            raise Ros2TransportError(
                f"heartbeat_s ({heartbeat_s}) must be shorter than lease_s ({lease_s})"
            )
        if not (isinstance(match_timeout_s, int | float) and 0 <= match_timeout_s < 3600):
            raise Ros2TransportError(f"match_timeout_s must be >= 0, not {match_timeout_s!r}")
        if not (isinstance(discovery_s, int | float) and 0 <= discovery_s < 3600):
            raise Ros2TransportError(f"discovery_s must be >= 0, not {discovery_s!r}")
        if not (isinstance(depth, int) and 1 <= depth <= 100_000):
            raise Ros2TransportError(f"depth must be an integer 1..100000, not {depth!r}")
        self.prefix = ros_topic("", prefix).lstrip("/") if prefix.strip("/") else ""
        self.encode = encode
        self.decode = decode
        self._init_delivery(deliver, on_drop, log)
        self.lease_s = float(lease_s)
        self.heartbeat_s = float(heartbeat_s)
        self.match_timeout_s = float(match_timeout_s)
        self.discovery_s = float(discovery_s)
        self.published = 0
        self.domain_id = domain_id_from_env(domain_id)
        self._qos = _qos.QoSProfile(
            depth=depth,
            reliability=_qos.ReliabilityPolicy.RELIABLE,
            durability=_qos.DurabilityPolicy.VOLATILE,
            history=_qos.HistoryPolicy.KEEP_LAST,
        )
        self.context = rclpy.Context()
        rclpy.init(
            context=self.context,
            domain_id=self.domain_id,
            signal_handler_options=_signals.SignalHandlerOptions.NO,
        )
        name = node_name or f"flexhrc_{uuid.uuid4().hex[:10]}"
        if not _TOKEN.match(name):
            self.context.shutdown()
            raise Ros2TransportError(f"node name {name!r} is not a valid ROS 2 node name")
        self.node = rclpy.create_node(
            name, context=self.context, start_parameter_services=False, enable_rosout=False
        )
        self._lock = threading.RLock()
        self._publishers: dict[str, Any] = {}
        self._typed: dict[str, Any] = {}  # ROS name -> a publisher of a standard message
        self._waited: dict[str, int] = {}  # ROS name -> subscribers known at the last wait
        self._rsubs: dict[int, Any] = {}
        self._tokens: list[_Token] = []
        self._watches: list[_Watch] = []
        self._closed = False
        self._origin = uuid.uuid4().hex  # tells this transport's own beats from the others'
        self._heard_own = time.monotonic()  # when the latest own beat that came back was sent
        # a token's own DDS writer: the middleware (not this process's Python) asserts its
        # liveliness, and a watcher's reader declares it gone after ``lease_s`` of silence —
        # a busy process stays alive, a killed one goes, and no other process can withdraw it
        self._token_qos = _qos.QoSProfile(
            depth=1,
            reliability=_qos.ReliabilityPolicy.RELIABLE,
            durability=_qos.DurabilityPolicy.VOLATILE,
            history=_qos.HistoryPolicy.KEEP_LAST,
            liveliness=_qos.LivelinessPolicy.AUTOMATIC,
            liveliness_lease_duration=_Duration(seconds=self.lease_s),
        )
        self._writers: dict[str, Any] = {}  # key -> the readers of its token topic
        self._writers_alive: dict[str, int] = {}  # key -> its token writers alive (DDS)
        self._queries: list[str] = []  # key expressions :meth:`liveliness_holders` asks about
        self._beating: dict[str, float] = {}  # key -> latest heartbeat of another transport
        self._live_topic = ros_topic(self.prefix, LIVELINESS_TOPIC)
        self._token_root = self._live_topic + "/"
        self._live_pub = self.node.create_publisher(_String, self._live_topic, self._qos)
        self._live_sub = self.node.create_subscription(
            _String, self._live_topic, self._on_liveliness_info, self._qos
        )
        self._timer = self.node.create_timer(self.heartbeat_s, self._tick)
        self._executor = _executors.SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=f"ros2-{name}", daemon=True)
        self._thread.start()

    # -- names ------------------------------------------------------------------------------
    def ros_name(self, topic: str) -> str:
        """The ROS 2 topic that carries ``topic`` (an absolute name, ``/...``, is kept as is)."""
        if topic.startswith("/"):
            return ros_topic("", topic)
        return ros_topic(self.prefix, topic)

    # -- spinning ---------------------------------------------------------------------------
    def _spin(self) -> None:
        while not self._closed:
            try:
                self._executor.spin_once(timeout_sec=0.05)
            except Exception as exc:
                if self._closed or not self.context.ok():
                    return
                log.exception("ROS 2 executor: %s", exc)

    # -- publish ----------------------------------------------------------------------------
    def publish(self, topic: str, payload: Any) -> None:
        self._send(topic, self.encode(payload))

    def publish_bytes(self, topic: str, data: bytes) -> None:
        """Send ``data`` as is (decoded as UTF-8 with replacement: ROS strings are text) — for
        custom codecs and for tests of malformed input."""
        self._send(topic, bytes(data).decode("utf-8", errors="replace"))

    def _publisher(self, name: str) -> Any:
        with self._lock:
            pub = self._publishers.get(name)
            if pub is None:
                pub = self.node.create_publisher(_String, name, self._qos)
                self._publishers[name] = pub
            return pub

    def _send(self, topic: str, text: str) -> None:
        self._check_open()
        name = self.ros_name(topic)
        pub = self._publisher(name)
        self._await_subscribers(topic, name, pub)
        msg = _String()
        msg.data = text
        with self._lock:
            self.published += 1
        pub.publish(msg)

    def _await_subscribers(self, topic: str, name: str, pub: Any) -> None:
        # wait for discovered-but-unmatched subscribers only when there are more of them than
        # at the last wait: a subscriber that died (DDS forgets it only after its lease) then
        # costs one wait, not one per message
        known = self.node.count_subscribers(name)
        if known > pub.get_subscription_count() and known > self._waited.get(name, -1):
            self.wait_matched(topic, timeout=self.match_timeout_s, _pub=pub)
            self._waited[name] = self.node.count_subscribers(name)

    def publish_message(self, publisher: Any, message: Any) -> None:
        """Publish a standard message on a publisher of :meth:`create_publisher`, first waiting
        (as :meth:`publish` does) for the subscribers the ROS graph already knows to match — for
        a message sent once, such as a command's trajectory or a ``DELETE`` marker."""
        self._check_open()
        name = publisher.topic_name
        self._await_subscribers(name, name, publisher)
        publisher.publish(message)

    def wait_matched(
        self, topic: str, minimum: int = 0, timeout: float = 2.0, _pub: Any = None
    ) -> bool:
        """Wait until this transport's publisher of ``topic`` (its JSON one, or the typed one
        :meth:`create_publisher` made) is matched with every subscriber
        the ROS graph knows for it, and with at least ``minimum`` of them; returns whether that
        happened within ``timeout`` seconds."""
        if _pub is None:
            name = self.ros_name(topic)
            _pub = self._typed.get(name) or self._publisher(name)
        pub = _pub
        name = pub.topic_name
        deadline = time.monotonic() + timeout
        while True:
            matched = pub.get_subscription_count()
            known = self.node.count_subscribers(name)
            if matched >= max(known, minimum):
                return True
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.002)

    # -- subscribe --------------------------------------------------------------------------
    def subscribe(self, topic: str, callback: Callback, *, raw: bool = False) -> Subscription:
        """Deliver every later payload of ``topic`` to ``callback`` (decoded unless ``raw``,
        when it gets the UTF-8 bytes)."""
        self._check_open()
        name = self.ros_name(topic)
        sub = Subscription(topic, callback, self)

        def on_msg(msg: Any) -> None:
            text = msg.data
            if raw:
                self._hand(sub, text.encode("utf-8"))
                return
            try:
                payload = self.decode(text)
            except Exception as exc:
                self._drop(topic, text.encode("utf-8", errors="replace"), exc)
                return
            self._hand(sub, payload)

        rsub = self.node.create_subscription(_String, name, on_msg, self._qos)
        with self._lock:
            self._rsubs[id(sub)] = rsub
        return sub

    def unsubscribe(self, subscription: Subscription) -> None:
        subscription.active = False
        with self._lock:
            rsub = self._rsubs.pop(id(subscription), None)
            self._watches = [w for w in self._watches if w.sub is not subscription]
        if rsub is not None and not self._closed:
            with contextlib.suppress(Exception):
                self.node.destroy_subscription(rsub)

    # -- liveliness -------------------------------------------------------------------------
    def declare_token(self, key: str) -> _Token:
        """Declare a liveliness token at ``key`` (under the prefix); withdraw with
        ``undeclare()``. Heartbeats start at the next tick (within ``heartbeat_s``)."""
        self._check_open()
        ros_topic(self.prefix, key)  # same name rules as topics
        key = key.strip("/")
        publisher = self.node.create_publisher(_String, self._token_root + key, self._token_qos)
        token = _Token(key, self, publisher)
        with self._lock:
            self._tokens.append(token)
        # the first heartbeat goes at the next tick (<= heartbeat_s), not now: subscriptions a
        # component creates right after its token are then announced to the others first, so
        # whoever reacts to the token finds them (a message sent before the match is lost)
        return token

    def watch_liveliness(
        self, key_expr: str, callback: LivelinessCallback, *, history: bool = True
    ) -> Subscription:
        """Call ``callback(key, alive)`` when a token matching ``key_expr`` (``*``, ``**``
        wildcards) appears or goes. With ``history`` (default) the tokens already alive are
        reported too (at their next heartbeat); without it, tokens heard within the first lease
        after the call are taken as already there and not reported."""
        self._check_open()

        def relay(event: tuple[str, bool]) -> None:
            callback(*event)

        sub = Subscription(key_expr, relay, self)
        with self._lock:
            self._watches.append(_Watch(key_expr.strip("/"), sub, history, time.monotonic()))
        return sub

    def _withdraw(self, token: _Token) -> None:
        with self._lock:
            if token in self._tokens:
                self._tokens.remove(token)
        if not self._closed:
            self._beat(token.key, False)
            with contextlib.suppress(Exception):  # its watchers see the writer go at once
                self.node.destroy_publisher(token.publisher)

    def _beat(self, key: str, alive: bool, *, probe: bool = False) -> None:
        msg = _String()
        body = {"key": key, "alive": alive, "lease_s": self.lease_s}
        body.update(origin=self._origin, sent=time.monotonic())
        if probe:
            body["probe"] = True
        msg.data = json_encode(body)
        with contextlib.suppress(Exception):
            self._live_pub.publish(msg)

    def _tick(self) -> None:
        with self._lock:
            keys = [t.key for t in self._tokens if t.active]
            watching = bool(self._watches)
        for key in keys:
            self._beat(key, True)
        if not keys:
            self._beat("", True, probe=True)
        if watching:
            self._discover_tokens()
        now = time.monotonic()
        # only what this transport had the chance to hear counts: a deadline is past only once
        # an own beat sent after it came back (or, should own beats never come back, after 5
        # leases)
        heard = self._heard_own if now - self._heard_own < 5 * self.lease_s else now
        events: list[tuple[_Watch, str, bool]] = []
        with self._lock:
            for w in self._watches:
                for key, deadline in list(w.beats.items()):
                    if now > deadline and heard > deadline:
                        del w.beats[key]
                        w.holder.pop(key, None)
                        events.extend(self._settle(w, key, now))
        self._report(events)

    def _discover_tokens(self) -> None:
        """Read the tokens' DDS writers of every watched key: the ROS graph names their topics
        (``/<prefix>/liveliness/<key>``), and a reader with the cell's lease counts the alive
        ones (:meth:`_on_writers`)."""
        for name, _types in self.node.get_topic_names_and_types():
            if not name.startswith(self._token_root):
                continue
            key = name[len(self._token_root) :]
            with self._lock:
                patterns = [w.pattern for w in self._watches] + self._queries
                if key in self._writers or not any(key_matches(p, key) for p in patterns):
                    continue
                self._writers[key] = None  # claimed: created once
            callbacks = _events.SubscriptionEventCallbacks(
                liveliness=lambda info, key=key: self._on_writers(key, info),
                incompatible_qos=lambda info, key=key: log.warning(
                    "liveliness token %s: its writer's lease is longer than this node's "
                    "lease_s (%s s): it is not watched",
                    key,
                    self.lease_s,
                ),
            )
            reader = self.node.create_subscription(
                _String, name, lambda msg: None, self._token_qos, event_callbacks=callbacks
            )
            with self._lock:
                self._writers[key] = reader

    def _on_writers(self, key: str, info: Any) -> None:
        # the middleware's own count of this key's writers alive: a token is there while one
        # of them is; no message of another process changes it
        now = time.monotonic()
        events: list[tuple[_Watch, str, bool]] = []
        with self._lock:
            self._writers_alive[key] = int(info.alive_count)
            for w in self._watches:
                if key_matches(w.pattern, key):
                    events.extend(self._settle(w, key, now))
        self._report(events)

    def _settle(self, w: _Watch, key: str, now: float) -> list[tuple[_Watch, str, bool]]:
        """Bring ``w``'s view of ``key`` in line with its two witnesses — the token's DDS
        writers and its heartbeats — and return the event to report, if any. A token appears
        when either witness has it and goes only when both agree it went (call with the
        lock held)."""
        live = key in w.beats or self._writers_alive.get(key, 0) > 0
        if live and key not in w.alive:
            w.alive.add(key)
            if not w.history and now - w.started < self.lease_s:
                w.silent.add(key)
                return []
            return [(w, key, True)]
        if not live and key in w.alive:
            w.alive.discard(key)
            if key in w.silent:
                w.silent.discard(key)
                return []
            return [(w, key, False)]
        return []

    def _report(self, events: list[tuple[_Watch, str, bool]]) -> None:
        for w, key, state in events:
            self._hand(w.sub, (key, state))

    def _on_liveliness_info(self, msg: Any, info: Any) -> None:
        # two parameters: rclpy then hands the message's info (its writer's id) too
        self._on_liveliness(msg, info)

    def _on_liveliness(self, msg: Any, info: Any = None) -> None:
        try:
            data = json_decode(msg.data)
            key = str(data["key"])
            alive = bool(data["alive"])
            lease = float(data.get("lease_s", self.lease_s))
            if not 0 < lease < 3600:
                raise ValueError(f"lease_s {lease} out of range")
            own = data.get("origin") == self._origin
            sent = float(data["sent"]) if own else 0.0
        except Exception as exc:
            self._drop(LIVELINESS_TOPIC, msg.data.encode("utf-8", errors="replace"), exc)
            return
        if own:
            with self._lock:
                self._heard_own = max(self._heard_own, sent)
        if data.get("probe"):
            return
        if not own:
            with self._lock:
                if alive:
                    self._beating[key] = time.monotonic()
                else:
                    self._beating.pop(key, None)
        # who sent it: the DDS writer's id (each transport beats through one writer). A key's
        # heartbeats count from the writer that began them, until they stop or it withdraws
        # them; another writer's heartbeats or goodbyes for it are ignored (R2P2)
        gid = info.get("publisher_gid") if isinstance(info, dict) else None
        writer = bytes(gid["data"]) if isinstance(gid, dict) and "data" in gid else b""
        now = time.monotonic()
        events: list[tuple[_Watch, str, bool]] = []
        refused = False
        with self._lock:
            for w in self._watches:
                if not key_matches(w.pattern, key):
                    continue
                holder = w.holder.get(key)
                if holder is not None and holder != writer:
                    refused = refused or not alive
                    continue
                if alive:
                    # no longer than this watcher's lease, as a token writer's: a heartbeat
                    # that claims an hour holds a key for a lease, not an hour (R2P4)
                    w.beats[key] = now + min(lease, self.lease_s)
                    w.holder[key] = writer
                else:
                    w.beats.pop(key, None)
                    w.holder.pop(key, None)
                events.extend(self._settle(w, key, now))
        if refused:
            log.warning(
                "liveliness: a goodbye for %s from a node that does not hold it was ignored", key
            )
        self._report(events)

    def liveliness_holders(self, key_expr: str, timeout: float | None = None) -> list[str]:
        """The keys of the tokens of other transports matching ``key_expr`` alive now: a
        token whose DDS writer the middleware reports alive, or whose heartbeats came within
        the last lease. A process asks before it declares a token that must have one holder
        (an agent's name, a cell's manager): the first holder keeps it. DDS discovery has no
        end to wait for, so this looks for ``timeout`` seconds (``discovery_s``, 3 s, by
        default; less when a holder shows itself): under load DDS took up to 1.8 s here to
        show a node of the same host. A process killed less than a lease ago no longer
        counts (its writer is not asserted, its heartbeats stopped), though DDS lists it in
        the graph for a while."""
        self._check_open()
        pattern = key_expr.strip("/")
        with self._lock:
            self._queries.append(pattern)
        try:
            wait = self.discovery_s if timeout is None else timeout
            deadline = time.monotonic() + wait
            while True:
                self._discover_tokens()
                now = time.monotonic()
                with self._lock:
                    own = {t.key for t in self._tokens}
                    held = {k for k, n in self._writers_alive.items() if n > 0 and k not in own} | {
                        k for k, t in self._beating.items() if now - t < self.lease_s
                    }
                    keys = sorted(k for k in held if key_matches(pattern, k))
                if keys or now >= deadline:
                    return keys
                # a bounded look at the graph, at start only: DDS has no "discovery done"
                time.sleep(0.02)
        finally:
            with self._lock:
                self._queries.remove(pattern)

    def alive(self, key_expr: str = "**") -> list[str]:
        """Keys of the tokens currently alive and matching ``key_expr``, as seen by the
        watchers of this transport (a watch on it must exist)."""
        with self._lock:
            keys = {k for w in self._watches for k in w.alive if key_matches(key_expr, k)}
        return sorted(keys)

    # -- typed topics (for the bridge's standard messages) ----------------------------------
    def create_publisher(self, msg_type: Any, topic: str, qos: Any = None) -> Any:
        """A plain ROS 2 publisher of ``msg_type`` on ``topic`` (under the prefix unless it is
        absolute)."""
        self._check_open()
        name = self.ros_name(topic)
        pub = self.node.create_publisher(msg_type, name, qos or self._qos)
        with self._lock:
            self._typed.setdefault(name, pub)
        return pub

    def create_subscription(
        self, msg_type: Any, topic: str, callback: Callable[[Any], None], qos: Any = None
    ) -> Any:
        """A plain ROS 2 subscription; ``callback(msg)`` is queued like any payload
        (``deliver="flush"``: it runs inside :meth:`flush`)."""
        self._check_open()
        sub = Subscription(topic, callback, self)
        rsub = self.node.create_subscription(
            msg_type, self.ros_name(topic), lambda m: self._hand(sub, m), qos or self._qos
        )
        with self._lock:
            self._rsubs[id(sub)] = rsub
        return sub

    # -- lifetime ---------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise Ros2TransportError("the ROS 2 transport is closed")

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Withdraw tokens (watchers see them go at once), stop the executor, destroy the node
        and shut its ROS context down. Idempotent."""
        if self._closed:
            return
        with self._lock:
            tokens = list(self._tokens)
            self._tokens.clear()
        for token in tokens:
            token.active = False
            self._beat(token.key, False)
        # what was published last (an ack, the cell's end, the withdrawals, the last markers
        # with their DELETEs) must reach its subscribers before the participant goes: wait
        # until they acknowledged it, briefly
        with self._lock:
            pubs = [self._live_pub, *self._publishers.values(), *self._typed.values()]
        deadline = time.monotonic() + 1.0
        for pub in pubs:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            with contextlib.suppress(Exception):
                pub.wait_for_all_acked(_Duration(seconds=left))
        self._closed = True
        self._thread.join(timeout=2.0)
        try:
            self._executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        except Exception:
            pass
        with contextlib.suppress(Exception):
            self.context.try_shutdown()
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> Ros2Transport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
