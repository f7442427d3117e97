"""What the household's hands teach the robot.

A person's switch is an *observed correction*: the service that makes it (the one that sets just
that device to that state) was wanted in the context just before it, by that person. A person
switching back, within the undo window and while every feature is in the bin or value it was in
when the robot acted, what the robot switched is an *undo*: a rejection of the robot's service in
the context where the robot did it (once a reading has crossed a bin since, the person answers
the home as it is now: an observed correction). Both are learned for the person's homecog
user at once and go to the experience log with their kind and weight.

What teaches nothing, counted and logged, never learned as a wish: an automation's change; a
person the home's ``household.users`` does not know; a device that flaps (a switch within
:data:`FLAP_SECONDS` of a person's last switch of the same device, and every switch of it after
that until it has been still for :data:`QUIET_SECONDS`: only the burst's first switch counts);
a change dated before one already seen (a clock that went back); a switch that no service
makes.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable, Mapping
from typing import Any

from homecog.context import DeviceChange
from homecog.errors import ContextError
from homecog.home.codec import Point, Space
from homecog.home.household import Household
from homecog.home.model import Home
from homecog.home.states import state_word
from homecog.knowledge.correction import Correction
from homecog.robot.journal import Journal

log = logging.getLogger("homecog.robot")

#: a person's switches of one device closer than this (seconds) are a flapping state
FLAP_SECONDS = 2.0
#: after a flap, the device teaches nothing until it has been still this long
QUIET_SECONDS = 60.0

#: a situation lived this long (seconds) without switching a device back says it was as wanted
QUIET_SITUATION = 600.0

#: learn(correction): commit and learn a correction
Learn = Callable[[Correction], Any]
#: the point of a context of the household's stream (its recent past included)
PointOf = Callable[[Mapping[str, str]], Point]


def switch_services(home: Home) -> dict[tuple[str, bool], str]:
    """Per (device, state), the service that sets just that device to that state (the first in
    the home's order where several do).

    >>> from homecog.home import load_home
    >>> switch_services(load_home("paper"))[("lamp", True)]
    'TurnOnLamp'
    """
    out: dict[tuple[str, bool], str] = {}
    for s in home.services:
        if len(s.sets) == 1:
            out.setdefault((s.sets[0][0], bool(s.sets[0][1])), s.name)
    return out


class Guidance:
    """Turns a person's switches into corrections; counts what it refuses to learn from."""

    def __init__(
        self, home: Home, household: Household, journal: Journal, learn: Learn, point: PointOf | None = None
    ) -> None:
        self.home = home
        self.household = household
        self.journal = journal
        self._learn = learn
        self._space = Space(home)
        self._point = point or self._space.point
        self._services = switch_services(home)
        self._n = len(home.features)
        self._last_at: float | None = None
        self._last_switch: dict[str, float] = {}  # device -> a person's latest switch of it
        self._quiet_until: dict[str, float] = {}  # device -> flapping: teaches nothing until
        self.counts: Counter[str] = Counter()
        self._lock = threading.Lock()

    def person(self, change: DeviceChange) -> str:
        """Learn from a person's switch; what it was: ``observed``, ``undo``, or why not."""
        why = self._refusal(change)
        if why is not None:
            self.counts[why] += 1
            log.info("a person switched %s %s: not learned (%s)", change.device, state_word(change.on), why)
            return why
        user = self.household.user(change.user)
        if user is None:
            self.counts["unknown_person"] += 1
            log.warning(
                "a switch of %s by %r, a person the home does not know: not learned",
                change.device,
                change.user,
            )
            return "unknown_person"
        before = change.before
        assert before is not None
        undone = self.journal.undoable(
            change.device, change.on, at=change.at, window=self.household.undo_window
        )
        if undone is not None and self._same_context(undone[0].context, before):
            return self._undo(undone[0], change, user, by="person")
        if undone is not None:  # the home moved on since the robot acted: it answers the home now
            undone[0].undone[change.device] = "person"
        wanted = self._services.get((change.device, change.on))
        if wanted is None:
            self.counts["no_service"] += 1
            return "no_service"
        weight = self.household.weight("observed")
        note = {"device": change.device, "state": state_word(change.on)}
        self._learn(Correction.observed(user, self._point(before), wanted, weight=weight, **note))
        self.counts["observed"] += 1
        return "observed"

    def quiet(self, context: Mapping[str, str], user: str) -> list[str]:
        """The household lived through a situation and left the devices as they are at its end
        (``context``): the services that would switch one of them were not wanted there. Returns
        those services, learned as one correction."""
        services = [
            name for (device, on), name in self._services.items() if (context.get(device) == "on") != on
        ]
        if services:  # one correction's worth, however much a switch is worth
            self._learn(Correction.lived(user, self._point(context), services))
            self.counts["quiet"] += 1
        return services

    def undo(self, action_id: int, user: str) -> list[str]:
        """The HMI's undo of a robot's action: every service of it rejected where it acted.
        Returns the services rejected."""
        action = self.journal.get(action_id)
        if action is None:
            return []
        weight = self.household.weight("undo")
        for service in action.services:
            note = {"action": action.id, "by": "hmi"}
            self._learn(Correction.undo(user, self._point(action.context), service, weight=weight, **note))
        self.counts["undo"] += 1
        return list(action.services)

    def _undo(self, action: Any, change: DeviceChange, user: str, *, by: str) -> str:
        weight = self.household.weight("undo")
        for service in self._services_of(action.services, change.device):
            note = {"action": action.id, "device": change.device, "by": by}
            self._learn(Correction.undo(user, self._point(action.context), service, weight=weight, **note))
        action.undone[change.device] = by  # once learned
        self.counts["undo"] += 1
        return "undo"

    def _same_context(self, a: Mapping[str, str], b: Mapping[str, str]) -> bool:
        """Whether two contexts fall in the same bins and values of every feature (the devices
        aside): a switch back in the same circumstances rejects the robot's service; one after a
        reading crossed a bin answers the new circumstances instead."""
        try:
            codes = [self._space.point(c).codes[: self._n] for c in (a, b)]
        except ContextError:
            return False
        return codes[0] == codes[1]

    def _services_of(self, services: list[str], device: str) -> list[str]:
        """The services among ``services`` that set ``device``."""
        out = []
        for name in services:
            service = self.home.services[self.home.service_index(name)]
            if any(d == device for d, _ in service.sets):
                out.append(name)
        return out

    def _refusal(self, change: DeviceChange) -> str | None:
        """Why a person's switch teaches nothing, or ``None``."""
        if change.before is None:
            return "incomplete_context"
        with self._lock:
            last, self._last_at = self._last_at, max(change.at, self._last_at or change.at)
            if last is not None and change.at < last - 1.0:
                log.warning("a change dated %.0f s before the last: the clock went back", last - change.at)
                return "clock_back"
            if change.automation:
                return "automation"
            previous = self._last_switch.get(change.device)
            self._last_switch[change.device] = change.at
            if previous is not None and change.at - previous < FLAP_SECONDS:
                self._quiet_until[change.device] = change.at + QUIET_SECONDS
                return "flapping"
            if change.at < self._quiet_until.get(change.device, float("-inf")):
                self._quiet_until[change.device] = change.at + QUIET_SECONDS
                return "flapping"
        return None
