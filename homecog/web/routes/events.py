"""``GET /api/events``: a live stream of server-sent events.

``context`` (the whole context, as ``GET /api/context`` gives it) first and whenever the home
changes; ``correction`` (``{"user", "want", "added", "rejected", "kind"}``, and ``"concerns"``
where it spoke of some services only) when one is stored. A comment line keeps the connection
alive every 15 s.
"""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterable

from fastapi import APIRouter
from fastapi.sse import EventSourceResponse, ServerSentEvent

from homecog.errors import ContextError
from homecog.web.deps import RuntimeDep

router = APIRouter(tags=["context"])


@router.get("/api/events", response_class=EventSourceResponse)
async def events(runtime: RuntimeDep) -> AsyncIterable[ServerSentEvent]:
    """Server-sent events: ``context`` when the home changes, ``correction`` when one is made."""
    queue = runtime.subscribe()
    try:
        # a broker that has not sent every state yet: the first context comes when it has
        with contextlib.suppress(ContextError, ValueError):
            yield ServerSentEvent(event="context", data=runtime.json_context())
        while True:
            kind, data = await queue.get()
            yield ServerSentEvent(event=kind, data=data)
    finally:
        runtime.unsubscribe(queue)
