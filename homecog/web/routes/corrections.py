"""``POST /api/corrections``: the services a user wants in a context; the robot learns at once."""

from fastapi import APIRouter

from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses
from homecog.web.models import CorrectionOut, HomeModels


def router(models: HomeModels) -> APIRouter:
    """The correction route of one home."""
    r = APIRouter(tags=["cognition"])

    @r.post("/api/corrections", response_model=CorrectionOut, responses=responses(413, 422, 503))
    def correct(body: models.correction_in, runtime: RuntimeDep) -> CorrectionOut:
        """The services the user wants in the context: the robot learns at once, for that user,
        and the experience log keeps it. 503 when the knowledge database cannot be used."""
        return CorrectionOut(**runtime.correct(body.context, body.want, body.user))

    return r
