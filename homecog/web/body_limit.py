"""The body limit: a plain ASGI layer in front of FastAPI refusing request bodies over the
limit with 413, in JSON (docs/design.md, "The HTTP server under load").
"""

from __future__ import annotations

from typing import Any

from homecog.web.settings import MAX_BODY


def _replay(body: bytes, receive: Any) -> Any:
    """A ``receive`` that gives ``body`` once, then whatever the client sends next."""
    sent = False

    async def replay() -> dict[str, Any]:
        nonlocal sent
        if not sent:
            sent = True
            return {"type": "http.request", "body": body, "more_body": False}
        return await receive()

    return replay


class BodyLimit:
    """Pure ASGI middleware refusing request bodies over ``limit`` bytes with 413, whether the
    client says their length or streams them in chunks.

    A plain ASGI class, not ``@app.middleware("http")``: that one wraps every request in a
    task and two memory streams and costs more than the whole cognition. Not FastAPI's
    ``max_body_size`` either: it answers a declared oversize length in plain text, not JSON.
    """

    def __init__(self, app: Any, limit: int = MAX_BODY) -> None:
        self.app = app
        self.limit = limit

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        length = next((v for k, v in scope["headers"] if k == b"content-length"), None)
        if length is not None:
            if not length.isdigit() or int(length) > self.limit:
                return await self._refuse(send)
            return await self.app(scope, receive, send)
        if scope["method"] not in ("POST", "PUT", "PATCH"):
            return await self.app(scope, receive, send)
        body, more = b"", True  # chunked: read it all here, up to the limit
        while more:
            message = await receive()
            if message["type"] != "http.request":
                return None  # the client went away
            body += message.get("body", b"")
            more = message.get("more_body", False)
            if len(body) > self.limit:
                return await self._refuse(send)
        return await self.app(scope, _replay(body, receive), send)

    async def _refuse(self, send: Any) -> None:
        detail = f'{{"detail": "request body over {self.limit // 1024} KiB"}}'.encode()
        await send(
            {
                "type": "http.response.start",
                "status": 413,
                "headers": [(b"content-type", b"application/json"), (b"content-length", b"%d" % len(detail))],
            }
        )
        await send({"type": "http.response.body", "body": detail})
