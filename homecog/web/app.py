"""The HTTP API of the running robot (SPEC §10), with OpenAPI at ``/docs``.

========================  ===================================================================
``GET /api/home``         the home: features, devices, services (for forms and clients)
``GET /api/context``      the current context (values as in a scenario file)
``PUT /api/context``      manual mode: set some features or devices (a write)
``POST /api/cognize``     ``{"context": {...}, "user": ...}`` → services, unknown, explanations
``POST /api/corrections`` ``{"context": {...}, "want": [...], "user": ...}`` → added, rejected (a write)
``POST /api/plan``        ``{"services": [...], "context": {...}}`` → actions, tree
``GET /api/history``      corrections so far and how the robot's agreement with users grew
``GET /api/events``       a live stream of server-sent events: context, correction
========================  ===================================================================

Writes need ``Authorization: Bearer <token>`` when the server was given a token (it is, on
any address other than 127.0.0.1). Bodies over 64 KiB are refused with 413. Bad input is a 4xx
with ``{"detail": "..."}`` naming what is wrong; nothing stored changes.
"""

from __future__ import annotations

import asyncio
import hmac
import logging
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, FastAPI, Header, HTTPException, Request
from fastapi.responses import HTMLResponse, JSONResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, Field

from homecog.errors import HomecogError
from homecog.web.runtime import Runtime

MAX_BODY = 64 * 1024
Value = str | float | int | bool


class CognizeIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    context: dict[str, Value] = Field(description="Every feature and device, as in a scenario file.")
    user: str = Field("default", min_length=1, max_length=200)


class CorrectionIn(CognizeIn):
    want: list[str] = Field(description="The services the user wants there (empty: none).", max_length=200)


class PlanIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    services: list[str] = Field(min_length=1, max_length=500)
    context: dict[str, Value] | None = None


class ContextIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    values: dict[str, Value] = Field(description="Features or devices to change.")


def create_app(runtime: Runtime, *, speed: float | None = None) -> FastAPI:
    """The FastAPI application serving ``runtime``; with ``speed``, a simulated source lives
    that many simulated seconds per real second, and the robot acts on what it proposes."""

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        task = asyncio.create_task(_live(runtime, speed)) if speed else None
        yield
        if task is not None:
            task.cancel()

    app = FastAPI(
        title="homecog",
        summary="Service cognition for a home service robot",
        version="0.1.0",
        lifespan=lifespan,
    )
    app.state.runtime = runtime

    @app.middleware("http")
    async def limit_body(request: Request, call_next: Callable[[Request], Awaitable[Any]]) -> Any:
        length = request.headers.get("content-length")
        if length is not None and (not length.isdigit() or int(length) > MAX_BODY):
            return JSONResponse({"detail": f"request body over {MAX_BODY // 1024} KiB"}, status_code=413)
        if request.method in ("POST", "PUT") and length is None:
            body = b""
            async for chunk in request.stream():
                body += chunk
                if len(body) > MAX_BODY:
                    return JSONResponse(
                        {"detail": f"request body over {MAX_BODY // 1024} KiB"}, status_code=413
                    )
            request._body = body  # the stream is spent; the route reads the body from here
        return await call_next(request)

    @app.exception_handler(HomecogError)
    async def homecog_error(request: Request, exc: HomecogError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=422)

    def writer(authorization: Annotated[str | None, Header()] = None) -> None:
        if runtime.token is None:
            return
        scheme, _, given = (authorization or "").partition(" ")
        if scheme.lower() != "bearer" or not hmac.compare_digest(given.strip(), runtime.token):
            raise HTTPException(
                401, detail="this server needs a token for writes: Authorization: Bearer <token>"
            )

    page = (Path(__file__).parent / "static" / "index.html").read_text(encoding="utf-8")

    @app.get("/", response_class=HTMLResponse, include_in_schema=False)
    def index() -> str:
        """The HMI: the home now, the robot's services and why, the user's services, the plan,
        the corrections; one page that works on a phone."""
        return page

    @app.get("/api/home")
    def get_home() -> dict[str, Any]:
        """The home's features (with values), devices and services."""
        h = runtime.home
        return {
            "name": h.name,
            "features": [
                {"name": f.name, "kind": f.kind, "values": list(f.values), "unit": getattr(f, "unit", None)}
                for f in h.features
            ],
            "devices": [{"name": d.name, "room": d.room, "iot": d.iot} for d in h.devices],
            "services": [{"name": s.name, "category": s.category} for s in h.services],
            "layout": h.layout is not None,
        }

    @app.get("/api/context")
    def get_context() -> dict[str, str]:
        """The current context."""
        return runtime.context()

    @app.put("/api/context", dependencies=[Depends(writer)])
    def put_context(body: ContextIn) -> dict[str, str]:
        """Manual mode: change features or devices; answers the whole new context."""
        return runtime.set_context(body.values)

    @app.post("/api/cognize")
    def cognize(body: CognizeIn) -> dict[str, Any]:
        """The services the user needs in a context, in priority order, and why."""
        return runtime.cognize(body.context, body.user)

    @app.post("/api/corrections", dependencies=[Depends(writer)])
    def corrections(body: CorrectionIn) -> dict[str, Any]:
        """The services the user wants in a context: the robot learns at once, for that user."""
        return runtime.correct(body.context, body.want, body.user)

    @app.post("/api/plan")
    def plan(body: PlanIn) -> dict[str, Any]:
        """The services decomposed into robot actions, in the given order."""
        from homecog.planning import plan_services

        context = dict(runtime.space.context(runtime.space.point(body.context))) if body.context else None
        result = plan_services(runtime.home, body.services, context=context)
        return {"actions": [list(a) for a in result.actions], "tree": [n.as_dict() for n in result.tree]}

    @app.get("/api/history")
    def history(user: str | None = None) -> dict[str, Any]:
        """Corrections so far (newest last) and the running agreement with the users."""
        rows = [c for c in runtime.history if user is None or c.user == user]
        return {
            "corrections": [
                {"at": c.at, "user": c.user, "want": c.want, "predicted": c.predicted, "agreed": c.agreed}
                for c in rows
            ],
            "agreement": runtime.agreement(user),
        }

    @app.get("/api/events")
    async def events(request: Request) -> StreamingResponse:
        """Server-sent events: ``context`` when the home changes, ``correction`` when one is made."""
        queue = runtime.subscribe()

        async def stream() -> AsyncIterator[str]:
            try:
                yield f"event: context\ndata: {_json(runtime.context())}\n\n"
                while not await request.is_disconnected():
                    try:
                        yield await asyncio.wait_for(queue.get(), timeout=15)
                    except TimeoutError:
                        yield ": keep-alive\n\n"
            finally:
                runtime.unsubscribe(queue)

        return StreamingResponse(stream(), media_type="text/event-stream")

    return app


async def _live(runtime: Runtime, speed: float, period: float = 1.0) -> None:
    """Advance the simulated home with the real clock; a failing tick is logged, not fatal."""
    last = time.monotonic()
    while True:
        await asyncio.sleep(period)
        now = time.monotonic()
        try:
            await asyncio.to_thread(runtime.tick, (now - last) * speed)
        except Exception:  # the server stays up whatever the simulation does
            logging.getLogger("homecog.web").exception("the simulated home failed a tick")
        last = now


def _json(data: object) -> str:
    import json

    return json.dumps(data)
