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
import json
import logging
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from fastapi import Depends, FastAPI, Header, HTTPException, Request
from fastapi.responses import HTMLResponse, JSONResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, Field, ValidationError
from starlette.types import ASGIApp

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


class ExplanationOut(BaseModel):
    service: str
    category: str = Field(description="The service's category (the tree's middle level).")
    priority: float = Field(description="Higher first: the order the services are carried out in.")
    cluster: int = Field(description="The experience cluster that answered.")
    user: str | None = Field(description="Whose correction made the cluster; null: common knowledge.")
    conditions: dict[str, str] = Field(description="What the cluster matched, per feature or device.")


class CognizeOut(BaseModel):
    services: list[str] = Field(description="In priority order.")
    unknown: bool = Field(description="True when no experience answers the context.")
    explanations: list[ExplanationOut]


class ContextIn(BaseModel):
    model_config = ConfigDict(extra="forbid")
    values: dict[str, Value] = Field(description="Features or devices to change.")


def create_app(runtime: Runtime, *, speed: float | None = None) -> ASGIApp:
    """The ASGI application serving ``runtime``; with ``speed``, a simulated source lives
    that many simulated seconds per real second, and the robot acts on what it proposes.

    It is the FastAPI application (routes, OpenAPI), reached as ``.app.app``, behind two plain
    ASGI layers: the body limit, then the fast path of ``POST /api/cognize``."""

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
    async def index() -> str:
        """The HMI: the home now, the robot's services and why, the user's services, the plan,
        the corrections; one page that works on a phone."""
        return page

    @app.get("/api/home")
    def get_home() -> dict[str, Any]:
        """The home's features (with values), devices and services, and its floor plan (null
        without one): size, rooms and walls and doors as rectangles and segments
        ``[x0, y0, x1, y1]``, places as points, the robot's start place; metres, y up."""
        h = runtime.home
        return {
            "name": h.name,
            "features": [
                {"name": f.name, "kind": f.kind, "values": list(f.values), "unit": getattr(f, "unit", None)}
                for f in h.features
            ],
            "devices": [{"name": d.name, "room": d.room, "iot": d.iot} for d in h.devices],
            "services": [{"name": s.name, "category": s.category} for s in h.services],
            "layout": _layout(h),
        }

    @app.get("/api/context")
    def get_context() -> dict[str, str]:
        """The current context."""
        return runtime.context()

    @app.get("/api/source")
    def get_source() -> dict[str, Any]:
        """Where the context comes from (``simulated``, ``manual``, ``mqtt``, ``home_assistant``)
        and whether it is connected now; Home Assistant adds its version, reconnections, the
        states skipped and the last error."""
        status = getattr(runtime.source, "status", None)
        if callable(status):
            return status()
        kinds = {"SimulatedHome": "simulated", "ManualSource": "manual", "MqttSource": "mqtt"}
        name = type(runtime.source).__name__
        return {"kind": kinds.get(name, name), "connected": bool(getattr(runtime.source, "connected", True))}

    @app.put("/api/context", dependencies=[Depends(writer)])
    def put_context(body: ContextIn) -> dict[str, str]:
        """Manual mode: change features or devices; answers the whole new context."""
        return runtime.set_context(body.values)

    @app.post("/api/cognize", response_model=CognizeOut)
    async def cognize(body: CognizeIn) -> JSONResponse:
        """The services the user needs in a context, in priority order, and why."""
        # CognizeFastPath answers the valid requests; this route words the errors
        return JSONResponse(await asyncio.to_thread(runtime.cognize, body.context, body.user))

    @app.post("/api/corrections", dependencies=[Depends(writer)])
    def corrections(body: CorrectionIn) -> dict[str, Any]:
        """The services the user wants in a context: the robot learns at once, for that user."""
        return runtime.correct(body.context, body.want, body.user)

    @app.post("/api/plan")
    def plan(body: PlanIn) -> dict[str, Any]:
        """The services decomposed into robot actions, in the given order, and the plan carried
        out by the simulated robot on the floor plan: its timeline, time, distance and
        trajectory (``[t, x, y]`` rows, at most 400, metres and seconds)."""
        from homecog.planning import initial_state, plan_services
        from homecog.simulation import simulate

        context = dict(runtime.space.context(runtime.space.point(body.context))) if body.context else None
        result = plan_services(runtime.home, body.services, context=context)
        sim = simulate(runtime.home, result.actions, devices=initial_state(runtime.home, context).devices)
        simulation = sim.as_dict()
        del simulation["actions"]  # the same as the plan's
        simulation["trajectory"] = _thin(sim.trajectory, 400)
        return {
            "actions": [list(a) for a in result.actions],
            "tree": [n.as_dict() for n in result.tree],
            "simulation": simulation,
        }

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
                yield f"event: context\ndata: {json.dumps(runtime.context())}\n\n"
                while not await request.is_disconnected():
                    try:
                        yield await asyncio.wait_for(queue.get(), timeout=15)
                    except TimeoutError:
                        yield ": keep-alive\n\n"
            finally:
                runtime.unsubscribe(queue)

        return StreamingResponse(stream(), media_type="text/event-stream")

    # in front of FastAPI's own middleware stack, whose error middleware alone wraps every send
    return BodyLimit(CognizeFastPath(app, runtime), limit=MAX_BODY)


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


def _layout(home: Any) -> dict[str, Any] | None:
    layout = home.layout
    if layout is None:
        return None
    return {
        "size": list(layout.size),
        "rooms": {name: list(r) for name, r in layout.rooms.items()},
        "walls": [list(w) for w in layout.walls],
        "doors": [list(d) for d in layout.doors],
        "places": {name: list(p) for name, p in layout.places.items()},
        "robot": layout.robot,
    }


def _thin(trajectory: np.ndarray, most: int) -> list[list[float]]:
    """At most ``most`` rows ``[t, x, y]`` of a trajectory, evenly spaced, first and last kept.

    >>> _thin(np.array([[t, t, 0, 0] for t in range(10)], dtype=float), 4)
    [[0.0, 0.0, 0.0], [3.0, 3.0, 0.0], [6.0, 6.0, 0.0], [9.0, 9.0, 0.0]]
    """
    n = len(trajectory)
    keep = np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int)) if n else []
    return [[round(float(t), 2), round(float(x), 3), round(float(y), 3)] for t, x, y, *_ in trajectory[keep]]


class CognizeFastPath:
    """Pure ASGI middleware answering valid ``POST /api/cognize`` requests itself, the hot path
    of a robot asking many times a second, without FastAPI's per-request machinery (routing,
    dependency solving, its middleware stack): that machinery costs several times the cognition.

    Anything else, and every request it cannot answer (not JSON, invalid, an unknown value),
    goes to the FastAPI application with the body replayed, so the route in ``create_app``
    documents the endpoint in OpenAPI and words every error; a test checks that both give the
    same answers.
    """

    def __init__(self, app: Any, runtime: Runtime) -> None:
        self.app = app
        self.runtime = runtime

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["path"] != "/api/cognize" or scope["method"] != "POST":
            return await self.app(scope, receive, send)
        kind = next((v for k, v in scope["headers"] if k == b"content-type"), b"")
        if kind.split(b";")[0].strip().lower() != b"application/json":
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
            request = CognizeIn.model_validate_json(body)
            if self.runtime.lock.locked():  # a correction is being stored: wait off the loop
                answer = await asyncio.to_thread(self.runtime.cognize_json, request.context, request.user)
            else:
                answer = self.runtime.cognize_json(request.context, request.user)
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

    def __init__(self, app: Any, limit: int) -> None:
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
