"""``GET /api/history``: the corrections and how the robot's agreement with users grew, read
from the experience log (they outlive the server)."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query

from homecog.knowledge.history import agreement, correction_history
from homecog.web.deps import SettingsDep, StoreDep
from homecog.web.errors import responses
from homecog.web.models import AgreementOut, HistoryCorrectionOut, HistoryOut, User

router = APIRouter(tags=["cognition"])
#: the most corrections one page gives (a page of 1,000 is about 80 kB)
MAX_PAGE = 1_000


@router.get("/api/history", response_model=HistoryOut, responses=responses(422, 503))
def history(
    store: StoreDep,
    settings: SettingsDep,
    user: Annotated[User | None, Query(description="Only this user's.")] = None,
    limit: Annotated[
        int | None, Query(ge=1, le=MAX_PAGE, description="At most this many (default 500).")
    ] = None,
    before: Annotated[
        int | None, Query(ge=1, le=2**53, description="Only corrections older than this one (its id).")
    ] = None,
) -> HistoryOut:
    """The latest corrections (oldest first), a page at a time, and the running agreement over
    them: whether the robot had already proposed what the user wanted. 503 when the database
    cannot be used."""
    found = correction_history(store, user=user, limit=limit or settings.history_limit, before=before)
    return HistoryOut(
        total=found.total,
        before=found.before,
        corrections=[
            HistoryCorrectionOut(
                id=c.id,
                at=c.at,
                user=c.user,
                want=c.want,
                predicted=c.predicted,
                agreed=c.agreed,
                kind=c.kind,
                weight=c.weight,
                concerns=c.concerns,
            )
            for c in found.corrections
        ],
        agreement=[AgreementOut(n=a.n, user=a.user, agreed=a.agreed, rate=a.rate) for a in agreement(found)],
    )
