"""The recent past: what a stream of contexts says beyond the snapshot.

A home's context is one moment; a household's habits are sequences. :class:`RecentPast` follows
the contexts of a stream — the rows of an event file in order, or the contexts a running robot
sees — and derives, at each new moment, features of what came just before it:

- ``weekday`` (``mon`` … ``sun``) of the moment;
- ``minutes since previous``: since the previous moment of the stream, binned (:data:`SPANS`);
- per categorical feature (the first :data:`TRACKED` of the home, in its order): ``previous X``,
  the value it had before its current one, and ``minutes in X``, how long it has had the current
  one, binned;
- the services wanted at the previous moment (:attr:`Recent.previous`), which the correction
  learner reads per service: was *this* service wanted just before, and which were?
- the devices switched within the last four hours and how long ago (:attr:`Recent.switched`;
  a switch is seen where a moment's services set a device, or where its state differs from
  the moment before): per service, how long ago the device it sets switched — an appliance
  switched on a minute ago is switched off at another moment than one on for hours.

Each is ``unknown`` where the stream cannot say (its first moment, a stream without times). The
features are derived from the stream alone, so any event file gains them without new columns,
and a robot computes them the same way live. They are for the correction learner (and the
baselines that read sequences); the comfort model never sees them.

>>> from datetime import datetime
>>> from homecog.home import load_home
>>> past = RecentPast(load_home("paper"))
>>> x = {"location": "sofa", "posture": "sit", "behavior": "read"}
>>> past.learn(datetime(2026, 12, 1, 19, 0), x, {"TurnOnLamp"})
>>> r = past.at(datetime(2026, 12, 1, 19, 20), {**x, "behavior": "watch_tv"})
>>> r.value("weekday"), r.value("minutes since previous"), r.value("previous behavior")
('tue', '15-60', 'read')
>>> r.value("minutes in location"), r.value("minutes in behavior"), sorted(r.previous)
('15-60', '<5', ['TurnOnLamp'])
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import datetime

from homecog.home.model import Home
from homecog.home.states import state_word

UNKNOWN = "unknown"
#: categorical features whose previous value and duration are followed, at most
TRACKED = 3
#: upper ends (minutes) of the spans durations are binned into, and their names
SPANS = (5.0, 15.0, 60.0, 240.0)
SPAN_NAMES = ("<5", "5-15", "15-60", "1-4h", ">4h")
WEEKDAYS = ("mon", "tue", "wed", "thu", "fri", "sat", "sun")


def span(minutes: float) -> str:
    """A duration's bin: ``<5``, ``5-15``, ``15-60``, ``1-4h`` or ``>4h``.

    >>> span(0), span(5), span(59.9), span(600)
    ('<5', '5-15', '15-60', '>4h')
    """
    return SPAN_NAMES[bisect.bisect_right(SPANS, minutes)]


@dataclass(frozen=True)
class Recent:
    """The recent past at one moment: its time, the named features (every value a word, at
    worst ``unknown``) and the services wanted at the previous moment (None: unknown)."""

    at: datetime | None
    values: tuple[tuple[str, str], ...]
    previous: frozenset[str] | None = None
    # the devices switched within the last four hours, and how long ago (binned)
    switched: tuple[tuple[str, str], ...] = ()

    def since_switched(self, device: str) -> str:
        """How long ago a device took its current state: a span, ``>4h`` (not within four
        hours, or never seen switching) or ``unknown`` (a stream without times)."""
        for name, ago in self.switched:
            if name == device:
                return ago
        return UNKNOWN if self.at is None else SPAN_NAMES[-1]

    def value(self, name: str) -> str:
        for key, value in self.values:
            if key == name:
                return value
        raise KeyError(name)

    def as_dict(self) -> dict[str, object]:
        """As plain data (an experience log's payload, a predictions line)."""
        return {
            "at": None if self.at is None else self.at.isoformat(),
            **dict(self.values),
            "previous services": None if self.previous is None else sorted(self.previous),
            **({"switched": dict(self.switched)} if self.switched else {}),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, object]) -> Recent:
        """What :meth:`as_dict` wrote, back."""
        at = data.get("at")
        previous = data.get("previous services")
        values = tuple(
            (str(k), str(v)) for k, v in data.items() if k not in ("at", "previous services", "switched")
        )
        switched = data.get("switched") or {}
        return cls(
            at=datetime.fromisoformat(str(at)) if at else None,
            values=values,
            previous=None if previous is None else frozenset(str(s) for s in previous),  # type: ignore[union-attr]
            switched=tuple((str(k), str(v)) for k, v in switched.items()),  # type: ignore[union-attr]
        )


