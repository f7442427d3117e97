"""Two plain ASGI layers in front of FastAPI (docs/design.md, "The HTTP server under load"):
the body limit, and the fast path of ``POST /api/cognize``.

FastAPI's routing, dependency solving and middleware stack cost several times the cognition; the
fast path answers the valid requests itself, with the same pydantic model as the route, and
hands every other request (not JSON, invalid, without the token) to FastAPI with the body
replayed, so the route in :mod:`homecog.web.routes.cognize` documents the endpoint in OpenAPI
and words every error. A test checks that both give the same answers and errors.
"""

from __future__ import annotations

import asyncio
from typing import Any

from pydantic import BaseModel, ValidationError

from homecog.errors import HomecogError
from homecog.robot.runtime import Runtime
from homecog.web.deps import authorized
from homecog.web.settings import MAX_BODY


class CognizeFastPath:
    """Pure ASGI middleware answering valid ``POST /api/cognize`` requests itself, the hot path
    of a robot asking many times a second."""

    def __init__(self, app: Any, runtime: Runtime, model: type[BaseModel], token: str | None) -> None:
        self.app = app
        self.runtime = runtime
        self.model = model  # the home's CognizeIn
        self.token = token

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["path"] != "/api/cognize" or scope["method"] != "POST":
            return await self.app(scope, receive, send)
        kind = dict(scope["headers"]).get(b"content-type", b"")  # repeated: the last, not ours
        if kind.split(b";")[0].strip().lower() != b"application/json" or not authorized(
            scope["headers"], self.token, scope["method"]
        ):
            return await self.app(scope, receive, send)
        chunks, more = [], True
        while more:
            message = await receive()
            if message["type"] != "http.request":
                return None  # the client went away
            chunks.append(message.get("body", b""))
            more = message.get("more_body", False)
        body = b"".join(chunks)
        try:
            request = self.model.model_validate_json(body)
            context, user = request.context, request.user  # type: ignore[attr-defined]
            if self.runtime.lock.locked():  # a correction is being stored: wait off the loop
                answer = await asyncio.to_thread(self.runtime.cognize_json, context, user)
            else:
                answer = self.runtime.cognize_json(context, user)
        except (ValidationError, HomecogError):
            return await self.app(scope, _replay(body, receive), send)
        await send(
            {
                "type": "http.response.start",
                "status": 200,
                "headers": [(b"content-type", b"application/json"), (b"content-length", b"%d" % len(answer))],
            }
        )
        await send({"type": "http.response.body", "body": answer})


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
