"""The HTTP API of the running robot, with OpenAPI at ``/docs`` and ``/openapi.json``.

========================  ===================================================================
``GET /api/home``         the home: features, devices, services, floor plan
``GET /api/context``      the current context, as ``POST /api/cognize`` takes it
``GET /api/source``       where the context comes from, and whether it is connected
``PUT /api/context``      manual mode: set some features or devices
``POST /api/cognize``     ``{"context": {...}, "user": ...}`` → services, unknown, explanations
``POST /api/corrections`` ``{"context": {...}, "want": [...], "user": ...}`` → added, rejected
                          (or ``"change": {"S1": "add", "S2": "reject"}``: those services only)
``POST /api/answers``     ``{"context", "service", "answer": "yes"|"no", "user"}``: one proposal
                          answered, learned as that service added or rejected
``POST /api/plan``        ``{"services": [...], "context": {...}}`` → actions, tree, simulation
``GET /api/history``      corrections so far and how the robot's agreement with users grew
``GET /api/actions``      what the robot did lately, when and why; what the household did
``POST /api/actions/…``   ``/{id}/undo``: switch back what it did, learned as a rejection
``GET /api/switches``     the household's switches by hand and undos, day by day
``GET /api/events``       a live stream of server-sent events: context, correction, action
``POST /api/session``     the token kept in an HttpOnly cookie for a browser (the page's way)
========================  ===================================================================

The schema is made for the served home (:mod:`homecog.web.models`). With a token every
``/api`` endpoint needs it (:mod:`homecog.web.deps`); the page and the schema do not. Bodies
over 64 KiB get 413; every error is ``{"detail": "..."}`` (:mod:`homecog.web.errors`).
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Security
from starlette.types import ASGIApp

from homecog.robot.runtime import Runtime
from homecog.web import errors
from homecog.web.body_limit import BodyLimit
from homecog.web.cross_site import CrossSiteGuard
from homecog.web.deps import require_token, require_token_or_query
from homecog.web.models import HomeModels
from homecog.web.planner import PLANNER
from homecog.web.routes import (
    actions,
    answers,
    cognize,
    context,
    corrections,
    events,
    history,
    home,
    page,
    plan,
    session,
    source,
)
from homecog.web.settings import Settings

#: The answers ``homecog serve`` itself gives on every operation of a home, before the home's
#: app: an unknown home, a database that cannot be used, a home whose stored file does not load.
FLEET_ERRORS = (404, 409, 503)


def create_app(runtime: Runtime, settings: Settings | None = None, *, fleet: bool = False) -> ASGIApp:
    """The ASGI application serving ``runtime``.

    It is the FastAPI application (routes, OpenAPI; :func:`api`) behind two plain ASGI layers:
    the cross-site guard, then the body limit. With
    ``settings.live``, the server's clock moves the home that many simulated seconds per real
    second, and the robot acts on what it proposes. ``fleet``: one home of ``homecog serve``
    (:mod:`homecog.fleet.serve`): only the routes whose state the database holds (the home,
    cognition, corrections, plans, the history), no page, no context, no events.
    """
    settings = settings if settings is not None else Settings()
    models = HomeModels.of(runtime.home)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        task = asyncio.create_task(_live(runtime, settings.live)) if settings.live else None
        yield
        if task is not None:
            task.cancel()
        PLANNER.close()

    app = FastAPI(
        title=f"homecog: {runtime.home.name}",
        summary="Service cognition for a home service robot",
        version="0.1.0",
        lifespan=lifespan,
    )
    app.state.runtime, app.state.settings, app.state.models = runtime, settings, models
    errors.install(app, runtime.home)
    # what the fleet's own layer may answer on every operation of a home (homecog.fleet.serve):
    # the home gone from the database, the database unusable, the home's stored file unusable
    shared = errors.responses(*FLEET_ERRORS) if fleet else {}
    guarded: dict[str, Any] = {"responses": shared}
    if settings.token is not None:
        guarded = {
            "dependencies": [Security(require_token)],
            "responses": {**shared, **errors.responses(401)},
        }
    cognize.add(app, models, **guarded)  # first: the most asked for is the first route matched
    if not fleet:
        app.include_router(page.router)  # after cognition, the most asked for
    app.include_router(home.router, **guarded)
    makers = (corrections.router, plan.router)
    for make in makers if fleet else (context.router, *makers):
        app.include_router(make(models), **guarded)
    app.include_router(history.router, **guarded)
    if fleet:
        return CrossSiteGuard(BodyLimit(app, limit=settings.max_body))
    app.include_router(answers.router(models), **guarded)
    app.include_router(source.router, **guarded)
    app.include_router(actions.router, **guarded)
    app.include_router(session.router, **guarded)
    if settings.token is not None:
        guarded = {
            "dependencies": [Security(require_token_or_query)],
            "responses": errors.responses(401, stream=True),
        }
    app.include_router(events.router, **guarded)
    return CrossSiteGuard(BodyLimit(app, limit=settings.max_body))


def api(app: ASGIApp) -> FastAPI:
    """The FastAPI application of an app :func:`create_app` made (its routes and OpenAPI),
    behind the plain ASGI layers in front of it."""
    while not isinstance(app, FastAPI):
        app = app.app  # type: ignore[attr-defined]  # CrossSiteGuard, BodyLimit
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
