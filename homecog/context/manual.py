"""A context set by hand (``PUT /api/context``, ``homecog serve``): nothing moves by itself.

>>> from homecog.home import load_home
>>> source = ManualSource(load_home("paper"))
>>> source.snapshot()["window"], source.snapshot()["location"]
('off', 'table')
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from homecog.context import ChangeNotifier, DeviceChange
from homecog.errors import ContextError
from homecog.home.clock import format_clock
from homecog.home.model import Home, format_number
from homecog.home.states import state_word


class ManualSource(ChangeNotifier):
    """A context set by hand; starts at each feature's first bin or value (a numeric feature at
    the lower end of its first finite bin) with every device off. The robot's switches are
    reported as changes of the home; devices set by :meth:`set_context` as set by hand."""

    ready = True

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
        self._set(device, state_word(on), "home")

    def set_context(self, values: Mapping[str, object]) -> None:
        for name, value in values.items():
            if name in self.home.device_names:
                self._set(name, str(value), "manual")
            else:
                self._values[name] = str(value)

    def _set(self, device: str, word: str, origin: Any) -> None:
        before = dict(self._values)
        self._values[device] = word
        if before[device] != word:
            self._tell(DeviceChange(device, word == "on", before, self.clock(), origin=origin))

    def status(self) -> dict[str, Any]:
        return {"kind": "manual", "connected": True}
