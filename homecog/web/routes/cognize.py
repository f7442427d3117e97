"""``POST /api/cognize``: the services a user needs in a context, in priority order, and why.

The fast path (:mod:`homecog.web.fastpath`) answers the valid requests before they get here;
this route documents the endpoint and words the errors of the others.
"""

import asyncio

from fastapi import APIRouter
from fastapi.responses import Response

from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import CognizeOut, HomeModels


def router(models: HomeModels) -> APIRouter:
    """The cognition route of one home."""
    r = APIRouter(tags=["cognition"])

    @r.post("/api/cognize", response_model=CognizeOut, responses=responses(413, 422))
    async def cognize(body: models.cognize_in, runtime: RuntimeDep) -> Response:
        """The services the user needs in the context, in priority order, and why."""
        answer = await asyncio.to_thread(runtime.cognize_json, body.context, body.user)
        return Response(answer, media_type="application/json")

    return r
