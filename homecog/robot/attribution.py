"""Whose change is it: the robot's own switch, reported back by the home, or a
person's — or nobody's, an automation's, or set by hand through the API.

A change the robot commanded and then sees reported is its own: every command is expected for a
while (:data:`EXPECT_SECONDS` of the source's clock) and the first report of that device in that
state answers it. Any other change of a device is a person's; Home Assistant also says whose.

>>> from homecog.context import DeviceChange
>>> who = Attribution()
>>> who.expect("lamp", True, at=100.0)
>>> who.whose(DeviceChange("lamp", True, {}, 100.5))
'robot'
>>> who.whose(DeviceChange("lamp", False, {}, 160.0))
'person'
>>> who.whose(DeviceChange("lamp", True, {}, 170.0, automation=True))
'automation'
"""

from __future__ import annotations

import threading
from typing import Literal

from homecog.context import DeviceChange

Who = Literal["robot", "person", "automation", "manual"]
#: how long a command waits for its report (seconds of the source's clock)
EXPECT_SECONDS = 60.0


class Attribution:
    """The robot's commands waiting for their reports, and the judge of each change."""

    def __init__(self, expect_seconds: float = EXPECT_SECONDS) -> None:
        self.expect_seconds = expect_seconds
        self._pending: dict[str, list[tuple[bool, float]]] = {}
        self._lock = threading.Lock()

    def expect(self, device: str, on: bool, *, at: float) -> None:
        """The robot commands ``device`` to ``on`` now."""
        with self._lock:
            pending = [(o, t) for o, t in self._pending.get(device, []) if at - t <= self.expect_seconds]
            self._pending[device] = [*pending, (on, at)]

    def forget(self, device: str, on: bool) -> None:
        """A command that failed: no report of it will come."""
        with self._lock:
            pending = self._pending.get(device, [])
            for i, (state, _) in enumerate(pending):
                if state == on:
                    del pending[i]
                    break

    def whose(self, change: DeviceChange) -> Who:
        """Who made ``change``; a report that answers a command uses the command up."""
        if change.origin == "manual":
            return "manual"
        with self._lock:
            pending = [
                (on, t)
                for on, t in self._pending.get(change.device, [])
                if change.at - t <= self.expect_seconds
            ]
            for i, (on, _) in enumerate(pending):
                if on == change.on:
                    del pending[i]
                    self._pending[change.device] = pending
                    return "robot"
            self._pending[change.device] = pending
        return "automation" if change.automation else "person"
