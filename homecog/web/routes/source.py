"""``GET /api/source``: where the context comes from and whether it is connected (the page's
connection indicator)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from homecog.web.deps import RuntimeDep
from homecog.web.home_models import SourceOut

router = APIRouter(tags=["context"])


@router.get("/api/source", response_model=SourceOut, response_model_exclude_none=True)
def get_source(runtime: RuntimeDep) -> Any:
    """Where the context comes from (``simulated``, ``manual``, ``mqtt``, ``home_assistant``)
    and whether it is connected now; Home Assistant adds its version, reconnections, the
    states skipped and the last error."""
    return runtime.source.status()
