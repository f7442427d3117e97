"""Two online baselines that read the stream beyond the snapshot: when an event happened and
what was wanted just before it.

- :class:`HAUsage` (``ha_usage``): Home Assistant's ``usage_prediction`` integration, the
  "common controls" it shows each user: the entities the user's own service calls used most in
  the current time of day over the last 30 days.
- :class:`ServiceMarkov` (``markov``): a last-event Markov chain: how often each service was
  wanted right after the set of services wanted at the previous event.

Both speak river's API like :mod:`homecog.evaluation.baselines`: ``x`` maps every feature and
device to its value (``on``/``off`` for devices) and holds three more keys, which no home's
name can be (they have spaces): :data:`AT` (the event's datetime, or None), :data:`HOUR` (the
hour of day of the home's clock feature, or None) and :data:`PREVIOUS` (the services wanted at
the previous event, or None). A service is proposed when its share exceeds a threshold chosen
online (:class:`~homecog.knowledge.threshold.OnlineThreshold`: the candidate of
:data:`SHARES` with the best F1 on the past events, each judged before it was counted), and
never where it would change nothing: a service whose every device is already in the state it
sets (switching on a lamp that is on).

>>> sets = {"LampOn": [("lamp", True)], "LampOff": [("lamp", False)]}
>>> m = ServiceMarkov(sets)
>>> for y in ({"LampOn"}, {"LampOff"}) * 3:
...     m.learn_one({PREVIOUS: frozenset(y ^ {"LampOn", "LampOff"}), "lamp": "off"}, y)
>>> m.predict_one({PREVIOUS: frozenset({"LampOff"}), "lamp": "off"})
{'LampOn'}
>>> m.predict_one({PREVIOUS: frozenset({"LampOff"}), "lamp": "on"})  # it is on already
set()
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Collection, Mapping, Sequence
from datetime import datetime, timedelta
from typing import Any

from homecog.home.states import state_word
from homecog.knowledge.threshold import OnlineThreshold

#: The keys of ``x`` beyond the home's features and devices.
AT, HOUR, PREVIOUS = "event time", "hour of day", "previous services"
#: Home Assistant's times of day (by the local hour: 6–12, 12–18, 18–22, 22–6).
TIME_CATEGORIES = ("morning", "afternoon", "evening", "night")
#: Home Assistant counts the service calls of the last 30 days …
WINDOW = timedelta(days=30)
#: … and lists the 8 most used entities of the time of day.
RESULTS = 8
#: The bucket of events that have no time at all (a home without a clock, no timestamps).
ANY_TIME = "any time"
#: The thresholds chosen among: shares of all events are small where quiet events dominate.
SHARES = (0.0, 0.01, 0.02, 0.03, 0.05, 0.075, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)

Features = Mapping[str, Any]
Sets = Mapping[str, Sequence[tuple[str, bool]]]


def time_category(hour: float) -> str:
    """Home Assistant's time of day of an hour (its ``time_category``).

    >>> [time_category(h) for h in (5.99, 6, 11.5, 12, 18, 21.99, 22, 0)]
    ['night', 'morning', 'morning', 'afternoon', 'evening', 'evening', 'night', 'night']
    """
    if 6 <= hour < 12:
        return "morning"
    if 12 <= hour < 18:
        return "afternoon"
    if 18 <= hour < 22:
        return "evening"
    return "night"


def bin_middle(low: float, high: float) -> float:
    """The middle hour of a clock bin ``[low, high)`` (one with ``low > high`` wraps midnight).

    >>> bin_middle(6, 10), bin_middle(22, 6), bin_middle(0, 24)
    (8.0, 2.0, 12.0)
    """
    length = (high - low) % 24 or 24.0
    return (low + length / 2) % 24


def changes_something(sets: Sequence[tuple[str, bool]], x: Features) -> bool:
    """Whether a service that sets ``sets`` would change a device in ``x`` (a service that
    sets none, an interaction, always does something).

    >>> changes_something([("lamp", True)], {"lamp": "on"}), changes_something([], {})
    (False, True)
    """
    return not sets or any(x.get(d) != state_word(on) for d, on in sets)


class _ShareLearner:
    """Per service a share (a score in [0, 1]); a threshold chosen online; never a service
    that would change nothing. Subclasses say the shares and count an event."""

    def __init__(self, sets: Sets, thresholds: Sequence[float] = SHARES, start: float = 0.5) -> None:
        self.sets = {s: tuple(v) for s, v in sets.items()}
        self._threshold = OnlineThreshold(thresholds, start=start)

    @property
    def threshold(self) -> float:
        """The threshold in use: the best on the events learned so far."""
        return self._threshold.value

    def shares(self, x: Features) -> dict[str, float]:
        """Per service with a share at ``x``, its share (the others have none)."""
        raise NotImplementedError

    def _count(self, x: Features, y: Collection[str]) -> None:
        raise NotImplementedError

    def _proposable(self, x: Features) -> dict[str, float]:
        shares = self.shares(x)
        return {s: v for s, v in shares.items() if changes_something(self.sets[s], x)}

    def predict_one(self, x: Features) -> set[str]:
        t = self._threshold.value
        return {s for s, v in self._proposable(x).items() if v > t}

    def learn_one(self, x: Features, y: Collection[str]) -> None:
        shares = self._proposable(x)
        for s in self.sets:  # how every threshold would have answered, before counting
            self._threshold.judge(shares.get(s), s in y)
        self._count(x, y)


class HAUsage(_ShareLearner):
    """Home Assistant's common controls: counts per service and time of day over 30 days.

    Faithful to ``usage_prediction`` (``common_control.py``): the four times of day by the
    event's local hour (6–12 morning, 12–18 afternoon, 18–22 evening, else night); only the
    events of the 30 days before the moment asked count (older ones are forgotten); every
    service of an event counts once for its time of day (as every entity of a service call);
    the services are ranked by their count and only the 8 most used (``RESULTS_TO_INCLUDE``)
    can be proposed.

    Different, because homecog needs a set of services, not a list to show: HA answers the
    ranked list itself; here a listed service is proposed when its *share* of the time of
    day's events (its count over all the events counted there, quiet events included) exceeds
    the threshold chosen online, and not where it would change nothing. HA counts per user and
    recomputes its lists once a day (a 24-hour cache); here the stream is one household and
    the counts are current at every event. A service is a device's direction (``TurnOnLamp``),
    where HA counts the entity. Ties in the ranking go to the home's service order. Where an
    event has no time, the hour of the home's clock feature places it, and it is never
    forgotten (no window without time); with neither, all events share one bucket.

    >>> from datetime import datetime
    >>> u = HAUsage({"LampOn": [("lamp", True)], "TeaPlease": []})
    >>> for day in (1, 2, 3):
    ...     u.learn_one({AT: datetime(2026, 3, day, 19), "lamp": "off"}, {"LampOn"})
    >>> u.shares({AT: datetime(2026, 3, 4, 20), "lamp": "off"}), u.bucket({HOUR: 7.5})
    ({'LampOn': 1.0}, 'morning')
    >>> u.predict_one({AT: datetime(2026, 3, 4, 20), "lamp": "off"})
    {'LampOn'}
    >>> u.predict_one({AT: datetime(2026, 4, 2, 20), "lamp": "off"})  # 30 days on: forgotten
    set()
    """

    def __init__(
        self,
        sets: Sets,
        *,
        window: timedelta = WINDOW,
        results: int = RESULTS,
        thresholds: Sequence[float] = SHARES,
        start: float = 0.5,
    ) -> None:
        super().__init__(sets, thresholds, start)
        self.window = window
        self.results = results
        self._order = {s: i for i, s in enumerate(self.sets)}
        self._counts: dict[str, Counter[str]] = {}  # per bucket: per service, events wanting it
        self._events: Counter[str] = Counter()  # per bucket: events counted
        self._timed: deque[tuple[datetime, str, frozenset[str]]] = deque()  # inside the window

    def bucket(self, x: Features) -> str:
        """The time of day of ``x``: by its event time, else its clock's hour."""
        at, hour = x.get(AT), x.get(HOUR)
        if at is not None:
            return time_category(at.hour)
        return ANY_TIME if hour is None else time_category(float(hour))

    def count(self, bucket: str, service: str) -> int:
        """How many counted events of ``bucket`` wanted ``service``."""
        return self._counts.get(bucket, Counter())[service]

    def _forget(self, at: datetime | None) -> None:
        """Forget the timed events older than the window before ``at``."""
        if at is None:
            return
        while self._timed and self._timed[0][0] < at - self.window:
            _, bucket, wanted = self._timed.popleft()
            self._events[bucket] -= 1
            self._counts[bucket].subtract(wanted)

    def ranked(self, bucket: str) -> list[str]:
        """The most used services of a time of day, most used first (HA's list)."""
        counts = self._counts.get(bucket, Counter())
        used = [s for s in self.sets if counts[s] > 0]
        return sorted(used, key=lambda s: (-counts[s], self._order[s]))[: self.results]

    def shares(self, x: Features) -> dict[str, float]:
        self._forget(x.get(AT))
        bucket = self.bucket(x)
        n = self._events[bucket]
        return {s: self._counts[bucket][s] / n for s in self.ranked(bucket)}

    def _count(self, x: Features, y: Collection[str]) -> None:
        bucket, wanted = self.bucket(x), frozenset(s for s in y if s in self.sets)
        self._events[bucket] += 1
        self._counts.setdefault(bucket, Counter()).update(wanted)
        if x.get(AT) is not None:
            self._timed.append((x[AT], bucket, wanted))


