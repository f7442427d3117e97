"""``GET /api/actions`` and ``POST /api/actions/{id}/undo``: what the robot did, when and why,
and its undo (the devices switched back, the services learned as rejections where it acted);
``GET /api/switches``: what the household switched by hand, day by day."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Path, Query

from homecog.errors import FixedContextError
from homecog.knowledge.history import switches_per_day
from homecog.web.action_models import ActionsOut, SwitchDayOut, SwitchesOut, UndoIn, UndoOut
from homecog.web.deps import RuntimeDep, StoreDep
from homecog.web.errors import responses
from homecog.web.models import ErrorOut

router = APIRouter(tags=["cognition"])
UNKNOWN = {404: {"model": ErrorOut, "description": "No action of this number among the robot's latest."}}


@router.get("/api/actions", response_model=ActionsOut, responses=responses(422))
def actions(
    runtime: RuntimeDep,
    limit: Annotated[int, Query(ge=1, le=100, description="At most this many (newest first).")] = 20,
) -> Any:
    """The robot's latest actions, newest first — the services it carried out, the devices it
    switched, why, and which switches were undone — and what the household did by hand."""
    return {"actions": [a.as_dict() for a in runtime.journal.recent(limit)], "household": runtime.status()}


@router.post(
    "/api/actions/{action}/undo",
    response_model=UndoOut,
    responses={**UNKNOWN, **responses(409, 413, 422, 503)},
)
def undo(
    runtime: RuntimeDep,
    action: Annotated[int, Path(ge=1, le=2**53, description="The action's number.")],
    body: UndoIn | None = None,
) -> Any:
    """Undo an action of the robot's: its switches are switched back (and left alone for the
    person), and its services are learned as not wanted where it acted, for the user. 409 for
    an action already undone."""
    try:
        return runtime.undo(action, body.user if body is not None else None)
    except LookupError as e:
        raise HTTPException(404, detail=str(e)) from None
    except FixedContextError as e:
        raise HTTPException(409, detail=str(e)) from None


@router.get("/api/switches", response_model=SwitchesOut, responses=responses(422, 503))
def switches(
    store: StoreDep,
    days: Annotated[int, Query(ge=1, le=92, description="This many days, up to today.")] = 14,
) -> SwitchesOut:
    """Per day, the devices the household switched by hand and the robot's actions it undid,
    read from the experience log (they outlive the server). 503 when the database cannot be
    used."""
    found = switches_per_day(store, days=days)
    return SwitchesOut(days=[SwitchDayOut(day=d.day, switches=d.switches, undos=d.undos) for d in found])
