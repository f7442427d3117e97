"""The robot does not undo its own switch: a device it switched is not
switched back while the user's situation is the same and the home is as the switch left it.

Its rules and the readings its own switch causes can disagree — a curtain opened to a room that
is not light makes it light, and the light rule closes it again — and a robot that followed
them would switch back and forth. So after its switch the robot keeps its hands off the device
until something moves that its switch did not: the situation (a categorical feature), the
clock's bin, or a reading into another bin, by more than a margin (:data:`MARGIN` of the reading,
so that a reading that hovers at a bin's edge does not count as moving). Given the context it
switched in, it also keeps its hands off while the user's situation is the one it switched in,
for :data:`SAME_SITUATION` at most, whatever the clock and the readings do: a light switched off
makes the room dark, and a switch back in the same situation would be the robot answering itself.
That starts after the moment of the switch (:data:`MOMENT`): a ceiling light switched on in the
dark may still go off when the curtain the robot opens next makes the room light.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> settling = Settling(home)
>>> after = {"time": "13:31", "temperature": "29.7", "illumination": "2149", "location": "sofa",
...          "posture": "sit", "behavior": "watch_tv"}
>>> settling.switched("window", True)
>>> settling.settled("window", {**after, "window": "off"})   # not reported yet: it waits
True
>>> settling.settled("window", {**after, "window": "on"})    # reported: the home as it left it
True
>>> settling.settled("window", {**after, "window": "on", "temperature": "29.9"})   # suitable
True
>>> settling.settled("window", {**after, "window": "on", "temperature": "31.2"})   # hot: moved
False
>>> settling.switched("window", True, at=0.0, context=after)   # the situation it switched in
>>> settling.settled("window", {**after, "window": "on"}, at=60.0)
True
>>> hot = {**after, "window": "on", "temperature": "31.2"}
>>> settling.settled("window", hot, at=600.0), settling.settled("window", hot, at=3600.0)
(True, False)
"""

from __future__ import annotations

import threading
from collections.abc import Mapping

from homecog.errors import ContextError
from homecog.home.model import Home
from homecog.robot.attribution import EXPECT_SECONDS
from homecog.robot.holds import situation

#: how far into another bin a reading must be to count as moved, as a share of the reading
MARGIN = 0.02
#: how long the robot does not switch back its own switch while the situation is the same (s)
SAME_SITUATION = 3600.0
#: the moment of a switch (s): the robot's other switches then (a curtain opened after the light
#: went on) may still answer it, the home as they leave it judged as before
MOMENT = 60.0


class Settling:
    """The robot's recent switches and the home as each left it."""

    def __init__(self, home: Home, margin: float = MARGIN, same_situation: float = SAME_SITUATION) -> None:
        self.home = home
        self.margin = margin
        self.same_situation = same_situation
        # device -> the state the robot switched it to, when, and the home's codes once it is so
        self._after: dict[str, tuple[bool, float, tuple[int, ...] | None]] = {}
        self._where: dict[str, tuple[object, ...]] = {}  # device -> the situation it switched in
        self._lock = threading.Lock()

    def switched(
        self, device: str, on: bool, *, at: float = 0.0, context: Mapping[str, str] | None = None
    ) -> None:
        """The robot switched ``device`` to ``on`` at ``at`` (in ``context``, where given); the
        home as it leaves it is the first look at the home that reports the device so."""
        with self._lock:
            self._after[device] = (on, at, None)
            if context is not None:
                self._where[device] = situation(self.home, context)
            else:
                self._where.pop(device, None)

    def forget(self, device: str) -> None:
        """A switch that failed: nothing to keep."""
        with self._lock:
            self._after.pop(device, None)
            self._where.pop(device, None)

    def settled(self, device: str, now: Mapping[str, str], *, at: float = 0.0) -> bool:
        """Whether ``device`` is still as the robot's switch left it, in a home that has not
        moved since: the robot must not switch it back. A switch not reported within
        :data:`~homecog.robot.attribution.EXPECT_SECONDS` is given up."""
        with self._lock:
            if device not in self._after:
                return False
            on, since, after = self._after[device]
            if (now.get(device) == "on") != on:
                if after is None and at - since <= EXPECT_SECONDS:
                    return True  # not reported yet
                del self._after[device]  # switched since by someone else, or never reported
                self._where.pop(device, None)
                return False
            if after is None:  # the first look at the home with the switch done
                self._after[device] = (on, since, self._codes(now))
                return True
            if self._same_situation(device, now, since, at):
                return True
            if self._moved(after, now):
                del self._after[device]
                self._where.pop(device, None)
                return False
            return True

    def _same_situation(self, device: str, now: Mapping[str, str], since: float, at: float) -> bool:
        """Whether the user is still in the situation the robot switched ``device`` in, and
        :attr:`same_situation` has not passed since but :data:`MOMENT` has (the lock held)."""
        where = self._where.get(device)
        if where is None or 0 <= at - since < MOMENT:
            return False  # the moment of the switch: what else the robot does then may answer it
        if at - since < self.same_situation and where and where == situation(self.home, now):
            return True
        del self._where[device]  # moved on, or long enough: the readings and the clock count again
        return False

    def settled_devices(self, now: Mapping[str, str], *, at: float = 0.0) -> set[str]:
        return {d for d in list(self._after) if self.settled(d, now, at=at)}

    def _codes(self, context: Mapping[str, str]) -> tuple[int, ...]:
        return tuple(f.discretize(context[f.name]) for f in self.home.features)

    def _moved(self, after: tuple[int, ...], now: Mapping[str, str]) -> bool:
        for f, code in zip(self.home.features, after, strict=True):
            try:
                if f.discretize(now[f.name]) == code:
                    continue
                if f.kind != "numeric":
                    return True
                x = float(now[f.name])
                m = self.margin * max(abs(x), 1.0)
                if f.discretize(x - m) == f.discretize(x + m):  # well inside its new bin
                    return True
            except (ContextError, ValueError):  # a reading off every bin, within the margin
                continue
        return False