def recent_names(home: Home) -> tuple[str, ...]:
    """The names of a home's recent-past features, in order."""
    tracked = [f.name for f in home.features if f.kind == "categorical"][:TRACKED]
    return (
        "weekday",
        "minutes since previous",
        *(f"previous {n}" for n in tracked),
        *(f"minutes in {n}" for n in tracked),
    )


class RecentPast:
    """Follows a stream of moments: :meth:`at` before a moment is judged, :meth:`learn` after."""

    def __init__(self, home: Home) -> None:
        self.names = recent_names(home)
        self.tracked = [f.name for f in home.features if f.kind == "categorical"][:TRACKED]
        self._last_at: datetime | None = None
        self._previous: frozenset[str] | None = None
        # per tracked feature: its current value, since when, and the value before it
        self._current: dict[str, tuple[str, datetime | None, str]] = {}
        self.devices = [d.name for d in home.devices]
        self._sets = {sv.name: [(d, state_word(on)) for d, on in sv.sets] for sv in home.services}
        self._states: dict[str, str] = {}  # per device: its state at the latest moment
        self._switched: dict[str, datetime] = {}  # per device: when it was last seen to switch

    def at(self, when: datetime | None, context: Mapping[str, object]) -> Recent:
        """The recent past at a new moment (its time, if known, and its context)."""
        since = UNKNOWN
        if when is not None and self._last_at is not None and when >= self._last_at:
            since = span((when - self._last_at).total_seconds() / 60)
        weekday = UNKNOWN if when is None else WEEKDAYS[when.weekday()]
        befores, durations = [], []
        for name in self.tracked:
            before, minutes = self._feature(name, str(context.get(name, UNKNOWN)), when)
            befores.append((f"previous {name}", before))
            durations.append((f"minutes in {name}", minutes))
        values = (("weekday", weekday), ("minutes since previous", since), *befores, *durations)
        return Recent(at=when, values=values, previous=self._previous, switched=self._recent_switches(when))

    def _recent_switches(self, when: datetime | None) -> tuple[tuple[str, str], ...]:
        if when is None:
            return ()
        out = []
        for device, at in self._switched.items():
            minutes = (when - at).total_seconds() / 60
            if 0 <= minutes < SPANS[-1]:
                out.append((device, span(minutes)))
        return tuple(sorted(out))

    def _feature(self, name: str, now: str, when: datetime | None) -> tuple[str, str]:
        """A tracked feature's previous value and how long it has had the current one."""
        if name not in self._current:
            return UNKNOWN, UNKNOWN
        value, start, before = self._current[name]
        if now != value:  # it changed just now
            return value, span(0.0)
        if when is None or start is None or when < start:
            return before, UNKNOWN
        return before, span((when - start).total_seconds() / 60)

    def learn(self, when: datetime | None, context: Mapping[str, object], wanted: Iterable[str]) -> None:
        """The moment lived: its context and the services wanted there become the past."""
        wanted = frozenset(wanted)
        for name in self.tracked:
            now = str(context.get(name, UNKNOWN))
            if name not in self._current:
                self._current[name] = (now, when, UNKNOWN)
            elif now != self._current[name][0]:
                self._current[name] = (now, when, self._current[name][0])
        self._learn_states(when, context)
        if when is not None:
            self._learn_switches(when, wanted)
        self._previous = wanted

    def _learn_states(self, when: datetime | None, context: Mapping[str, object]) -> None:
        """The devices' states of the moment; a change is a switch at ``when``, if known."""
        for device in self.devices:
            state = context.get(device)
            if state is None:
                continue
            state = str(state)
            if device in self._states and self._states[device] != state and when is not None:
                self._switched[device] = when
            self._states[device] = state

    def _learn_switches(self, when: datetime, wanted: frozenset[str]) -> None:
        """What the moment's services switched, and the switches too old to tell forgotten."""
        for service in sorted(wanted):  # in one order in every process (two may set one device)
            for device, state in self._sets.get(service, ()):
                if self._states.get(device) != state:
                    self._switched[device] = when
                    self._states[device] = state
        self._last_at = when
        for device in [
            d for d, at in self._switched.items() if (when - at).total_seconds() >= SPANS[-1] * 60
        ]:
            del self._switched[device]
