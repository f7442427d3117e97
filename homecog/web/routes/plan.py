"""``POST /api/plan``: services decomposed into robot actions and carried out in the simulator."""

from fastapi import APIRouter
from fastapi.responses import Response

from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import HomeModels, PlanOut
from homecog.web.planner import PLANNER


def router(models: HomeModels) -> APIRouter:
    """The planning route of one home."""
    r = APIRouter(tags=["planning"])

    @r.post("/api/plan", response_model=PlanOut, responses=responses(409, 413, 422, 429))
    async def plan(body: models.plan_in, runtime: RuntimeDep) -> Response:
        """The services decomposed into robot actions, in the given order, and the plan carried
        out by the simulated robot on the floor plan: its timeline, time, distance and
        trajectory (``[t, x, y]`` rows, at most 400, metres and seconds). 409 for a home
        without a floor plan, or a plan the robot cannot carry out there; 429 when the planner
        is busy with other plans (it makes one at a time, off the server's own work)."""
        answer = await PLANNER.plan(runtime.home, body.services, body.context, runtime.robot)  # checked there
        return Response(answer, media_type="application/json")

    return r
