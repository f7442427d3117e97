"""``POST /api/cognize``: the services a user needs in a context, in priority order, and why.

The hot path of a robot asking many times a second, and one route of FastAPI's: routed,
documented in OpenAPI and refused with FastAPI's words like every other. Its route class
(:class:`CognizeRoute`) answers a valid request itself — the body read once, validated in
Rust by the home's model (``model_validate_json``), the answer written by orjson — and hands
every other request (not JSON, not valid, without the token, or a cognition that fails) to
FastAPI's own handler of the same route, with the body already read: FastAPI's dependency
solving and response model are never on the way of a valid request, and never off the way of
a refused one (docs/design.md, "The HTTP server under load").
"""

import asyncio  # no ``from __future__ import annotations``: FastAPI reads the body's model
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import Response
from fastapi.routing import APIRoute
from pydantic import BaseModel, ValidationError

from homecog.errors import HomecogError
from homecog.web.deps import RuntimeDep, authorized
from homecog.web.errors import responses
from homecog.web.models import CognizeOut, HomeModels

Handler = Callable[[Request], Coroutine[Any, Any, Response]]


def add(app: FastAPI, models: HomeModels, **guarded: Any) -> None:
    """The cognition route of one home, added to ``app`` itself (not through an included
    router, whose dispatch costs more than the cognition): call it first, so that the most asked
    for route is the first one matched. ``guarded``: ``dependencies`` and ``responses`` as for
    ``include_router`` (the token's)."""

    async def cognize(body: models.cognize_in, runtime: RuntimeDep) -> Response:
        """The services the user needs in the context, in priority order, and why."""
        answer = await asyncio.to_thread(runtime.cognize_json, body.context, body.user)
        return Response(answer, media_type="application/json")

    app.router.add_api_route(
        "/api/cognize",
        cognize,
        methods=["POST"],
        response_model=CognizeOut,
        responses={**guarded.get("responses", {}), **responses(413, 422)},
        dependencies=guarded.get("dependencies"),
        tags=["cognition"],
        route_class_override=cognize_route(models.cognize_in),
    )


def cognize_route(model: type[BaseModel]) -> type[APIRoute]:
    """The route class of ``POST /api/cognize`` for a home whose request model is ``model``."""

    class CognizeRoute(APIRoute):
        """FastAPI's route, its handler answering the valid requests first (:func:`answer`)."""

        def get_route_handler(self) -> Handler:
            framework = super().get_route_handler()  # FastAPI's, with the token's dependency

            async def handler(request: Request) -> Response:
                answered = await answer(request, model)
                if answered is None:  # FastAPI's handler reads the body Starlette kept
                    return await framework(request)
                return Response(answered, media_type="application/json")

            return handler

    return CognizeRoute


async def answer(request: Request, model: type[BaseModel]) -> bytes | None:
    """The answer to a valid cognition request carrying the token (as JSON), or None for
    every other: FastAPI's handler answers it, or words why not."""
    headers = request.scope["headers"]
    state = request.app.state
    kind = dict(headers).get(b"content-type", b"")  # repeated: the last, not ours
    if kind.split(b";")[0].strip().lower() != b"application/json" or not authorized(
        headers, state.settings.token, "POST"
    ):
        return None
    body = await request.body()
    runtime = state.runtime
    try:
        asked = model.model_validate_json(body)
        context, user = asked.context, asked.user  # type: ignore[attr-defined]
        answered = runtime.cognize_json(context, user, wait=False)
        if answered is None:  # a lock held or the user's layer to learn: wait off the loop
            return await asyncio.to_thread(runtime.cognize_json, context, user)
        return answered
    except (ValidationError, HomecogError):
        return None
