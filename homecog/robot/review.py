"""The review step: each of the robot's proposals put to a user gets its own yes or no.

What is *pending* for a user: the services of the latest cognition the server answered for that
user (``POST /api/cognize``, as the page asks), in that context — every feature in the same bin
or value and every device in the same state — less those the user has answered there since. A
yes is a correction that adds that one service there, a no one that rejects it
(:meth:`Correction.change`): never the whole set, so a yes to one proposal confirms nothing
beside it. An answer for a service that is not pending is refused with
:class:`~homecog.errors.NotPendingError` naming what is, and nothing is stored.

>>> from homecog.home import load_home
>>> from homecog.home.codec import Space
>>> home = load_home("paper")
>>> point = Space(home).point({"time": "22:00", "temperature": 19, "illumination": 200,
...     "location": "table", "posture": "sit", "behavior": "read", **dict.fromkeys(home.device_names, "off")})
>>> pending = Pending()
>>> pending.shown("ann", point, ["SendDrinks", "RemindToSleep"])
>>> pending.check("ann", point, "SendDrinks")
>>> pending.answered("ann", point, "SendDrinks")
>>> pending.pending("ann", point)
['RemindToSleep']
>>> pending.check("ann", point, "SendDrinks")
Traceback (most recent call last):
...
homecog.errors.NotPendingError: SendDrinks is answered already for ann here; still pending: RemindToSleep
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from homecog.errors import NotPendingError
from homecog.home.codec import Point
from homecog.knowledge.correction import Correction

if TYPE_CHECKING:
    from homecog.robot.runtime import Runtime

#: the users whose latest proposals are kept (the least recently asked for go first)
KEEP = 1000


@dataclass
class Shown:
    """A user's latest proposals: the context's codes, the services, those answered there."""

    codes: tuple[int, ...]
    services: tuple[str, ...]
    answered: set[str] = field(default_factory=set)


class Pending:
    """Per user, the latest proposals shown and which of them are answered; at most ``keep``
    users (any name may ask for a cognition, so the map is bounded)."""

    def __init__(self, keep: int = KEEP) -> None:
        self.keep = keep
        self._shown: OrderedDict[str, Shown] = OrderedDict()
        self._lock = threading.Lock()  # the map; held for microseconds (cognition waits on it)
        self.answering = threading.Lock()  # one answer at a time, from its check to its commit

    def shown(self, user: str, point: Point, services: Sequence[str]) -> None:
        """The server answered ``services`` for ``user`` at ``point``: those are pending now,
        but those already answered in the same context."""
        with self._lock:
            before = self._shown.pop(user, None)
            answered = before.answered if before is not None and before.codes == point.codes else set()
            self._shown[user] = Shown(point.codes, tuple(services), answered)
            while len(self._shown) > self.keep:
                self._shown.popitem(last=False)

    def pending(self, user: str, point: Point) -> list[str]:
        """The services pending for ``user`` at ``point``, in the robot's order."""
        with self._lock:
            shown = self._shown.get(user)
            if shown is None or shown.codes != point.codes:
                return []
            return [s for s in shown.services if s not in shown.answered]

    def check(self, user: str, point: Point, service: str) -> None:
        """:class:`NotPendingError` saying why, unless ``service`` is pending for ``user`` there."""
        with self._lock:
            shown = self._shown.get(user)
        if shown is None:
            raise NotPendingError(f"nothing is pending for {user}: ask the robot for its services first")
        if shown.codes != point.codes:
            raise NotPendingError(
                f"{service} is not pending for {user}: the context changed since the robot's latest "
                "proposals; ask again"
            )
        still = ", ".join(s for s in shown.services if s not in shown.answered) or "nothing"
        if service in shown.answered:
            raise NotPendingError(f"{service} is answered already for {user} here; still pending: {still}")
        if service not in shown.services:
            raise NotPendingError(f"{service} is not among the robot's proposals to {user} here: {still}")

    def answered(self, user: str, point: Point, service: str) -> None:
        """``user`` answered ``service`` at ``point``: no longer pending there."""
        with self._lock:
            shown = self._shown.get(user)
            if shown is not None and shown.codes == point.codes:
                shown.answered.add(service)


def answer(
    runtime: Runtime, context: Mapping[str, object], user: str, service: str, yes: bool
) -> dict[str, Any]:
    """A user's yes or no to one pending proposal, learned and stored as a correction of that
    service alone; what :meth:`Runtime.correct` returns. :class:`ContextError` for a user who
    is not one of the household, :class:`NotPendingError` for a service not pending: nothing
    is stored."""
    point = runtime.space.point(context)
    runtime.household.member(user)
    with runtime.pending.answering:  # two answers to one proposal: the second finds it answered
        runtime.pending.check(user, point, service)
        change = {"add": [service]} if yes else {"reject": [service]}
        out = runtime.correct(Correction.change(user, point, **change))
        runtime.pending.answered(user, point, service)
    return out
