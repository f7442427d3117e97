"""``POST /api/answers``: a user's yes or no to one of the robot's pending proposals (the page's
review step; :mod:`homecog.robot.review`)."""

from typing import Any

from fastapi import APIRouter, HTTPException

from homecog.errors import NotPendingError
from homecog.robot import review
from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import CorrectionOut, HomeModels


def router(models: HomeModels) -> APIRouter:
    """The answer route of one home."""
    r = APIRouter(tags=["cognition"])

    @r.post("/api/answers", response_model=CorrectionOut, responses=responses(409, 413, 422, 503))
    def answer(body: models.answer_in, runtime: RuntimeDep) -> Any:
        """Yes or no to one service the robot proposed to the user in the context: a yes is
        learned as a correction adding that service there, a no as one rejecting it; every other
        service keeps what it had. Pending: the services of the latest cognition answered for
        that user in that context (the same bins, values and device states), less those answered
        there since. 409 naming what is pending when the service is not, and nothing is stored."""
        yes = body.answer == "yes"
        try:
            return CorrectionOut(**review.answer(runtime, body.context, body.user, body.service, yes))
        except NotPendingError as e:
            raise HTTPException(409, detail=str(e)) from None

    return r
