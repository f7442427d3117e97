"""The robot's stream of moments, for the recent past (:mod:`homecog.home.recent`) live.

A replayed event file is a stream of moments: a person's switch (the context just before it and
the service it made), and a change of the context's features where nobody switched. The running
robot lives the same stream and keeps the same recent past from it:

- a person's switch, seen by the robot: a moment with that service;
- the robot's own switches: a moment with the services it carried out;
- a change of a context feature (anything but a device) since the last moment: a moment where
  nothing was wanted.

What the robot proposes and what it learns from the household's hands are judged with the
recent past of the moment they belong to, as a replay of the same stream would judge them.
Corrections and cognitions asked over the API or the command line for a context given by the
caller are snapshots: that context is not a moment of the home's stream.

>>> from homecog.home import load_home
>>> m = Moments(load_home("paper"), clock=lambda: 1_764_612_000.0, simulated=True)  # a Monday
>>> x = {"location": "sofa", "posture": "sit", "behavior": "read", "lamp": "off"}
>>> m.lived(x, ["TurnOnLamp"])
>>> r = m.recent({**x, "lamp": "on"})
>>> r.value("weekday"), sorted(r.previous), r.since_switched("lamp")
('mon', ['TurnOnLamp'], '<5')
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Mapping
from datetime import UTC, datetime

from homecog.home.model import Home
from homecog.home.recent import Recent, RecentPast


class Moments:
    """The recent past of the robot's stream; ``clock()`` in seconds since 1970 (a simulated
    home's own clock reads as UTC, a real home's as the local time)."""

    def __init__(self, home: Home, clock: Callable[[], float], *, simulated: bool) -> None:
        self.past = RecentPast(home)
        self._clock = clock
        self._simulated = simulated
        self._features = [f.name for f in home.features]
        self._last: tuple[str, ...] | None = None  # the features at the latest moment
        self._lock = threading.Lock()

    def now(self) -> datetime:
        t = self._clock()
        if self._simulated:
            return datetime.fromtimestamp(t, UTC).replace(tzinfo=None)
        return datetime.fromtimestamp(t)

    def recent(self, context: Mapping[str, object]) -> Recent:
        """The recent past at the moment of ``context``."""
        with self._lock:
            return self.past.at(self.now(), context)

    def lived(self, context: Mapping[str, object], wanted: Iterable[str]) -> None:
        """A moment of the stream: its context and the services wanted there."""
        with self._lock:
            self.past.learn(self.now(), context, wanted)
            self._last = tuple(str(context.get(f)) for f in self._features)

    def changed(self, context: Mapping[str, object]) -> bool:
        """Whether a context feature differs from the latest moment's."""
        return self._last != tuple(str(context.get(f)) for f in self._features)
