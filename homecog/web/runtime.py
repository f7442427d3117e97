"""The running robot behind the web interface: the home, its knowledge and a context source,
shared by the HTTP routes. What happened (corrections, agreement) is read from the store's
experience log (:mod:`homecog.knowledge.history`), so it outlives the process.

>>> from homecog.home import load_home
>>> source = ManualSource(load_home("paper"))
>>> source.snapshot()["window"], source.snapshot()["location"]
('off', 'table')
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import orjson

from homecog.context import ContextSource
from homecog.errors import ContextError, HomecogError
from homecog.home.clock import format_clock
from homecog.home.codec import Space, parse_services
from homecog.home.model import Home, format_number
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.web.models import json_context


class FixedContextError(HomecogError):
    """The context comes from a source that cannot be set by hand (a broker)."""


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
class Runtime:
    """Everything the routes share. Cognition and corrections hold ``lock``: the tree is not
    thread-safe, FastAPI runs plain route functions (corrections) in a thread pool, and
    cognition runs on the event loop unless ``lock`` is held (see ``CognizeFastPath``)."""

    home: Home
    store: Store
    tree: IHDRTree
    source: ContextSource
    lock: threading.Lock = field(default_factory=threading.Lock)
    watchers: list[Callable[[dict[str, str]], object]] = field(default_factory=list)
    _subscribers: set[asyncio.Queue[tuple[str, object]]] = field(default_factory=set)
    _sent: dict[str, tuple[dict[str, str], str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.space = Space(self.home)

    # -- context ------------------------------------------------------------------------------
    def context(self) -> dict[str, str]:
        """The context as the source has it, as text; :class:`ContextError` while a broker has not
        sent every state yet."""
        return self.source.snapshot()

    def json_context(self) -> dict[str, str | float]:
        """The context as the HTTP contract writes it (numbers as numbers)."""
        return json_context(self.home, self.context())

    def set_context(self, values: Mapping[str, object]) -> dict[str, str | float]:
        """Manual mode: change some features or devices (valid values, as the contract checks
        them); :class:`FixedContextError` when the source cannot be set by hand."""
        setter = getattr(self.source, "set_context", None)
        if setter is None:
            raise FixedContextError("the context comes from a broker; it cannot be set by hand")
        unknown = [k for k in values if k not in self.space.names]
        if unknown:
            raise ContextError(f"unknown feature or device {unknown[0]!r}")
        typed = json_context(self.home, values)  # raises naming a value that does not fit
        text = {k: format_number(v) if isinstance(v, float) else v for k, v in typed.items()}
        self.space.point({**self.source.snapshot(), **text})  # the whole result must be valid
        setter(text)
        self.publish("context", self.context())
        return self.json_context()

    # -- cognition, corrections, plans ---------------------------------------------------------
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
        """Learn and store a correction; the store's log keeps it (and the history with it)."""
        point = self.space.point(context)
        wanted = parse_services(want, self.home)
        with self.lock:
            added, rejected = self.store.correct(self.tree, point, wanted, user)
        experiences = self.store.experience_count()  # outside the lock: cognition need not wait
        self.publish("correction", {"user": user, "want": wanted, "added": added, "rejected": rejected})
        return {"added": added, "rejected": rejected, "experiences": experiences, "user": user}

    def plan(self, services: list[str], context: Mapping[str, object] | None) -> dict[str, Any]:
        """The services decomposed into robot actions, in the given order, and the plan carried
        out by the simulated robot on the floor plan: its timeline, time, distance and
        trajectory (``[t, x, y]`` rows, at most 400). :class:`PlanningError` when it cannot be."""
        from homecog.planning import plan_services
        from homecog.simulation import simulate

        where = dict(self.space.context(self.space.point(context))) if context else None
        result = plan_services(self.home, services, context=where)
        sim = simulate(self.home, result.actions, state=result.start)
        simulation = sim.as_dict()
        del simulation["actions"]  # the same as the plan's
        simulation["trajectory"] = _thin(sim.trajectory, 400)
        return {
            "actions": [list(a) for a in result.actions],
            "tree": [n.as_dict() for n in result.tree],
            "simulation": simulation,
        }

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
    def subscribe(self) -> asyncio.Queue[tuple[str, object]]:
        """A queue of events ``(kind, data)`` for a server-sent event stream; call from the event
        loop."""
        self._loop = asyncio.get_running_loop()
        queue: asyncio.Queue[tuple[str, object]] = asyncio.Queue(maxsize=100)
        self._subscribers.add(queue)
        return queue

    def unsubscribe(self, queue: asyncio.Queue[tuple[str, object]]) -> None:
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
        if kind == "context":
            try:
                data = json_context(self.home, data)  # type: ignore[arg-type]
            except (ContextError, ValueError):
                logging.getLogger("homecog.web").exception("a context that does not fit the home")
                return
        loop.call_soon_threadsafe(self._deliver, (kind, data))

    def _deliver(self, message: tuple[str, object]) -> None:
        for queue in list(self._subscribers):
            if queue.full():
                with contextlib.suppress(asyncio.QueueEmpty):
                    queue.get_nowait()
            with contextlib.suppress(asyncio.QueueFull):
                queue.put_nowait(message)


def _thin(trajectory: np.ndarray, most: int) -> list[list[float]]:
    """At most ``most`` rows ``[t, x, y]`` of a trajectory, evenly spaced, first and last kept.

    >>> _thin(np.array([[t, t, 0, 0] for t in range(10)], dtype=float), 4)
    [[0.0, 0.0, 0.0], [3.0, 3.0, 0.0], [6.0, 6.0, 0.0], [9.0, 9.0, 0.0]]
    """
    n = len(trajectory)
    keep = np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int)) if n else []
    return [[round(float(t), 2), round(float(x), 3), round(float(y), 3)] for t, x, y, *_ in trajectory[keep]]
