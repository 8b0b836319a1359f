"""A :class:`~flexhrc.transport.Transport` over Zenoh, for components in several processes or hosts.

Zenoh is the publish/subscribe middleware ROS 2 itself offers (``rmw_zenoh``); here it carries the
same payloads the in-process bus carries, so a component written against
:class:`~flexhrc.transport.Transport` runs unchanged across processes. Needs the ``zenoh`` extra
(``pip install 'flexhrc[zenoh]'``); importing this module without it raises
:class:`~flexhrc.errors.OptionalDependencyError`.

Usage::

    from flexhrc.transport.zenoh import ZenohTransport, zenoh_config

    # the process others connect to: listens on a loopback port, no multicast scouting
    bus = ZenohTransport(zenoh_config(listen=["tcp/127.0.0.1:7447"]))
    # another process (or host) connects to it
    bus = ZenohTransport(zenoh_config(connect=["tcp/127.0.0.1:7447"]))

    sub = bus.subscribe("bn/left/state", print)       # topic = a Zenoh key expression
    bus.publish("bn/left/state", {"active": True})    # JSON-encoded on the wire
    bus.wait(1.0)                                     # block until something arrived...
    bus.flush()                                       # ...and deliver it on this thread

    token = bus.declare_token("flexhrc/cell/alive/left")           # liveliness
    bus.watch_liveliness("flexhrc/cell/alive/*", lambda key, alive: ...)

API (everything below is public and stable):

* :func:`zenoh_config` builds a ``zenoh.Config``: ``mode`` (``"peer"`` by default), ``listen``
  and ``connect`` endpoint lists (``tcp/HOST:PORT``; a bare ``HOST:PORT`` means TCP), multicast
  scouting **off** unless ``multicast=True``. A process that connects but does not listen still
  listens on ``tcp/127.0.0.1:0`` (a random loopback port) rather than Zenoh's default of every
  interface, so nothing is exposed beyond the host unless an endpoint says so.
  :func:`loopback_config` is the test helper: ``loopback_config(port)`` listens on
  ``127.0.0.1:port``, ``loopback_config(connect=port)`` connects to it. :func:`free_tcp_port`
  returns a free loopback port (kept for callers; flexhrc itself no longer uses it): a port
  picked, closed and bound again may be taken in between, so a listener binds port 0 itself and
  reports the port it got (:meth:`ZenohTransport.locators`; a child process writes it to its
  ready file, as ``flexhrc cell --ready-file`` and ``flexhrc behave --ready-file`` do).
  ``zenoh_config(..., adminspace=True)`` makes the admin space readable; it is on by default
  when a ``listen`` endpoint has port 0 (the system picks the port).
* ``zenoh_config(..., file=PATH)`` starts from a Zenoh configuration file (json5, Zenoh's own
  format, ``--zenoh-config``): TLS certificates, access control, anything Zenoh offers. The
  endpoints the options name replace the file's; flexhrc's own defaults (multicast scouting
  off, quick re-dial, the read-only admin space for a port-0 endpoint) fill only what the file
  leaves at Zenoh's default. :func:`load_zenoh_config` reads such a file with one clear error.
* :func:`check_exposure` refuses a configuration that listens on an address other hosts reach
  without TLS and mutual authentication (a ``tls/`` endpoint, the listener's certificate and
  key, the CA and ``enable_mtls: true``): such a cell would obey anyone on the network.
* :func:`open_zenoh` ``(listen, connect, *, prefix, warn, config_file)``: a transport on those
  endpoints, checked by :func:`check_exposure`; :func:`listening_on`: the endpoints as bound
  (what ``flexhrc cell --ready-file`` tells the agents).
* :class:`ZenohTransport` ``(config=None, *, session=None, prefix="", encode=json_encode,
  decode=json_decode, deliver="flush", on_drop=None)``.

  - ``deliver="flush"`` (default): payloads received by Zenoh's threads are queued and handed to
    the callbacks only inside :meth:`ZenohTransport.flush`, on the caller's thread, in arrival
    order — the same single-threaded discipline as the in-process bus, so sans-IO logic needs no
    locks. :meth:`ZenohTransport.wait` blocks until something is queued (or a timeout).
    ``deliver="thread"``: callbacks run at once on Zenoh's receive thread (lowest latency; the
    callbacks must be thread-safe); ``flush`` then returns 0.
  - ``encode(payload) -> bytes`` / ``decode(bytes) -> payload``: JSON by default
    (:func:`json_encode`, :func:`json_decode`; NaN and infinity are refused). ``NamedTuple``
    records serialise as JSON arrays, so pass a codec for them, e.g.
    ``encode=lambda m: json_encode(to_wire(m))``, ``decode=lambda b: from_wire(json_decode(b))``
    with :func:`flexhrc.behavior.messages.to_wire`.
  - A payload that cannot be decoded is *dropped*, never raised into Zenoh's thread: it is logged
    on the ``flexhrc.transport.zenoh`` logger, counted in :attr:`ZenohTransport.dropped`, and
    passed to ``on_drop(topic, data, error)`` when given.
  - ``prefix`` (e.g. ``"flexhrc/cell1"``) is prepended to every topic and token key and stripped
    from keys handed back, so two cells can share one Zenoh network.
  - :meth:`ZenohTransport.publish_bytes` sends raw bytes (no encoding) — for custom codecs and for
    tests of malformed input; ``subscribe(..., raw=True)`` hands the raw bytes to the callback.
  - :meth:`ZenohTransport.declare_token` declares a liveliness token (an object with
    ``undeclare()``); it disappears for every watcher when undeclared, when the transport is
    closed, or when the process dies (the TCP link drops: within milliseconds on one host, after
    the lease — 10 s by default — if a remote host vanishes without closing its link).
  - :meth:`ZenohTransport.liveliness_holders` lists the tokens matching a key expression that
    are alive now (a liveliness query): a cell's manager and each agent ask for their own key
    before declaring it, and are refused when another process holds it.
  - :meth:`ZenohTransport.subscribe_from` hands ``callback(payload, source)`` the id of the
    session that published each payload (every ``ZenohTransport`` stamps its puts with Zenoh's
    source info; :attr:`ZenohTransport.session_id` is its own): the sender's word, not a proof
    (only TLS with mutual authentication is).
  - :meth:`ZenohTransport.watch_liveliness` calls ``callback(key, alive)`` for tokens matching a
    key expression (wildcards allowed); with ``history=True`` (default) the tokens already alive
    are reported first. Returns a :class:`~flexhrc.transport.Subscription`.
  - :meth:`ZenohTransport.locators` lists the endpoints the session really listens on (the
    port a ``listen`` endpoint with port 0 got), read from the admin space.
  - Counters ``published``, ``delivered`` and ``dropped``; :meth:`close` releases the session
    (idempotent; also a context manager).

Topics are exact names as in the base contract; they must be valid Zenoh key expressions without
wildcards (``a/b/c``: no empty chunk, no leading or trailing ``/``, none of ``* $ ? #``).
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import math
import re
import socket
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

from flexhrc.errors import FlexhrcError, OptionalDependencyError
from flexhrc.transport.base import Callback, Subscription, Transport
from flexhrc.transport.delivery import DropCallback, QueuedDelivery

try:
    import zenoh as _zenoh
except ImportError as exc:  # pragma: no cover - exercised only without the extra
    raise OptionalDependencyError("the Zenoh transport", "zenoh", "eclipse-zenoh") from exc

__all__ = [
    "LivelinessCallback",
    "TransportError",
    "ZenohTransport",
    "check_exposure",
    "free_tcp_port",
    "json_decode",
    "json_encode",
    "listening_on",
    "load_zenoh_config",
    "loopback_config",
    "normalise_endpoint",
    "open_zenoh",
    "zenoh_config",
]

log = logging.getLogger("flexhrc.transport.zenoh")

LivelinessCallback = Callable[[str, bool], None]

_ENDPOINT = re.compile(r"^(?P<proto>tcp|udp|tls|quic|ws|unixsock-stream)/(?P<rest>.+)$")
_HOSTPORT = re.compile(r"^(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.\-]+):(?P<port>\d{1,5})$")
_BAD_TOPIC_CHARS = set("*$?#")


class TransportError(FlexhrcError):
    """A transport that cannot be set up: a malformed endpoint, a port in use, a closed session."""


def json_encode(payload: Any) -> bytes:
    """Compact UTF-8 JSON; NaN and infinity are refused (they are not JSON)."""
    return json.dumps(payload, separators=(",", ":"), allow_nan=False).encode()


def _refuse_constant(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):  # 1e999 is valid JSON text, but no number the store can keep
        raise ValueError(f"{text[:40]} is out of range for a number")
    return value


def json_decode(data: bytes) -> Any:
    """Inverse of :func:`json_encode`; raises ``ValueError`` on anything that is not strict JSON
    (NaN, Infinity, or a number such as 1e999 that overflows to infinity)."""
    return json.loads(
        data.decode("utf-8"), parse_constant=_refuse_constant, parse_float=_finite_float
    )


def normalise_endpoint(endpoint: str) -> str:
    """``tcp/HOST:PORT`` (and the other Zenoh link protocols) as given; a bare ``HOST:PORT`` gets
    ``tcp/``. Raises :class:`TransportError` naming the endpoint when it is malformed."""
    text = str(endpoint).strip()
    match = _ENDPOINT.match(text)
    rest = match.group("rest") if match else text
    proto = match.group("proto") if match else "tcp"
    if proto == "unixsock-stream":
        if not rest:
            raise TransportError(f"endpoint {endpoint!r}: no socket path")
        return f"{proto}/{rest}"
    hostport = _HOSTPORT.match(rest)
    if hostport is None:
        raise TransportError(
            f"endpoint {endpoint!r} is not of the form tcp/HOST:PORT (e.g. tcp/127.0.0.1:7447)"
        )
    port = int(hostport.group("port"))
    if port > 65535:
        raise TransportError(f"endpoint {endpoint!r}: port {port} is out of range 0..65535")
    return f"{proto}/{rest}"


def zenoh_config(
    *,
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    mode: Literal["peer", "client", "router"] = "peer",
    multicast: bool = False,
    adminspace: bool | None = None,
    file: str | Path | None = None,
) -> Any:
    """A ``zenoh.Config`` for flexhrc: explicit endpoints, multicast scouting off by default.

    A peer given no ``listen`` endpoint listens on ``tcp/127.0.0.1:0`` (a random loopback port,
    so other peers learned by gossip can reach it on this host) instead of every interface.
    ``adminspace`` (read-only) lets :meth:`ZenohTransport.locators` tell which port the system
    gave a ``listen`` endpoint with port 0; by default it is on exactly when one has port 0.

    ``file``: a Zenoh configuration file (``--zenoh-config``) to start from, taken as Zenoh
    reads it (:func:`load_zenoh_config`); ``mode`` and ``multicast`` are then the file's, a
    ``listen``/``connect`` given here replaces the file's endpoints, and flexhrc's defaults
    (no multicast, quick re-dial, the admin space for port 0) fill only the keys the file leaves
    at Zenoh's default.
    """
    if mode not in ("peer", "client", "router"):
        raise TransportError(f"zenoh mode must be peer, client or router, not {mode!r}")
    listen_eps = [normalise_endpoint(e) for e in listen]
    connect_eps = [normalise_endpoint(e) for e in connect]
    for given, ep in zip(connect, connect_eps, strict=True):
        if _port_of(ep) == 0:  # port 0 means "any port" to listen on; nothing listens on it
            raise TransportError(
                f"--connect {given}: port 0 is no port to connect to (give the port the cell "
                "listens on, e.g. tcp/127.0.0.1:7447)"
            )
    if file is not None:
        config = load_zenoh_config(file)
        if listen_eps:
            config.insert_json5("listen/endpoints", json.dumps(listen_eps))
        if connect_eps:
            config.insert_json5("connect/endpoints", json.dumps(connect_eps))
        defaults = _zenoh.Config()
        for key, value in _FLEXHRC_DEFAULTS.items():
            if config.get_json(key) == defaults.get_json(key):
                config.insert_json5(key, json.dumps(value))
        bound = _endpoints_of(config, "listen")
        if adminspace is None and config.get_json("adminspace/enabled") == "false":
            adminspace = any(_port_of(e) == 0 for e in bound)
    else:
        if adminspace is None:
            adminspace = any(_port_of(e) == 0 for e in listen_eps)
        if not listen_eps and mode != "client":
            listen_eps = ["tcp/127.0.0.1:0"]
        config = _zenoh.Config()
        config.insert_json5("mode", json.dumps(mode))
        config.insert_json5("scouting/multicast/enabled", json.dumps(bool(multicast)))
        config.insert_json5("listen/endpoints", json.dumps(listen_eps))
        config.insert_json5("connect/endpoints", json.dumps(connect_eps))
        for key, value in _FLEXHRC_DEFAULTS.items():
            config.insert_json5(key, json.dumps(value))
    if adminspace:
        admin = {"enabled": True, "permissions": {"read": True, "write": False}}
        config.insert_json5("adminspace", json.dumps(admin))
    return config


#: What flexhrc changes in Zenoh's defaults. Multicast scouting off: a cell is found only where
#: an endpoint says. Re-dial a lost or not-yet-started peer quickly (Zenoh's default backs off
#: to several seconds): agents started before the manager, or a manager restarted with
#: --resume, are found again within about a second.
_FLEXHRC_DEFAULTS: dict[str, Any] = {
    "scouting/multicast/enabled": False,
    "connect/retry": {"period_init_ms": 100, "period_max_ms": 1000, "period_increase_factor": 2},
}


def load_zenoh_config(path: str | Path) -> Any:
    """A Zenoh configuration file (json5, Zenoh's own format) as a ``zenoh.Config``; a file
    that is missing or that Zenoh refuses is one :class:`TransportError` naming
    ``--zenoh-config`` and the file."""
    p = Path(path)
    if not p.is_file():
        raise TransportError(f"--zenoh-config {p}: no such file")
    try:
        return _zenoh.Config.from_file(str(p))
    except Exception as exc:  # zenoh.ZError: a json5 syntax error, an unknown key...
        why = re.sub(r"\s+at\s+\S+\.rs:\d+\.?", "", str(exc)).strip()
        raise TransportError(f"--zenoh-config {p}: Zenoh refuses it: {why}") from None


def _endpoints_of(config: Any, which: str) -> list[str]:
    """The ``listen`` or ``connect`` endpoints of ``config`` for its mode (a mode-dependent
    value in a file is a dict by mode)."""
    value = json.loads(config.get_json(f"{which}/endpoints"))
    if isinstance(value, dict):
        mode = json.loads(config.get_json("mode")) or "peer"
        value = value.get(mode) or []
    return [str(e) for e in value or []]


def _is_loopback(endpoint: str) -> bool:
    """An endpoint only this host reaches: a Unix socket, ``localhost`` or a loopback IP."""
    proto, _, rest = endpoint.partition("/")
    if proto == "unixsock-stream":
        return True
    host = rest.split("#", 1)[0].split("?", 1)[0].rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:  # a host name: it may resolve to any interface
        return False


def check_exposure(config: Any, given: Sequence[str] = ()) -> None:
    """Refuse ``config`` when it listens where other hosts reach it without Zenoh's TLS with
    mutual authentication: a peer that can connect can publish anything into the cell (a
    ``stop``, an ``end``, an ack), so such a listener needs a ``tls/`` endpoint and a
    configuration (``--zenoh-config``) with the listener's certificate and key, the CA the
    peers' certificates are checked against and ``enable_mtls: true`` (``flexhrc certs DIR``
    writes one). Raises one :class:`TransportError` naming the endpoint — as ``--listen EP``
    when it is one of ``given`` (the option's), else as the config file's."""

    def tls(key: str) -> Any:
        return json.loads(config.get_json(f"transport/link/tls/{key}"))

    given_eps = {normalise_endpoint(e) for e in given}
    zenohs = config.get_json("listen/endpoints") == _zenoh.Config().get_json("listen/endpoints")
    for ep in _endpoints_of(config, "listen"):
        if _is_loopback(ep):
            continue
        if ep in given_eps:
            where = f"--listen {ep}"
        elif zenohs:
            where = (
                f"--zenoh-config: listen endpoint {ep} (Zenoh's default where the file names "
                "none: give listen: {endpoints: [...]})"
            )
        else:
            where = f"--zenoh-config: listen endpoint {ep}"
        if not ep.startswith("tls/"):
            raise TransportError(
                f"{where}: other hosts reach this address and a plain {ep.split('/')[0]}"
                " link lets any of them drive the cell; listen on a tls/ endpoint with a "
                "--zenoh-config that has certificates (`flexhrc certs DIR` writes them; "
                'docs/cell.md, "Securing a cell"), or on 127.0.0.1'
            )
        missing = [
            k
            for k in ("listen_certificate", "listen_private_key", "root_ca_certificate")
            if not tls(k)
        ]
        if missing or tls("enable_mtls") is not True:
            what = ", ".join(missing + ([] if tls("enable_mtls") is True else ["enable_mtls"]))
            raise TransportError(
                f"{where}: TLS without mutual authentication lets any host drive the "
                f"cell; the Zenoh config lacks transport.link.tls {what} (`flexhrc certs DIR` "
                'writes a config with all of them; docs/cell.md, "Securing a cell")'
            )


def open_zenoh(
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    *,
    prefix: str = "",
    warn: Callable[[str], None] | None = None,
    config_file: str | Path | None = None,
) -> ZenohTransport:
    """A :class:`ZenohTransport` (peer, no multicast, unless the ``config_file`` says
    otherwise) on these endpoints, its topics under ``prefix``. A configuration that listens
    where other hosts reach it without TLS and mutual authentication is refused
    (:func:`check_exposure`) before anything is opened. ``warn``: kept for callers that pass
    it; nothing is only warned of any more."""
    config = zenoh_config(listen=listen, connect=connect, file=config_file)
    check_exposure(config, given=listen)
    transport = ZenohTransport(config, prefix=prefix)
    transport.listen_endpoints = _endpoints_of(config, "listen")
    transport.dials = bool(connect)
    return transport


def listening_on(transport: ZenohTransport, configured: Sequence[str]) -> list[str]:
    """The endpoints ``transport`` listens on as bound (a port 0 resolved: what to tell the
    agents), else as ``configured``."""
    if any(normalise_endpoint(ep).endswith(":0") for ep in configured):
        return list(transport.locators())
    return list(configured)


def _port_of(endpoint: str) -> int | None:
    """The port of a normalised ``proto/HOST:PORT`` endpoint (None for a socket path)."""
    if endpoint.startswith("unixsock-stream/"):
        return None
    return int(endpoint.rsplit(":", 1)[1])


def loopback_config(port: int | None = None, *, connect: int | Sequence[int] = ()) -> Any:
    """Test helper: listen on ``127.0.0.1:port`` (when given) and/or connect to loopback ports."""
    ports = [connect] if isinstance(connect, int) else list(connect)
    return zenoh_config(
        listen=[f"tcp/127.0.0.1:{port}"] if port is not None else (),
        connect=[f"tcp/127.0.0.1:{p}" for p in ports],
    )


def free_tcp_port() -> int:
    """A TCP port free on 127.0.0.1 right now (the OS picks it).

    Only for a port this process binds at once: handed to another process, the port may be
    taken before that one binds it. A child process listens on port 0 instead and reports the
    port it got (``flexhrc cell --listen tcp/127.0.0.1:0 --ready-file PATH``,
    :meth:`ZenohTransport.locators`)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _check_topic(topic: str, *, wildcards: bool = False) -> str:
    if not isinstance(topic, str) or not topic:
        raise ValueError(f"topic must be a non-empty string, not {topic!r}")
    chunks = topic.split("/")
    if any(not c for c in chunks):
        raise ValueError(f"topic {topic!r}: empty chunk (leading, trailing or double '/')")
    if not wildcards and _BAD_TOPIC_CHARS & set(topic):
        raise ValueError(f"topic {topic!r}: '*', '$', '?' and '#' are not allowed in a topic")
    return topic


class _Token:
    """A declared liveliness token; ``undeclare()`` withdraws it (idempotent)."""

    def __init__(self, key: str, token: Any) -> None:
        self.key = key
        self._token = token
        self.active = True

    def undeclare(self) -> None:
        if self.active:
            self.active = False
            with contextlib.suppress(Exception):  # the session may already be closed
                self._token.undeclare()


class ZenohTransport(QueuedDelivery, Transport):
    """Publish/subscribe over a Zenoh session (see the module docstring for the full API)."""

    def __init__(
        self,
        config: Any = None,
        *,
        session: Any = None,
        prefix: str = "",
        encode: Callable[[Any], bytes] = json_encode,
        decode: Callable[[bytes], Any] = json_decode,
        deliver: Literal["flush", "thread"] = "flush",
        on_drop: DropCallback | None = None,
    ) -> None:
        if deliver not in ("flush", "thread"):
            raise ValueError(f"deliver must be 'flush' or 'thread', not {deliver!r}")
        self.prefix = _check_topic(prefix.strip("/")) if prefix.strip("/") else ""
        self.encode = encode
        self.decode = decode
        self._init_delivery(deliver, on_drop, log)
        self.published = 0
        self._owns_session = session is None
        if session is None:
            try:
                session = _zenoh.open(config if config is not None else zenoh_config())
            except Exception as exc:  # zenoh.ZError: port in use, bad locator...
                # Zenoh's messages name the Rust source files they come from: keep the words
                why = re.sub(r"\s+at\s+\S+\.rs:\d+\.?", "", str(exc)).strip()
                hint = (
                    " (another process listens there: choose another port)"
                    if "in use" in why.lower()
                    else ""
                )
                raise TransportError(f"cannot open a Zenoh session: {why}{hint}") from None
        self.session = session
        # the endpoints it was configured to listen on (set by open_zenoh; port 0 unresolved)
        self.listen_endpoints: list[str] = []
        self._publishers: dict[str, Any] = {}
        self._pub_ids: dict[str, Any] = {}
        self._zsubs: dict[int, Any] = {}
        self._tokens: list[_Token] = []
        self._lock = threading.Lock()
        self._closed = False
        self._sn = 0  # the sequence number of this session's source info
        self._zid: str | None = None
        #: the session dials endpoints (``connect``): a liveliness query first waits until it is
        #: connected, else it would ask no one (see :meth:`liveliness_holders`)
        self.dials = False

    # -- keys -------------------------------------------------------------------------------
    def _key(self, topic: str, *, wildcards: bool = False) -> str:
        _check_topic(topic, wildcards=wildcards)
        return f"{self.prefix}/{topic}" if self.prefix else topic

    def _unkey(self, key: str) -> str:
        if self.prefix and key.startswith(self.prefix + "/"):
            return key[len(self.prefix) + 1 :]
        return key

    # -- publish ----------------------------------------------------------------------------
    def publish(self, topic: str, payload: Any) -> None:
        self.publish_bytes(topic, self.encode(payload))

    def publish_bytes(self, topic: str, data: bytes) -> None:
        """Send ``data`` as is (no encoding) to the subscribers of ``topic``."""
        self._check_open()
        key = self._key(topic)
        with self._lock:
            pub = self._publishers.get(key)
            if pub is None:
                # express: no batching, so a command reaches its agent without waiting for more
                pub = self.session.declare_publisher(
                    key,
                    express=True,
                    congestion_control=_zenoh.CongestionControl.BLOCK,
                )
                self._publishers[key] = pub
                self._pub_ids[key] = pub.id  # made once: reading it builds a new object
            self.published += 1
            self._sn += 1
            sn = self._sn
        # the source info names this session (its zid) to every receiver: a cell binds an agent
        # name to the session that joined with it (see :meth:`subscribe_from`; ~1 us a put)
        pub.put(bytes(data), source_info=_zenoh.SourceInfo(self._pub_ids[key], sn))

    # -- subscribe --------------------------------------------------------------------------
    def subscribe(self, topic: str, callback: Callback, *, raw: bool = False) -> Subscription:
        """Deliver every later payload of ``topic`` to ``callback`` (decoded unless ``raw``)."""
        self._check_open()
        key = self._key(topic)
        sub = Subscription(topic, callback, self)

        def on_sample(sample: Any) -> None:
            data = sample.payload.to_bytes()
            if raw:
                self._hand(sub, data)
                return
            try:
                payload = self.decode(data)
            except Exception as exc:  # a bad payload must never reach Zenoh
                self._drop(topic, data, exc)
                return
            self._hand(sub, payload)

        zsub = self.session.declare_subscriber(key, on_sample)
        with self._lock:
            self._zsubs[id(sub)] = zsub
        return sub

    def subscribe_from(
        self, topic: str, callback: Callable[[Any, str | None], None]
    ) -> Subscription:
        """As :meth:`subscribe`, but ``callback(payload, source)`` also gets the id of the
        Zenoh session that published it (:attr:`session_id` of a ``ZenohTransport``; None for a
        sample without Zenoh's source info, e.g. from a peer that uses Zenoh directly).

        What it is worth: every ``ZenohTransport`` stamps its puts with its own session id,
        and Zenoh carries that stamp unchanged. The stamp is the sender's word, not a proof:
        zenoh-python cannot make another session's id, but a peer written against Zenoh's Rust
        or C API can claim any id it has seen. Only TLS with mutual authentication and access
        control tells who really sent a sample (docs/cell.md, "Securing a cell")."""
        self._check_open()
        key = self._key(topic)

        def relay(event: tuple[Any, str | None]) -> None:
            callback(*event)

        sub = Subscription(topic, relay, self)

        def on_sample(sample: Any) -> None:
            data = sample.payload.to_bytes()
            try:
                payload = self.decode(data)
            except Exception as exc:  # a bad payload must never reach Zenoh
                self._drop(topic, data, exc)
                return
            info = sample.source_info
            source = None if info is None else str(info.source_id.zid)
            self._hand(sub, (payload, source))

        zsub = self.session.declare_subscriber(key, on_sample)
        with self._lock:
            self._zsubs[id(sub)] = zsub
        return sub

    @property
    def session_id(self) -> str:
        """This transport's Zenoh session id (zid), the ``source`` its receivers see."""
        if self._zid is None:
            self._zid = str(self.session.zid())
        return self._zid

    def watch_liveliness(
        self, key_expr: str, callback: LivelinessCallback, *, history: bool = True
    ) -> Subscription:
        """Call ``callback(key, alive)`` whenever a token matching ``key_expr`` appears or goes."""
        self._check_open()
        kexpr = self._key(key_expr, wildcards=True)

        def relay(event: tuple[str, bool]) -> None:
            callback(*event)

        sub = Subscription(key_expr, relay, self)

        def on_sample(sample: Any) -> None:
            alive = sample.kind == _zenoh.SampleKind.PUT
            self._hand(sub, (self._unkey(str(sample.key_expr)), alive))

        zsub = self.session.liveliness().declare_subscriber(kexpr, on_sample, history=history)
        with self._lock:
            self._zsubs[id(sub)] = zsub
        return sub

    def declare_token(self, key: str) -> _Token:
        """Declare a liveliness token at ``key`` (under the prefix); withdraw with ``undeclare``."""
        self._check_open()
        full = self._key(key)
        token = _Token(key, self.session.liveliness().declare_token(full))
        self._tokens.append(token)
        return token

    def liveliness_holders(self, key_expr: str, timeout: float = 1.0) -> list[str]:
        """The keys of the tokens matching ``key_expr`` alive now (under the prefix, stripped
        as in :meth:`watch_liveliness`): a query to every connected session, answered within
        ``timeout`` seconds. A process asks before it declares a token that must have one
        holder (an agent's name, a cell's manager): the first holder keeps it. A session that
        dials (:attr:`dials`) first waits, up to ``timeout``, until it is connected to a peer
        or a router: under load the link may come up after the session opened."""
        self._check_open()
        kexpr = self._key(key_expr, wildcards=True)
        deadline = time.monotonic() + timeout
        while self.dials and not self._connected() and time.monotonic() < deadline:
            time.sleep(0.01)  # at start only: polls the link to come up, bounded by timeout
        try:
            replies = list(self.session.liveliness().get(kexpr, timeout=timeout))
        except Exception as exc:  # zenoh.ZError
            raise TransportError(f"cannot query the Zenoh liveliness tokens: {exc}") from None
        keys = []
        for reply in replies:
            ok = getattr(reply, "ok", None)
            if ok is not None:
                keys.append(self._unkey(str(ok.key_expr)))
        return sorted(set(keys))

    def _connected(self) -> bool:
        info = self.session.info
        return bool(list(info.peers_zid()) or list(info.routers_zid()))

    def unsubscribe(self, subscription: Subscription) -> None:
        with self._lock:
            zsub = self._zsubs.pop(id(subscription), None)
        subscription.active = False
        if zsub is not None:
            with contextlib.suppress(Exception):  # the session may already be closed
                zsub.undeclare()

    # -- where it listens ---------------------------------------------------------------------
    def locators(self, timeout: float = 2.0) -> list[str]:
        """The endpoints this session listens on, as the system bound them (a ``listen``
        endpoint with port 0 shows the port it got), e.g. ``["tcp/127.0.0.1:41327"]``.

        Read from Zenoh's admin space (``@/<zid>/<mode>``), which the config must enable
        (:func:`zenoh_config` does when a ``listen`` endpoint has port 0); raises
        :class:`TransportError` when it cannot be read."""
        self._check_open()
        zid = str(self.session.zid())
        try:
            replies = list(self.session.get(f"@/{zid}/**", timeout=timeout))
        except Exception as exc:  # zenoh.ZError
            raise TransportError(f"cannot read the Zenoh admin space: {exc}") from None
        for reply in replies:
            ok = getattr(reply, "ok", None)
            if ok is None:
                continue
            with contextlib.suppress(ValueError, TypeError):
                info = json.loads(ok.payload.to_bytes())
                if isinstance(info, dict) and isinstance(info.get("locators"), list):
                    return [str(loc) for loc in info["locators"]]
        raise TransportError(
            "the Zenoh admin space did not answer (enable it: zenoh_config(adminspace=True))"
        )

    # -- lifetime ---------------------------------------------------------------------------
    def _check_open(self) -> None:
        if self._closed:
            raise TransportError("the Zenoh transport is closed")

    @property
    def closed(self) -> bool:
        return self._closed

    def close(self) -> None:
        """Withdraw tokens, undeclare everything and close the session (if this object opened
        it). Idempotent."""
        if self._closed:
            return
        self._closed = True
        for token in self._tokens:
            token.undeclare()
        with self._lock:
            zsubs = list(self._zsubs.values())
            self._zsubs.clear()
            pubs = list(self._publishers.values())
            self._publishers.clear()
        for entity in (*zsubs, *pubs):
            with contextlib.suppress(Exception):
                entity.undeclare()
        if self._owns_session:
            with contextlib.suppress(Exception):
                self.session.close()
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> ZenohTransport:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
