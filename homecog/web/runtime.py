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
from homecog.context.simulated import SimulatedHome
from homecog.errors import ContextError, FixedContextError, PlanningError
from homecog.home.clock import format_clock
from homecog.home.codec import Space, parse_services
from homecog.home.model import Home, format_number
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.planning import Acting, State, acting, make_domain
from homecog.planning.state import device_states, observed_state
from homecog.simulation.body import SimulatedRobot
from homecog.web.models import json_context

log = logging.getLogger("homecog.web")


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
    acted: Acting | None = None
    """What the robot did last (:meth:`act`)."""
    _subscribers: set[asyncio.Queue[tuple[str, object]]] = field(default_factory=set)
    _sent: dict[str, dict[str, str]] = field(default_factory=dict)
    _proposed: set[str] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.space = Space(self.home)
        self.domain = make_domain(self.home)
        # In the simulated home the robot has a body on the floor plan: it drives, brings,
        # docks and switches by hand there. A real home (MQTT, Home Assistant) gets IoT switches.
        self.body = (
            SimulatedRobot(self.home, switch=self.source.switch, domain=self.domain)
            if isinstance(self.source, SimulatedHome) and self.home.layout is not None
            else None
        )

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
        carries out the services it proposes there (:meth:`act`). True if the context changed."""
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
            self.act(now, proposed)
        after = self.source.snapshot()
        if after != before:
            self.publish("context", after)
        return after != before

    def act(self, now: Mapping[str, str], proposed: list[str]) -> Acting | None:
        """Plan the proposed services that have something to do, in their order, and carry the
        plan out through acting: IoT switches through the context source, and in the simulated
        home everything else by the simulated robot. A failed command (the source raises) is
        replanned and logged, never raised. What was done is :attr:`acted` (``None``: nothing
        to do).

        A service that switches devices is done while one of them is not as it sets it, once
        per change of the home (not once a tick while a device is slow to report); without a
        body only by IoT. An errand (bring, dock, say) is done once each time it comes to be
        proposed, by the body."""
        iot = {d.name for d in self.home.devices if d.iot}
        devices = device_states(self.home, now)
        todo = []
        for name in proposed:
            sets = self.home.services[self.home.service_index(name)].sets
            if sets:
                pending = any(devices[d] != on for d, on in sets)
                reachable = self.body is not None or all(d in iot for d, _ in sets)
                if pending and reachable and self._sent.get(name) != now:
                    self._sent[name] = dict(now)
                    todo.append(name)
            elif self.body is not None and name not in self._proposed:
                todo.append(name)
        self._proposed = set(proposed)
        if not todo:
            return None
        try:
            state = self._observe()
            commands = acting.iot_commands(self.domain, self.source.switch)
            if self.body is not None:
                self.body.start(state)  # a new run on the floor plan, from where the robot is
                commands = self.body.commands()
            tasks = [(name,) for name in todo]
            result = acting.act(self.domain, state, tasks, commands, observe=self._observe)
        except PlanningError as e:  # the user at no place of the layout, say: the robot waits
            log.warning("the robot cannot plan %s: %s", ", ".join(todo), e)
            return None
        log.info("the robot did: %s", "; ".join(" ".join(a) for a in result.done) or "nothing")
        self.acted = result
        return result

    def _observe(self) -> State:
        """The home as the robot sees it: the source's context and, with a body, where it is."""
        world = self.body.observe() if self.body is not None else None
        return observed_state(self.home, self.source.snapshot(), world)

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
