"""The live stream of what happens in the running robot, for the HMI's server-sent events:
``context`` when the home changes, ``correction`` when one is learned (explicit, observed or an
undo), ``action`` when the robot acts. A slow reader loses old events, not the server.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from typing import Any

from homecog.knowledge.correction import Outcome

log = logging.getLogger("homecog.web")

Message = tuple[str, object]


#: the most event streams open at once (a household's pages are a handful)
MAX_STREAMS = 100


class TooManyStreamsError(RuntimeError):
    """Every stream the bus may hold is open."""


class EventBus:
    """Subscribers' queues on the server's event loop, fed from any thread; at most ``limit``
    of them (each open page holds one; unread streams cost every event its delivery)."""

    def __init__(self, limit: int = MAX_STREAMS) -> None:
        self._subscribers: set[asyncio.Queue[Message]] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self.limit = limit

    def subscribe(self) -> asyncio.Queue[Message]:
        """A queue of events ``(kind, data)``; call from the event loop.
        :class:`TooManyStreamsError` when ``limit`` are open."""
        if len(self._subscribers) >= self.limit:
            raise TooManyStreamsError(
                f"{self.limit} event streams are open, the most there may be; close one"
            )
        self._loop = asyncio.get_running_loop()
        queue: asyncio.Queue[Message] = asyncio.Queue(maxsize=100)
        self._subscribers.add(queue)
        return queue

    def unsubscribe(self, queue: asyncio.Queue[Message]) -> None:
        self._subscribers.discard(queue)

    @property
    def listening(self) -> bool:
        loop = self._loop
        return loop is not None and not loop.is_closed() and bool(self._subscribers)

    def send(self, kind: str, data: object) -> None:
        """Send an event to every open stream, from any thread."""
        if self.listening:
            assert self._loop is not None
            self._loop.call_soon_threadsafe(self._deliver, (kind, data))

    def _deliver(self, message: Message) -> None:
        for queue in list(self._subscribers):
            if queue.full():
                with contextlib.suppress(asyncio.QueueEmpty):
                    queue.get_nowait()
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(message)


def tell_all(watchers: list[Callable[[dict[str, str]], object]], context: dict[str, str]) -> None:
    """A new context to every watcher (a failing one is logged)."""
    for watcher in watchers:
        try:
            watcher(context)
        except Exception:
            log.exception("a context watcher failed")


def correction_event(outcome: Outcome) -> dict[str, Any]:
    """A correction as the live event stream tells it."""
    c = outcome.correction
    event = {
        "user": c.user,
        "want": list(c.want),
        "added": list(outcome.added),
        "rejected": list(outcome.rejected),
    }
    return {**event, "kind": c.kind, **({"concerns": list(c.concerns)} if c.concerns is not None else {})}
