"""Context sources: where the running robot learns the state of the home (SPEC §10).

A source gives the whole context — every feature and every device, values written as in a
scenario file (``{"time": "07:00", "temperature": "25", "location": "bed", "window": "off",
…}``) — and carries out the robot's IoT switch commands. The simulated home
(:mod:`homecog.context.simulated`) lives through days at an accelerated clock; the MQTT bridge
(:mod:`homecog.context.mqtt`) reads a real home's broker.
"""

from __future__ import annotations

import threading
import time
from typing import Any, Protocol, Self


class ContextSource(Protocol):
    """What the running system needs of a source of context."""

    def snapshot(self) -> dict[str, str]:
        """The current context: every feature and device of the home, as text."""
        ...

    def switch(self, device: str, on: bool) -> None:
        """Carry out the robot's IoT command to switch ``device``."""
        ...


class ConnectedSource:
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
