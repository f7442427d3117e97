"""``GET /api/context`` and ``PUT /api/context``: the home now, and setting it by hand."""

from typing import Any

from fastapi import APIRouter, HTTPException

from homecog.errors import ContextError, FixedContextError
from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import HomeModels


def router(models: HomeModels) -> APIRouter:
    """The context routes of one home."""
    r = APIRouter(tags=["context"])

    @r.get("/api/context", response_model=models.context, responses=responses(503))
    def get_context(runtime: RuntimeDep) -> Any:
        """The current context: every feature and device, as ``POST /api/cognize`` takes it."""
        try:
            return runtime.json_context()
        except (ContextError, ValueError) as e:  # a broker that has not sent every state yet
            raise HTTPException(503, detail=str(e)) from None

    @r.put("/api/context", response_model=models.context, responses=responses(409, 413, 422, 503))
    def put_context(body: models.context_in, runtime: RuntimeDep) -> Any:
        """Set some features or devices by hand (the simulated home holds them); answers the
        whole new context. 409 where the context comes from a broker."""
        try:
            return runtime.set_context(body.values)
        except FixedContextError as e:
            raise HTTPException(409, detail=str(e)) from None

    return r
