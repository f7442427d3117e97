"""``POST /api/corrections``: the services a user wants in a context; the robot learns at once.

The body gives ``want``, the whole set wanted (as the HMI sends it), or ``change``, some
services each ``"add"`` or ``"reject"`` (as ``homecog correct --add/--reject``): the others keep
what they had. An object cannot name a service twice, so no correction both adds and rejects
one; a body whose JSON names a key twice (which JSON parsers read as the last) is refused.
"""

import json
from collections.abc import Callable, Coroutine
from typing import Any

import anyio
import pydantic_core
from fastapi import APIRouter, Request, Response
from fastapi.routing import APIRoute

from homecog.home.codec import parse_services
from homecog.knowledge.correction import Correction
from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import CorrectionOut, HomeModels


class TwiceNamedError(ValueError):
    """A JSON object of the body names a key twice."""


def _once(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """``object_pairs_hook`` of :func:`json.loads`: an object, refused if it names a key twice."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise TwiceNamedError(key)
        out[key] = value
    return out


class OnceNamedRoute(APIRoute):
    """A route whose JSON body may not name a key twice: ``{"change": {"LampOn": "add",
    "LampOn": "reject"}}`` would otherwise be read as a rejection alone."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handle = super().get_route_handler()

        async def handler(request: Request) -> Response:
            body = await request.body()
            try:  # first the fast parser, which stops at 200 levels: Python's would take 20 ms
                pydantic_core.from_json(body)  # of the event loop over 64 KiB of brackets
            except ValueError:
                return await handle(request)  # not JSON: FastAPI words it
            try:
                json.loads(body, object_pairs_hook=_once)
            except TwiceNamedError as e:
                detail = f"body: {e.args[0]!r} is given twice in one object; give each name once"
                return Response(json.dumps({"detail": detail}), 422, media_type="application/json")
            except (ValueError, RecursionError):
                pass  # not JSON (or not UTF-8, or nested too deeply): FastAPI words it
            return await handle(request)

        return handler


#: corrections stored and learned at once, at most (the others wait their turn)
CORRECTING = 2


def router(models: HomeModels) -> APIRouter:
    """The correction route of one home."""
    r = APIRouter(tags=["cognition"], route_class=OnceNamedRoute)

    # corrections take turns on at most CORRECTING threads: however many clients correct at
    # once, cognition on the event loop competes with that many for the interpreter
    turns = anyio.CapacityLimiter(CORRECTING)

    @r.post("/api/corrections", response_model=CorrectionOut, responses=responses(413, 422, 503))
    async def correct(body: models.correction_in, runtime: RuntimeDep) -> CorrectionOut:
        """The services the user wants in the context: the whole set (`want`), or some services
        each added or rejected (`change`), every other service keeping what it had. The robot
        learns at once, for that user, and the experience log keeps it. 503 when the knowledge
        database cannot be used."""
        point = runtime.space.point(body.context)
        if "change" in body.model_fields_set:
            adds = [s for s, verdict in body.change.items() if verdict == "add"]
            rejects = [s for s, verdict in body.change.items() if verdict == "reject"]
            c = Correction.change(body.user, point, add=adds, reject=rejects)
        else:
            c = Correction.whole(body.user, point, parse_services(body.want, runtime.home))
        return CorrectionOut(**await anyio.to_thread.run_sync(runtime.correct, c, limiter=turns))

    return r
