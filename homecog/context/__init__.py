"""Context sources: where the running robot learns the state of the home (SPEC §10).

A source gives the whole context — every feature and every device, values written as in a
scenario file (``{"time": "07:00", "temperature": "25", "location": "bed", "window": "off",
…}``) — and carries out the robot's IoT switch commands. The simulated home
(:mod:`homecog.context.simulated`) lives through days at an accelerated clock; the MQTT bridge
(:mod:`homecog.context.mqtt`) reads a real home's broker.
"""

from __future__ import annotations

import threading
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

    def status(self) -> dict[str, Any]:  # pragma: no cover - each source says its own
        raise NotImplementedError
