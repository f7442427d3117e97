"""Where the HTTP API meets the network: ``homecog up`` and ``homecog serve`` run their app here.

Two guards beyond the app's own (docs/design.md, "Hostile input"):

- **Slow or half-sent requests time out.** A client has ``request_timeout`` seconds (5) from
  its connection, or from the first byte of its next request, to send the whole request; one
  that is slower, or stops half-way, is answered 408 and its connection closed, and request
  headers over 64 KiB get 431. uvicorn itself waits forever for a request that never ends; it
  closes only idle connections between requests (after ``timeout_keep_alive``, 5 s).
- **Without a token, only this machine's names.** A server without a token listens only on
  loopback; a web page elsewhere can still reach it through the browser by DNS rebinding (its
  own name made to point at 127.0.0.1), and would read the home. Such a request carries the
  page's name in ``Host``, so without a token only ``localhost``, ``127.0.0.1`` and ``[::1]``
  (with the server's port, or none) are answered; any other ``Host`` gets 400.

>>> loopback_host(b"localhost:8000", 8000), loopback_host(b"[::1]", 8000)
(True, True)
>>> loopback_host(b"evil.example:8000", 8000), loopback_host(b"127.0.0.1:9999", 8000)
(False, False)
"""

from __future__ import annotations

import json
from typing import Any

import uvicorn
from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

from homecog.web.settings import Settings

LOOPBACK_NAMES = (b"localhost", b"127.0.0.1", b"[::1]")
MAX_HEADERS = 64 * 1024


def loopback_host(host: bytes, port: int | None) -> bool:
    """Whether a ``Host`` header names this machine's loopback, at ``port`` or without one."""
    name, colon, given = host.strip().lower().rpartition(b":")
    if not colon or name.endswith(b":") or (given and not given.isdigit()):
        name, given = host.strip().lower(), b""  # no port (or a bare IPv6 address)
    return name in LOOPBACK_NAMES and (not given or port is None or int(given) == port)


class LoopbackOnly:
    """Plain ASGI middleware answering 400 to a request whose ``Host`` is not this machine's
    loopback (a server without a token)."""

    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        host = next((v for k, v in scope["headers"] if k == b"host"), b"")
        server = scope.get("server")
        if loopback_host(host, server[1] if server else None):
            return await self.app(scope, receive, send)
        if scope["type"] == "websocket":
            return await send({"type": "websocket.close", "code": 1008})
        shown = host.decode("latin-1")[:80]
        detail = (
            f"Host {shown!r} is not this machine: a server without a token answers only "
            "localhost, 127.0.0.1 and [::1]"
        )
        await _send_json(send, 400, detail)


async def _send_json(send: Any, status: int, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [(b"content-type", b"application/json"), (b"content-length", b"%d" % len(body))]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class TimedProtocol(HttpToolsProtocol):
    """uvicorn's HTTP/1.1 protocol (httptools), with a deadline of :attr:`timeout` seconds for
    each request to arrive whole and a bound on the size of its headers."""

    timeout: float = 5.0  # seconds; Settings.request_timeout through timed_protocol

    def connection_made(self, transport: Any) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._deadline: Any = None
        self._header_bytes: int | None = 0  # None: the headers are in
        self._arm()

    def data_received(self, data: bytes) -> None:
        if self._deadline is None:  # the first bytes of a request on a kept-alive connection
            self._arm()
        if self._header_bytes is not None:  # only the headers count: a body may come with them
            end = data.find(b"\r\n\r\n")
            self._header_bytes += len(data) if end < 0 else end + 4
            if self._header_bytes > MAX_HEADERS:
                return self._refuse(431, "request headers over 64 KiB")
        super().data_received(data)

    def on_message_begin(self) -> None:
        super().on_message_begin()
        self._header_bytes = 0
        if self._deadline is None:  # a request pipelined behind one that came whole
            self._arm()

    def on_headers_complete(self) -> None:
        self._header_bytes = None
        super().on_headers_complete()

    def on_message_complete(self) -> None:
        super().on_message_complete()
        self._disarm()  # the request is in: the app takes its time to answer

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm()
        super().connection_lost(exc)

    def _arm(self) -> None:
        self._disarm()
        self._deadline = self.loop.call_later(self.timeout, self._too_slow)

    def _disarm(self) -> None:
        if self._deadline is not None:
            self._deadline.cancel()
            self._deadline = None

    def _too_slow(self) -> None:
        self._deadline = None
        self._refuse(408, f"the request did not arrive whole within {self.timeout:g} s")

    def _refuse(self, status: int, detail: str) -> None:
        """Answer ``status`` unless an answer has begun, and close the connection."""
        if self.transport.is_closing():
            return
        cycle = self.cycle
        if cycle is None or not cycle.response_started:
            body = json.dumps({"detail": detail}).encode()
            reason = {408: b"Request Timeout", 431: b"Request Header Fields Too Large"}[status]
            self.transport.write(
                b"HTTP/1.1 %d %s\r\ncontent-type: application/json\r\ncontent-length: %d\r\n"
                b"connection: close\r\n\r\n%s" % (status, reason, len(body), body)
            )
            if cycle is not None:
                cycle.response_started = cycle.response_complete = True  # the app's answer is moot
        self.transport.close()


def timed_protocol(timeout: float) -> type[TimedProtocol]:
    """:class:`TimedProtocol` with a deadline of ``timeout`` seconds, as uvicorn takes it (a
    class it makes one of for each connection)."""
    return type("TimedProtocol", (TimedProtocol,), {"timeout": timeout})


def guarded(app: Any, settings: Settings) -> Any:
    """The app as the network gets it: loopback names only, where the server has no token."""
    return LoopbackOnly(app) if settings.token is None else app


def options(settings: Settings, *, host: str, port: int) -> dict[str, Any]:
    """uvicorn's options for serving with the guards above (the app goes through
    :func:`guarded`)."""
    return {
        "host": host,
        "port": port,
        "http": timed_protocol(settings.request_timeout),
        "log_level": "warning",
        "access_log": False,
        "proxy_headers": False,  # no proxy is trusted: X-Forwarded-For is not the client
        "timeout_keep_alive": 5,
        "timeout_graceful_shutdown": 1,
    }


def run(app: Any, settings: Settings, *, host: str, port: int) -> None:
    """Serve ``app`` until interrupted, with the guards above."""
    uvicorn.run(guarded(app, settings), **options(settings, host=host, port=port))
