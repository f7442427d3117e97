"""The running robot behind the web interface: the home, its knowledge, a context source, and
what happened (corrections, agreement), shared by the HTTP routes.

>>> from homecog.home import load_home
>>> source = ManualSource(load_home("paper"))
>>> source.snapshot()["window"], source.snapshot()["location"]
('off', 'table')
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import orjson

from homecog.context import ContextSource
from homecog.errors import ContextError
from homecog.home.model import Home, format_clock, format_number
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.space import Space, parse_services
from homecog.knowledge.store import Store


class ManualSource:
    """A context set by hand (``PUT /api/context``); starts at each feature's first bin or value
    (a numeric feature at the lower end of its first finite bin) with every device off."""

    def __init__(self, home: Home) -> None:
        self.home = home
        values: dict[str, str] = {}
        for f in home.features:
            if f.kind == "categorical":
                values[f.name] = f.values[0]
            elif f.kind == "clock":
                values[f.name] = format_clock(f.bins[0][0])  # type: ignore[index]
            else:
                low, high = f.bins[0]  # type: ignore[index]
                values[f.name] = format_number(low if low > float("-inf") else high - 1)
        values.update({d.name: "off" for d in home.devices})
        self._values = values

    def snapshot(self) -> dict[str, str]:
        return dict(self._values)

    def switch(self, device: str, on: bool) -> None:
        if device not in self.home.device_names:
            raise ContextError(f"unknown device {device!r}")
        self._values[device] = "on" if on else "off"

    def set_context(self, values: Mapping[str, object]) -> None:
        self._values.update({k: str(v) for k, v in values.items()})


@dataclass
class Correction:
    """One correction as the history shows it."""

    at: float
    user: str
    context: dict[str, str]
    want: list[str]
    predicted: list[str]
    added: list[str]
    rejected: list[str]

    @property
    def agreed(self) -> bool:
        return set(self.want) == set(self.predicted)


@dataclass
class Runtime:
    """Everything the routes share. Cognition and corrections hold ``lock``: the tree is not
    thread-safe, FastAPI runs plain route functions (corrections) in a thread pool, and
    cognition runs on the event loop unless ``lock`` is held (see ``CognizeFastPath``)."""

    home: Home
    store: Store
    tree: IHDRTree
    source: ContextSource
    token: str | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    history: deque[Correction] = field(default_factory=lambda: deque(maxlen=500))
    watchers: list[Callable[[dict[str, str]], object]] = field(default_factory=list)
    _subscribers: set[asyncio.Queue[str]] = field(default_factory=set)
    _sent: dict[str, tuple[dict[str, str], str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.space = Space(self.home)

    # -- context ------------------------------------------------------------------------------
    def context(self) -> dict[str, str]:
        return self.source.snapshot()

    def set_context(self, values: Mapping[str, object]) -> dict[str, str]:
        """Manual mode: change some features or devices; the whole result must be valid."""
        unknown = [k for k in values if k not in self.space.names]
        if unknown:
            raise ContextError(f"unknown feature or device {unknown[0]!r}")
        merged = {**self.source.snapshot(), **{k: str(v) for k, v in values.items()}}
        self.space.point(merged)  # raises ContextError naming what is wrong
        setter = getattr(self.source, "set_context", None)
        if setter is None:
            raise ContextError("the context comes from the simulator or a broker; it cannot be set by hand")
        setter(values)
        self.publish("context", self.context())
        return self.context()

    # -- cognition and corrections -------------------------------------------------------------
    def cognize(self, context: Mapping[str, object], user: str) -> dict[str, Any]:
        point = self.space.point(context)
        with self.lock:
            return self.tree.explain_one(point, user=user).as_dict()

    def cognize_json(self, context: Mapping[str, object], user: str) -> bytes:
        """:meth:`cognize` as JSON, the same object; orjson writes the dataclasses directly."""
        point = self.space.point(context)
        with self.lock:
            answer = self.tree.explain_one(point, user=user)
        return orjson.dumps(answer)

    def correct(self, context: Mapping[str, object], want: list[str], user: str) -> dict[str, Any]:
        point = self.space.point(context)
        wanted = parse_services(want, self.home)
        with self.lock:
            predicted = self.tree.predict_one(point, user=user)
            added, rejected = self.store.correct(self.tree, point, wanted, user)
            experiences = self.store.experience_count()
        correction = Correction(
            at=time.time(),
            user=user,
            context=self.space.context(point),
            want=wanted,
            predicted=predicted,
            added=added,
            rejected=rejected,
        )
        self.history.append(correction)
        self.publish("correction", {"user": user, "want": wanted, "added": added, "rejected": rejected})
        return {"added": added, "rejected": rejected, "experiences": experiences, "user": user}

    def agreement(self, user: str | None = None) -> list[dict[str, Any]]:
        """Per correction in order: whether the robot had already proposed what the user wanted,
        and the running rate of that agreement."""
        out, agreed = [], 0
        rows = [c for c in self.history if user is None or c.user == user]
        for i, c in enumerate(rows, start=1):
            agreed += c.agreed
            out.append({"n": i, "user": c.user, "agreed": c.agreed, "rate": agreed / i})
        return out

    # -- the living home ------------------------------------------------------------------------
    def tick(self, seconds: float, *, act: bool = True, user: str = "default") -> bool:
        """Let a simulated source live ``seconds`` of simulated time; then, if ``act``, the robot
        carries out the IoT switches of the services it proposes there. True if the context changed."""
        if not getattr(self.source, "ready", True):  # a broker has not sent every state yet
            return False
        advance = getattr(self.source, "advance", None)
        before = self.source.snapshot()
        if advance is not None:
            advance(seconds)
        if act:
            now = self.source.snapshot()
            point = self.space.point(now)
            with self.lock:
                proposed = self.tree.predict_one(point, user=user)
            iot = {d.name for d in self.home.devices if d.iot}
            for name in proposed:
                for device, on in self.home.services[self.home.service_index(name)].sets:
                    wanted = "on" if on else "off"
                    # one command per change of the home, not one a tick while a device is slow to report
                    if device in iot and now[device] != wanted and self._sent.get(device) != (now, wanted):
                        self._sent[device] = (now, wanted)
                        self.source.switch(device, on)
        after = self.source.snapshot()
        if after != before:
            self.publish("context", after)
        return after != before

    # -- the live event stream -----------------------------------------------------------------
    def subscribe(self) -> asyncio.Queue[str]:
        """A queue of server-sent events; call from the event loop."""
        self._loop = asyncio.get_running_loop()
        queue: asyncio.Queue[str] = asyncio.Queue(maxsize=100)
        self._subscribers.add(queue)
        return queue

    def unsubscribe(self, queue: asyncio.Queue[str]) -> None:
        self._subscribers.discard(queue)

    def switch(self, device: str, on: bool) -> None:
        """Switch a device of the home, as an IoT command from outside (a broker) does."""
        self.source.switch(device, on)
        self.publish("context", self.context())

    def publish(self, kind: str, data: object) -> None:
        """Send an event to every open stream, from any thread (a slow reader loses old events,
        not the server); a new context also goes to every watcher (a failing one is logged)."""
        if kind == "context":
            for watcher in self.watchers:
                try:
                    watcher(data)  # type: ignore[arg-type]
                except Exception:
                    logging.getLogger("homecog.web").exception("a context watcher failed")
        loop = getattr(self, "_loop", None)
        if loop is None or loop.is_closed() or not self._subscribers:
            return
        message = f"event: {kind}\ndata: {json.dumps(data)}\n\n"
        loop.call_soon_threadsafe(self._deliver, message)

    def _deliver(self, message: str) -> None:
        for queue in list(self._subscribers):
            if queue.full():
                with contextlib.suppress(asyncio.QueueEmpty):
                    queue.get_nowait()
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(message)
