"""``GET /``: the HMI, one page. It holds no data of the home, so it needs no token: it asks
for the token when the API answers 401 and keeps it in the browser (``localStorage``)."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from fastapi.responses import HTMLResponse

router = APIRouter()
PAGE = (Path(__file__).parent.parent / "static" / "index.html").read_text(encoding="utf-8")


@router.get("/", response_class=HTMLResponse, include_in_schema=False)
async def index() -> str:
    """The HMI: the home now, the robot's services and why, the user's services, the plan,
    the corrections; one page that works on a phone."""
    return PAGE
