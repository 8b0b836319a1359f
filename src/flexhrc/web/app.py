"""The operator panel as an ASGI app (Starlette): one page, a JSON API, a websocket.

Routes (the JSON keys are documented in ``docs/panel.md``):

* ``GET /`` — the page; ``GET /static/...`` — its script and style, served from the package
  (no CDN: the panel works with no network at all);
* ``GET /api/state`` — the backend's snapshot (``outcome``, ``suggestions``, ``agents``,
  ``events``, the graph, the timeline, the knowledge base, what the cooperation waits for);
* ``POST /api/human`` — ``{"action": "<ground action>"}`` or ``{"take": "<hyper-arc>"}``;
* ``POST /api/whatif`` — ``{"action": ...}`` or ``{"take": ...}``: what the robots would do if
  the person did that step or took that part (nothing changes);
* ``POST /api/stop`` / ``POST /api/resume`` — ``{"robot": "<arm>"}``;
* ``WS /ws`` — the snapshot on connect and again after every change (server push only; what a
  client sends on it is ignored).

Errors are ``{"error": "<message>"}`` with 400 (malformed), 401 (no or wrong token), 404
(unknown name), 409 (not possible now), 413 (too large), 415 (not JSON) or 503 (busy: more than
:data:`MAX_REQUESTS` requests at once); nothing changes. A websocket beyond
:data:`MAX_WEBSOCKETS` open ones is closed at once with code 1013 ("try again later") and the
reason.

The operator's stop is always answered: ``/api/stop`` and ``/api/resume`` are never counted
against those limits and run on threads of their own, so neither idle websockets nor requests
waiting for a busy cell can keep an arm from being stopped (uvicorn's own ``limit_concurrency``
counted every websocket and answered the stop 503; the panel does not use it).

Security: with a ``token`` every request and websocket must carry it (``Authorization: Bearer
T``, ``?token=T`` or the cookie the page sets), else 401. Without one (loopback only, see
:func:`flexhrc.web.server.check_bind`) the Host header must name a loopback host, so a web page
elsewhere cannot reach the panel by DNS rebinding; posts must be ``application/json`` (a
cross-site form cannot send that without a CORS pre-flight, which the panel never grants) and a
websocket from another origin is refused.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import json
import logging
from collections.abc import AsyncIterator, Awaitable, Callable, MutableMapping
from concurrent.futures import ThreadPoolExecutor
from importlib import resources
from typing import Any
from urllib.parse import urlsplit

from flexhrc.errors import OptionalDependencyError
from flexhrc.web.backend import (
    MAX_BODY_BYTES,
    PanelBackend,
    PanelInputError,
    is_loopback,
    parse_human_body,
    parse_robot_body,
    parse_what_if_body,
)

try:
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.requests import HTTPConnection, Request
    from starlette.responses import FileResponse, JSONResponse, Response
    from starlette.routing import Mount, Route, WebSocketRoute
    from starlette.staticfiles import StaticFiles
    from starlette.types import ASGIApp, Receive, Scope, Send
    from starlette.websockets import WebSocket, WebSocketDisconnect
except ImportError as exc:  # pragma: no cover - exercised without the web extra
    raise OptionalDependencyError("the operator panel", "web", exc.name or "starlette") from exc

log = logging.getLogger("flexhrc.web")

COOKIE = "flexhrc_panel_token"
#: open websockets (pages) at most; one more is closed at once and told why
MAX_WEBSOCKETS = 64
#: the websocket close code of that refusal (RFC 6455 registry: "Try Again Later")
TRY_AGAIN_LATER = 1013
#: HTTP requests in progress at most, the operator's stop and resume apart; one more gets 503
MAX_REQUESTS = 128
#: the operator's stop and resume never wait for a thread another request holds
OPERATOR_PATHS = frozenset({"/api/stop", "/api/resume"})


def static_dir() -> str:
    return str(resources.files("flexhrc.web").joinpath("static"))


def _error(message: str, status: int) -> JSONResponse:
    return JSONResponse({"error": message}, status_code=status)


class _Hub:
    """Pushes the backend's snapshot to every open websocket after each change.

    One snapshot and one JSON text per change, whatever the number of clients; each client
    keeps only the newest text, so a slow client skips states instead of slowing the others.
    """

    def __init__(self, backend: PanelBackend):
        self.backend = backend
        self.clients: set[_Client] = set()
        self._changed = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._unsubscribe: Callable[[], None] | None = None
        self.text = ""
        self.sockets = 0  # open or opening websockets (counted before the first await)

    async def start(self) -> None:
        loop = asyncio.get_running_loop()

        def on_change() -> None:  # any thread
            with contextlib.suppress(RuntimeError):  # the loop is closing
                loop.call_soon_threadsafe(self._changed.set)

        self._unsubscribe = self.backend.subscribe(on_change)
        self.text = await self._render()
        self._task = asyncio.create_task(self._run())

    async def stop(self) -> None:
        if self._unsubscribe is not None:
            self._unsubscribe()
        if self._task is not None:
            self._task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._task

    async def _render(self) -> str:
        snap = await run_in_threadpool(self.backend.snapshot)
        return json.dumps(snap, separators=(",", ":"), allow_nan=False)

    async def _run(self) -> None:
        while True:
            await self._changed.wait()
            self._changed.clear()
            try:
                text = await self._render()
            except Exception:  # a backend's fault must not end the pushes of later states
                log.exception("the panel could not take the state")
                continue
            if text == self.text:
                continue
            self.text = text
            for client in list(self.clients):
                client.offer(text)


class _Client:
    def __init__(self, ws: WebSocket):
        self.ws = ws
        self.latest: str | None = None
        self.ready = asyncio.Event()

    def offer(self, text: str) -> None:
        self.latest = text
        self.ready.set()

    async def pump(self) -> None:
        while True:
            await self.ready.wait()
            self.ready.clear()
            text, self.latest = self.latest, None
            if text is not None:
                await self.ws.send_text(text)


class _Guard:
    """Token, Host and Origin checks for HTTP and websocket alike (ASGI middleware)."""

    def __init__(self, app: ASGIApp, token: str | None, max_requests: int = MAX_REQUESTS):
        self.app = app
        self.token = token
        self.hub: _Hub | None = None
        self.max_requests = max_requests
        self.requests = 0  # HTTP requests in progress, the operator's stop and resume apart

    def _refusal(self, conn: HTTPConnection) -> tuple[int, str] | None:
        if self.token is None:
            host = (conn.url.hostname or "").strip("[]").lower()
            if not is_loopback(host):  # all of 127.0.0.0/8 is loopback (T15)
                return (
                    400,
                    f"host {host!r} refused: the panel without --token answers loopback only",
                )
        else:
            sent = _sent_token(conn)
            if sent is None or not hmac.compare_digest(sent.encode(), self.token.encode()):
                return 401, "missing or wrong token (Authorization: Bearer T, or ?token=T)"
        origin = conn.headers.get("origin")
        if (
            origin
            and conn.scope["type"] == "websocket"
            and urlsplit(origin).netloc.lower() != conn.headers.get("host", "").lower()
        ):
            return 403, f"websocket from another origin ({origin}) refused"
        return None

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        conn = HTTPConnection(scope)
        refusal = self._refusal(conn)
        if scope["type"] == "http":
            send = _with_headers(send, SECURITY_HEADERS)
        if refusal is None and scope["type"] == "http" and scope["path"] not in OPERATOR_PATHS:
            if self.requests >= self.max_requests:
                refusal = (
                    503,
                    f"the panel is busy ({self.requests} requests in progress); try again"
                    " (the operator's stop is always answered)",
                )
            else:
                self.requests += 1
                try:
                    await self._pass(conn, scope, receive, send)
                finally:
                    self.requests -= 1
                return
        if refusal is None:
            await self._pass(conn, scope, receive, send)
            return
        status, message = refusal
        response = _error(message, status)
        if scope["type"] == "websocket":
            ws = WebSocket(scope, receive, send)
            await ws.send_denial_response(response)
        else:
            await response(scope, receive, send)

    async def _pass(self, conn: HTTPConnection, scope: Scope, receive: Receive, send: Send) -> None:
        if self.token is not None and scope["type"] == "http" and "token" in conn.query_params:
            await self._with_cookie(scope, receive, send)
        else:
            await self.app(scope, receive, send)

    async def _with_cookie(self, scope: Scope, receive: Receive, send: Send) -> None:
        """A page opened with ?token=T remembers it, so its script and style load too."""
        assert self.token is not None
        cookie = f"{COOKIE}={self.token}; Path=/; HttpOnly; SameSite=Strict"

        async def send_with_cookie(message: MutableMapping[str, Any]) -> None:
            if message["type"] == "http.response.start":
                headers = list(message.get("headers", []))
                headers.append((b"set-cookie", cookie.encode("latin-1")))
                message = {**message, "headers": headers}
            await send(message)

        await self.app(scope, receive, send_with_cookie)


# Every HTTP answer: the page may load and connect to nothing but this server (no CDN, no
# injected script), is never framed, and never sends its URL (which may carry ?token=) onwards.
SECURITY_HEADERS = (
    (
        b"content-security-policy",
        b"default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "
        b"connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'none'",
    ),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
)


def _with_headers(send: Send, extra: tuple[tuple[bytes, bytes], ...]) -> Send:
    async def wrapped(message: MutableMapping[str, Any]) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message.get("headers", []), *extra]}
        await send(message)

    return wrapped


def _sent_token(conn: HTTPConnection) -> str | None:
    auth = conn.headers.get("authorization", "")
    if auth.lower().startswith("bearer "):
        return auth[7:].strip()
    if "token" in conn.query_params:
        return conn.query_params["token"]
    return conn.cookies.get(COOKIE)


async def _read_body(request: Request) -> bytes:
    """The body, refused past :data:`MAX_BODY_BYTES` without reading the rest."""
    ctype = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if ctype != "application/json":
        raise PanelInputError("send the body as Content-Type: application/json", 415)
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > MAX_BODY_BYTES:
        raise PanelInputError(f"request body too large (at most {MAX_BODY_BYTES} bytes)", 413)
    chunks: list[bytes] = []
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > MAX_BODY_BYTES:
            raise PanelInputError(f"request body too large (at most {MAX_BODY_BYTES} bytes)", 413)
        chunks.append(chunk)
    return b"".join(chunks)


def create_app(
    backend: PanelBackend,
    *,
    token: str | None = None,
    max_websockets: int = MAX_WEBSOCKETS,
    max_requests: int = MAX_REQUESTS,
) -> ASGIApp:
    """The panel app over ``backend``; ``token`` (None: loopback use only) guards everything;
    ``max_websockets`` and ``max_requests`` bound what clients may hold open."""
    hub = _Hub(backend)
    root = static_dir()
    # the operator's stop and resume: threads of their own, never queued behind requests that
    # wait for the cell in the shared pool (made when first needed, ended with the server)
    operator_threads: list[ThreadPoolExecutor] = []

    def operator_pool() -> ThreadPoolExecutor:
        if not operator_threads:
            operator_threads.append(
                ThreadPoolExecutor(max_workers=2, thread_name_prefix="flexhrc-panel-stop")
            )
        return operator_threads[0]

    async def index(request: Request) -> Response:
        return FileResponse(f"{root}/index.html", headers={"cache-control": "no-store"})

    async def state(request: Request) -> Response:
        return JSONResponse(await run_in_threadpool(backend.snapshot))

    def handler(
        parse: Callable[[bytes], Any],
        call: Callable[[Any], dict[str, Any]],
        *,
        reserved: bool = False,
    ) -> Callable[[Request], Awaitable[Response]]:
        async def endpoint(request: Request) -> Response:
            try:
                parsed = parse(await _read_body(request))
                if reserved:
                    loop = asyncio.get_running_loop()
                    result = await loop.run_in_executor(operator_pool(), call, parsed)
                else:
                    result = await run_in_threadpool(call, parsed)
            except PanelInputError as exc:
                return _error(str(exc), exc.status)
            return JSONResponse(result)

        return endpoint

    def what_if(body: dict[str, str]) -> dict[str, Any]:
        ask = getattr(backend, "what_if", None)  # optional in the backend contract
        if ask is None:
            raise PanelInputError("this panel's backend answers no what-if", 404)
        result: dict[str, Any] = ask(body)
        return result

    async def websocket(ws: WebSocket) -> None:
        if hub.sockets >= max_websockets:
            # refused with the websocket close code "try again later" and the reason (an HTTP
            # denial would do as well, but uvicorn logs each one as an error: a flood of them
            # would flood the log)
            await ws.accept()
            await ws.close(
                code=TRY_AGAIN_LATER,
                reason=f"too many open panels (at most {max_websockets}); close one and reload",
            )
            return
        hub.sockets += 1
        try:
            await _serve_socket(ws)
        finally:
            hub.sockets -= 1

    async def _serve_socket(ws: WebSocket) -> None:
        await ws.accept()
        client = _Client(ws)
        client.offer(hub.text)
        hub.clients.add(client)
        pump = asyncio.create_task(client.pump())
        try:
            while True:  # nothing a client sends is acted upon; this only sees it leave
                message = await ws.receive()
                if message["type"] == "websocket.disconnect":
                    break
        except WebSocketDisconnect:
            pass
        finally:
            hub.clients.discard(client)
            pump.cancel()
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await pump

    @contextlib.asynccontextmanager
    async def lifespan(app: Starlette) -> AsyncIterator[None]:
        await hub.start()
        try:
            yield
        finally:
            await hub.stop()
            for pool in operator_threads:
                pool.shutdown(wait=False)
            operator_threads.clear()

    app = Starlette(
        routes=[
            Route("/", index),
            Route("/api/state", state),
            Route("/api/human", handler(parse_human_body, backend.submit), methods=["POST"]),
            Route("/api/whatif", handler(parse_what_if_body, what_if), methods=["POST"]),
            Route(
                "/api/stop",
                handler(parse_robot_body, backend.stop_robot, reserved=True),
                methods=["POST"],
            ),
            Route(
                "/api/resume",
                handler(parse_robot_body, backend.resume_robot, reserved=True),
                methods=["POST"],
            ),
            WebSocketRoute("/ws", websocket),
            Mount("/static", StaticFiles(directory=root), name="static"),
        ],
        lifespan=lifespan,
    )
    guard = _Guard(app, token, max_requests)
    guard.hub = hub
    return guard


__all__ = ["COOKIE", "MAX_REQUESTS", "MAX_WEBSOCKETS", "create_app", "static_dir"]
