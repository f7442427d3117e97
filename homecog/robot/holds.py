"""Never fight: after a person switches a device, the robot leaves it alone while the
user's situation is the same — no context feature but the clock and the readings has changed —
and, when the situation moves on sooner, until the hold runs out: a person's switch is theirs
for as long as they are doing what they were doing, and a moment's change of situation does not
give the device back at once.

Fights are counted here too, independently of the hold: a fight is the robot switching a device
again that a person switched, in the same situation as the person's switch.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> holds = Holds(home, hold=1800)
>>> ctx = {"time": "19:00", "location": "sofa", "posture": "sit", "behavior": "watch_tv"}
>>> holds.hold("ceiling_light", ctx, at=0.0)
>>> holds.held("ceiling_light", {**ctx, "time": "23:20"}, at=15000.0)    # the same situation
True
>>> holds.held("ceiling_light", {**ctx, "behavior": "eat"}, at=1300.0)   # moved on, in the hold
True
>>> holds.held("ceiling_light", {**ctx, "behavior": "eat"}, at=1900.0)   # moved on, hold over
False
>>> holds.held("ceiling_light", ctx, at=1950.0)                          # and given back
False
"""

from __future__ import annotations

import threading
from collections.abc import Mapping

from homecog.errors import ContextError
from homecog.home.model import Home


def situation(home: Home, context: Mapping[str, str]) -> tuple[object, ...]:
    """The user's situation: the context less the clock and the readings (and the devices); in
    a home without categorical features, the clock's bin (without a clock either: nothing, and
    a hold is the hold time alone)."""
    features = [f for f in home.features if f.kind == "categorical"]
    if features:
        return tuple(context.get(f.name) for f in features)
    out: list[object] = []
    for f in home.features:
        if f.kind == "clock":
            try:
                out.append(f.discretize(context.get(f.name)))
            except (ContextError, ValueError, TypeError):
                out.append(None)
    return tuple(out)


class Holds:
    """Devices a person switched, each with the situation and time of the switch."""

    def __init__(self, home: Home, *, hold: float) -> None:
        self.home = home
        self.hold_seconds = hold
        self._held: dict[str, tuple[tuple[object, ...], float]] = {}
        self._last: dict[str, tuple[object, ...]] = {}  # a person's last switch: for fights
        self.fights = 0
        self._lock = threading.Lock()

    def hold(self, device: str, context: Mapping[str, str], *, at: float) -> None:
        """A person switched ``device`` in ``context`` at ``at``."""
        where = situation(self.home, context)
        with self._lock:
            self._held[device] = (where, at)
            self._last[device] = where

    def held(self, device: str, context: Mapping[str, str], *, at: float) -> bool:
        """Whether the robot must leave ``device`` alone now."""
        with self._lock:
            entry = self._held.get(device)
            if entry is None:
                return False
            where, since = entry
            same = bool(where) and where == situation(self.home, context)
            if same or 0 <= at - since < self.hold_seconds:
                return True
            del self._held[device]
            return False

    def held_devices(self, context: Mapping[str, str], *, at: float) -> set[str]:
        """Every device the robot must leave alone now."""
        return {d for d in list(self._held) if self.held(d, context, at=at)}

    def observe(self, context: Mapping[str, str]) -> None:
        """The home now: a person's switch in another situation than this is in the past."""
        where = situation(self.home, context)
        with self._lock:
            for device in [d for d, w in self._last.items() if w != where]:
                del self._last[device]

    def robot_switched(self, device: str, context: Mapping[str, str]) -> bool:
        """The robot switches ``device``: a fight if a person last switched it in this very
        situation (counted). The situation moving on ends it."""
        where = situation(self.home, context)
        with self._lock:
            fight = self._last.get(device) == where
            self._last.pop(device, None)
            self.fights += fight
        return fight
