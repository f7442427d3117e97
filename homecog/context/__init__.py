"""Context sources: where the running robot learns the state of the home (SPEC §10).

A source gives the whole context — every feature and every device, values written as in a
scenario file (``{"time": "07:00", "temperature": "25", "location": "bed", "window": "off",
…}``) — and carries out the robot's IoT switch commands. The simulated home
(:mod:`homecog.context.simulated`) lives through days at an accelerated clock; the MQTT bridge
(:mod:`homecog.context.mqtt`) reads a real home's broker.
"""

from __future__ import annotations

from typing import Protocol


class ContextSource(Protocol):
    """What the running system needs of a source of context."""

    def snapshot(self) -> dict[str, str]:
        """The current context: every feature and device of the home, as text."""
        ...

    def switch(self, device: str, on: bool) -> None:
        """Carry out the robot's IoT command to switch ``device``."""
        ...