class ServiceMarkov(_ShareLearner):
    """A last-event Markov chain: per set of services wanted at the previous event, how often
    each service was wanted next, learned online from the stream's transitions.

    A previous set never seen before, or none (the stream's first event; every sample of
    ``eval``, whose scenarios have no sequence), falls back to the unconditional share: how
    often the service was wanted over all the events — so in ``eval`` it is a plain count.

    >>> m = ServiceMarkov({"A": [], "B": []})
    >>> m.learn_one({PREVIOUS: None}, {"A"}); m.learn_one({PREVIOUS: frozenset({"A"})}, {"B"})
    >>> m.shares({PREVIOUS: frozenset({"A"})}), m.shares({PREVIOUS: frozenset({"C"})})
    ({'B': 1.0}, {'A': 0.5, 'B': 0.5})
    """

    def __init__(self, sets: Sets, thresholds: Sequence[float] = SHARES, start: float = 0.5) -> None:
        super().__init__(sets, thresholds, start)
        self._after: dict[frozenset[str], tuple[list[int], Counter[str]]] = {}  # events, wanted
        self._all: tuple[list[int], Counter[str]] = ([0], Counter())

    def transitions(self, previous: frozenset[str]) -> dict[str, int]:
        """How often each service was wanted right after ``previous`` was (counts)."""
        return dict(self._after.get(previous, ([0], Counter()))[1])

    def shares(self, x: Features) -> dict[str, float]:
        previous = x.get(PREVIOUS)
        seen, wanted = self._after.get(previous, self._all) if previous is not None else self._all
        if not seen[0]:
            return {}
        return {s: wanted[s] / seen[0] for s in self.sets if wanted[s]}

    def _count(self, x: Features, y: Collection[str]) -> None:
        wanted = [s for s in y if s in self.sets]
        previous = x.get(PREVIOUS)
        states = [self._all]
        if previous is not None:
            states.append(self._after.setdefault(previous, ([0], Counter())))
        for seen, counts in states:
            seen[0] += 1
            counts.update(wanted)
