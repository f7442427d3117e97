"""The robot never flaps a device: a minimum time between its switches of one device,
hysteresis at the edges of numeric bins (the home file's ``min_on``, ``min_off`` and
``deadband``; :mod:`homecog.home.pacing` has the defaults), and at most :data:`MOST_AN_HOUR` of
its own switches of one device within any :data:`HOUR` (a switch past that is left to the
household).

>>> from homecog.home import load_home
>>> home = load_home("paper")   # ac_living is a climate device: 10 minutes either way
>>> pacing = Pacing(home)
>>> pacing.switched("ac_living", True, at=0.0)
>>> pacing.resting("ac_living", at=300.0), pacing.resting("ac_living", at=600.0)
(True, False)
>>> now = {"temperature": "25.3"}   # suitable from 25 °C; the deadband is 0.5 °C
>>> pacing.steady({"temperature": "24.9"})["temperature"], pacing.steady(now)["temperature"]
('24.9', '24.999999')
>>> pacing.steady({"temperature": "25.6"})["temperature"]
'25.6'
>>> pacing.robot_switched("lamp", at=0.0); pacing.robot_switched("lamp", at=1200.0)
>>> pacing.spent("lamp", at=3599.0), pacing.spent("lamp", at=3600.0)   # two within the hour
(True, False)
"""

from __future__ import annotations

import bisect
import threading
from collections import deque
from collections.abc import Mapping

from homecog.home.model import Home

#: how far inside the bin it keeps a reading that has not crossed an edge by the deadband
_INSIDE = 1e-6
#: the most switches of one device the robot makes within :data:`HOUR`
MOST_AN_HOUR = 2
#: the rolling window of :data:`MOST_AN_HOUR` (seconds)
HOUR = 3600.0


class Pacing:
    """Per device its latest switch (whoever made it) and the robot's own switches of the last
    hour; per numeric feature the bin the robot last saw."""

    def __init__(self, home: Home) -> None:
        self._least = {d.name: (d.min_off, d.min_on) for d in home.devices}
        self._last: dict[str, tuple[bool, float]] = {}
        self._bands = {
            f.name: (f.deadband, sorted({b[0] for b in f.bins[1:]}))  # type: ignore[index]
            for f in home.features
            if f.kind == "numeric" and f.deadband > 0 and f.bins
        }
        self._bin: dict[str, int] = {}
        self._robot: dict[str, deque[float]] = {}  # device -> the robot's switches within the hour
        self._lock = threading.Lock()

    def switched(self, device: str, on: bool, *, at: float) -> None:
        """A device was seen switching to ``on`` at ``at`` (by the robot or by anyone)."""
        with self._lock:
            self._last[device] = (on, at)

    def resting(self, device: str, *, at: float) -> bool:
        """Whether ``device`` switched less than its minimum time ago: the robot leaves it."""
        with self._lock:
            last = self._last.get(device)
        if last is None:
            return False
        on, since = last
        return at - since < self._least[device][int(on)]

    def robot_switched(self, device: str, *, at: float) -> None:
        """The robot switched ``device`` at ``at`` (its own command)."""
        with self._lock:
            times = self._robot.setdefault(device, deque())
            times.append(at)
            self._prune(times, at)

    def spent(self, device: str, *, at: float) -> bool:
        """Whether the robot switched ``device`` :data:`MOST_AN_HOUR` times within the last
        :data:`HOUR`: it leaves it (to the household) until the first of them is an hour old."""
        with self._lock:
            times = self._robot.get(device)
            if not times:
                return False
            self._prune(times, at)
            return len(times) >= MOST_AN_HOUR

    @staticmethod
    def _prune(times: deque[float], at: float) -> None:
        while times and at - times[0] >= HOUR:
            times.popleft()

    def steady(self, context: Mapping[str, str]) -> dict[str, str]:
        """The context as the robot reads it: a reading that left its bin by less than the
        deadband is held just inside the bin it was in."""
        out = dict(context)
        with self._lock:
            for name, (band, edges) in self._bands.items():
                try:
                    x = float(context[name])
                except (KeyError, ValueError):  # missing, or unknown: nothing to hold
                    continue
                held = self._held(name, x, band, edges)
                if held != x:
                    out[name] = repr(round(held, 6))
        return out

    def _held(self, name: str, x: float, band: float, edges: list[float]) -> float:
        k = bisect.bisect_right(edges, x)
        was = self._bin.get(name)
        if was is None or was == k:
            self._bin[name] = k
            return x
        if k > was and x - edges[was] < band:  # above its bin's top edge, by too little
            return edges[was] - _INSIDE
        if k < was and edges[was - 1] - x < band:  # below its bin's bottom edge, by too little
            return edges[was - 1]
        self._bin[name] = k
        return x
