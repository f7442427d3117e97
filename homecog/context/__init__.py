"""Context sources: where the running robot learns the state of the home.

A source gives the whole context — every feature and every device, values written as in a
scenario file (``{"time": "07:00", "temperature": "25", "location": "bed", "window": "off",
…}``) — carries out the robot's IoT switch commands, and tells its listeners of every change of
a device as it sees it (:class:`DeviceChange`), with the context just before it, so the running
robot can tell its own switches from a person's (:mod:`homecog.robot.attribution`). The
simulated home (:mod:`homecog.context.simulated`) lives through days at an accelerated clock;
the MQTT bridge (:mod:`homecog.context.mqtt_source`) reads a real home's broker; Home Assistant
(:mod:`homecog.context.home_assistant`) also says who made each change; a context set by hand
is :mod:`homecog.context.manual`'s.

>>> from homecog.home import load_home
>>> from homecog.context.manual import ManualSource
>>> source = ManualSource(load_home("paper"))
>>> seen = []
>>> source.listen(seen.append)
>>> source.switch("lamp", True)
>>> seen[0].device, seen[0].on, seen[0].before["lamp"]
('lamp', True, 'off')
>>> isinstance(source, ContextSource), isinstance(source, SettableSource)
(True, True)
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal, Protocol, Self, runtime_checkable

log = logging.getLogger(__name__)

#: where a change comes from as far as the source knows: the home (a device reported, or the
#: simulated household's hand: whoever did it, the robot tells), or set by hand through the
#: API (``PUT /api/context``), which describes the home rather than switching it
Origin = Literal["home", "manual"]


@dataclass(frozen=True)
class DeviceChange:
    """A device seen switching.

    ``before`` is the whole context just before the change (``None`` while the source has not
    had every value yet); ``at`` the source's clock (seconds since 1970; simulated time in the
    simulated home); ``user`` who made it where the source says (Home Assistant: the user id of
    the change's context); ``automation`` whether an automation made it (a context with a
    parent).
    """

    device: str
    on: bool
    before: dict[str, str] | None
    at: float
    user: str | None = None
    automation: bool = False
    origin: Origin = "home"


ChangeListener = Callable[[DeviceChange], None]


@runtime_checkable
class ContextSource(Protocol):
    """What the running system needs of a source of context."""

    def snapshot(self) -> dict[str, str]:
        """The current context: every feature and device of the home, as text."""
        ...

    def switch(self, device: str, on: bool) -> object:
        """Carry out the robot's IoT command to switch ``device``."""
        ...

    @property
    def ready(self) -> bool:
        """Whether every value is there and the robot may act on them."""
        ...

    def clock(self) -> float:
        """The source's clock, seconds since 1970 (the simulated home's own)."""
        ...

    def listen(self, listener: ChangeListener) -> None:
        """Call ``listener`` with every device change from now on (on the source's thread)."""
        ...

    def status(self) -> dict[str, Any]:
        """Where the context comes from (``kind``) and whether it is ``connected``, and more
        where the source says more."""
        ...


@runtime_checkable
class LivingSource(ContextSource, Protocol):
    """A source whose time the caller moves (the simulated home)."""

    def advance(self, seconds: float) -> None: ...


@runtime_checkable
class SettableSource(ContextSource, Protocol):
    """A source whose features and devices can be set by hand (``PUT /api/context``)."""

    def set_context(self, values: Any) -> None: ...


class ChangeNotifier:
    """The listeners of a source and how it tells them; a failing listener is logged."""

    _listeners: list[ChangeListener]

    def listen(self, listener: ChangeListener) -> None:
        if not hasattr(self, "_listeners"):
            self._listeners = []
        self._listeners.append(listener)

    def _tell(self, change: DeviceChange) -> None:
        for listener in getattr(self, "_listeners", ()):
            try:
                listener(change)
            except Exception:
                log.exception("a listener of device changes failed on %s", change)

    def clock(self) -> float:
        return time.time()


class ConnectedSource(ChangeNotifier):
    """What the sources over a network share: a connection that a background thread keeps (set
    ``_connected`` when it is up), started and stopped as a context manager."""

    _connected: threading.Event
    _changed: threading.Condition  # notified whenever a value arrives
    _values: dict[str, str]
    _names: list[str]  # the names whose values come over the network

    def start(self) -> Self:
        raise NotImplementedError

    def stop(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @property
    def connected(self) -> bool:
        """Whether the connection is up now."""
        return self._connected.is_set()

    def snapshot(self) -> dict[str, str]:  # pragma: no cover - each source says its own
        raise NotImplementedError

    def wait_ready(self, timeout: float) -> dict[str, str]:
        """The snapshot once every value has arrived; :class:`ContextError` after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        with self._changed:
            while any(n not in self._values for n in self._names):
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._changed.wait(left)
        return self.snapshot()

    def status(self) -> dict[str, Any]:  # pragma: no cover - each source says its own
        raise NotImplementedError
