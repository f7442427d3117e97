"""``GET /api/home``: the home's features, devices, services and floor plan."""

from __future__ import annotations

from fastapi import APIRouter

from homecog.web.deps import RuntimeDep
from homecog.web.home_models import HomeOut, home_out

router = APIRouter(tags=["home"])


@router.get("/api/home", response_model=HomeOut)
def get_home(runtime: RuntimeDep) -> HomeOut:
    """The home's features (with values), devices and services, and its floor plan (null
    without one): size, rooms and walls and doors as rectangles and segments
    ``[x0, y0, x1, y1]``, places as points, the robot's start place; metres, y up."""
    return home_out(runtime.home)
