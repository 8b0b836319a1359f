"""Serving the panel: the ``--web HOST:PORT`` address, the loopback rule, a server thread.

* :func:`parse_web_address` reads ``HOST:PORT`` (``:PORT``, ``HOST``, ``[::1]:PORT``; port 0 =
  any free port); the default is ``127.0.0.1:8080``;
* :func:`check_bind` refuses any address but loopback without a token — the panel moves robots;
  on a shared network nobody may press its buttons without the token;
* :class:`PanelServer` runs uvicorn on a thread of its own (the cooperation keeps the main
  thread) and stops it cleanly.
"""

from __future__ import annotations

import re
import socket
import sys
import threading
import time
from typing import Any

from flexhrc.errors import FlexhrcError, OptionalDependencyError
from flexhrc.web.backend import PanelBackend, is_loopback

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8080
DEFAULT_ADDRESS = f"{DEFAULT_HOST}:{DEFAULT_PORT}"
MIN_TOKEN_CHARS = 8
_TOKEN_RE = re.compile(r"^[A-Za-z0-9._~+/=-]+$")


def parse_web_address(text: str, option: str = "--web") -> tuple[str, int]:
    """``"0.0.0.0:9000"`` -> ``("0.0.0.0", 9000)``; errors name the option."""
    value = text.strip()
    if not value:
        return DEFAULT_HOST, DEFAULT_PORT
    if "://" in value or "/" in value:  # a URL, not an address (T14)
        raise FlexhrcError(
            f"{option} {text!r}: give HOST:PORT, not a URL (e.g. {DEFAULT_ADDRESS}, or "
            "[::1]:8080 for an IPv6 address)"
        )
    if value.startswith("["):  # [v6]:port
        end = value.find("]")
        if end < 0:
            raise FlexhrcError(f"{option} {text!r}: missing ']' after the IPv6 address")
        host, rest = value[1:end], value[end + 1 :]
        port_text = rest[1:] if rest.startswith(":") else (None if not rest else "?")
    elif value.count(":") == 1:
        host, port_text = value.split(":")
    elif ":" in value:
        raise FlexhrcError(f"{option} {text!r}: write an IPv6 address as [ADDRESS]:PORT")
    else:
        host, port_text = value, None
    host = host or DEFAULT_HOST
    if port_text is None:
        port = DEFAULT_PORT
    else:
        if not port_text.isdigit() or not 0 <= int(port_text) <= 65535:
            raise FlexhrcError(f"{option} {text!r}: the port must be a number 0..65535")
        port = int(port_text)
    if not re.match(r"^[A-Za-z0-9.\-:]+$", host):
        raise FlexhrcError(f"{option} {text!r}: {host!r} is not a host name or address")
    return host, port


def check_bind(host: str, token: str | None) -> None:
    """Refuse a non-loopback address without a token, and a token too weak to mean anything."""
    if token is not None:
        if len(token) < MIN_TOKEN_CHARS or not _TOKEN_RE.match(token):
            raise FlexhrcError(
                f"--token must be at least {MIN_TOKEN_CHARS} characters of"
                " A-Z a-z 0-9 . _ ~ + / = -"
                " (e.g. python -c 'import secrets; print(secrets.token_urlsafe())')"
            )
        return
    if not is_loopback(host):
        raise FlexhrcError(
            f"--web {host}: the panel moves robots, so an address other than loopback needs "
            "--token T (every request must then carry it); or serve on 127.0.0.1"
        )


class PanelServer:
    """uvicorn serving :func:`flexhrc.web.app.create_app` on a background thread."""

    def __init__(
        self,
        backend: PanelBackend,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        *,
        token: str | None = None,
        max_websockets: int | None = None,
        max_requests: int | None = None,
    ):
        """``max_websockets`` / ``max_requests``: the app's bounds (None: its defaults,
        :data:`flexhrc.web.app.MAX_WEBSOCKETS` and :data:`flexhrc.web.app.MAX_REQUESTS`)."""
        check_bind(host, token)
        try:
            import uvicorn
        except ImportError as exc:
            raise OptionalDependencyError("the operator panel", "web", "uvicorn") from exc
        from flexhrc.web.app import MAX_REQUESTS, MAX_WEBSOCKETS, create_app

        self.host, self.port, self.token = host, port, token
        self.app = create_app(
            backend,
            token=token,
            max_websockets=MAX_WEBSOCKETS if max_websockets is None else max_websockets,
            max_requests=MAX_REQUESTS if max_requests is None else max_requests,
        )
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._sock = socket.socket(family, socket.SOCK_STREAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._sock.bind((host, port))
        except OSError as exc:
            self._sock.close()
            raise FlexhrcError(
                f"--web {host}:{port}: cannot listen there ({exc.strerror})"
            ) from None
        self.port = self._sock.getsockname()[1]
        config = uvicorn.Config(
            self.app,
            log_level="warning",
            ws="websockets-sansio",
            ws_max_size=64 * 1024,
            lifespan="on",
            # no limit_concurrency: uvicorn counts websockets in it and then answers every
            # request 503, the operator's stop included (probe WS07); the app bounds websockets
            # and requests itself and keeps the stop apart (flexhrc.web.app)
        )
        self._server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    @property
    def address(self) -> str:
        """``http://HOST:PORT/`` with the port as bound (port 0: the one the system gave), no
        token (what a ready file may hold)."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    @property
    def url(self) -> str:
        """The page's address to open, with ``?token=`` when there is a token."""
        return f"{self.address}?token={self.token}" if self.token else self.address

    def start(self, timeout: float = 10.0) -> PanelServer:
        self._thread = threading.Thread(
            target=self._server.run,
            kwargs={"sockets": [self._sock]},
            daemon=True,
            name="flexhrc-panel-http",
        )
        self._thread.start()
        deadline = time.monotonic() + timeout
        while not self._server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise FlexhrcError(f"the panel did not start on {self.host}:{self.port}")
            time.sleep(0.01)
        return self

    def stop(self, grace: float = 0.0) -> None:
        """Stop serving; ``grace`` seconds first, for the last push to reach the pages."""
        if grace > 0 and self._server.started:
            time.sleep(grace)
        self._server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._sock.close()

    def __enter__(self) -> PanelServer:
        return self.start()

    def __exit__(self, *exc: Any) -> None:
        self.stop()

    def announce(self) -> None:
        print(f"panel: {self.url}", file=sys.stderr, flush=True)


__all__ = [
    "DEFAULT_ADDRESS",
    "DEFAULT_HOST",
    "DEFAULT_PORT",
    "PanelServer",
    "check_bind",
    "is_loopback",
    "parse_web_address",
]
