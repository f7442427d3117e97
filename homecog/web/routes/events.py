"""``GET /api/events``: a live stream of server-sent events.

``context`` (the whole context, as ``GET /api/context`` gives it) first and whenever the home
changes; ``correction`` (``{"user", "want", "added", "rejected", "kind"}``, and ``"concerns"``
where it spoke of some services only) when one is stored. A comment line keeps the connection
alive every 15 s.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterable
from typing import Annotated, Any

from fastapi import APIRouter, Depends, HTTPException
from fastapi.sse import EventSourceResponse, ServerSentEvent

from homecog.errors import ContextError
from homecog.robot.events import TooManyStreamsError
from homecog.web.deps import RuntimeDep
from homecog.web.errors import responses

router = APIRouter(tags=["context"])


async def _stream(runtime: RuntimeDep) -> asyncio.Queue[Any]:
    """A stream's queue, taken before the response starts: 503 when every stream is open."""
    try:
        return runtime.subscribe()
    except TooManyStreamsError as e:
        raise HTTPException(503, detail=str(e), headers={"Retry-After": "10"}) from None


@router.get("/api/events", response_class=EventSourceResponse, responses=responses(503, stream=True))
async def events(
    runtime: RuntimeDep, queue: Annotated[asyncio.Queue[Any], Depends(_stream)]
) -> AsyncIterable[ServerSentEvent]:
    """Server-sent events: ``context`` when the home changes, ``correction`` when one is made.
    503 while every stream the server keeps (100) is open."""
    try:
        # a broker that has not sent every state yet: the first context comes when it has
        with contextlib.suppress(ContextError, ValueError):
            yield ServerSentEvent(event="context", data=runtime.json_context())
        while True:
            kind, data = await queue.get()
            yield ServerSentEvent(event=kind, data=data)
    finally:
        runtime.unsubscribe(queue)
