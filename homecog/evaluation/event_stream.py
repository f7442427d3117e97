"""The conversion core under every log of a home: state changes in, event-file rows out.

A reader of a log — a CSV of state changes (:mod:`~homecog.evaluation.log_events`), a Home
Assistant recorder (:mod:`~homecog.evaluation.ha_history`) — turns its rows into
:class:`LogRow`\\ s in time order and gives, per entity, the :class:`Reader`\\ s that read its
states as a feature's value, a device's state or a presence entity's. :class:`EventStream`
keeps the context as it goes and makes two kinds of rows:

- a *switch row* per switch of a device (off to on, on to off): the context just before it —
  every feature's last value, every device's state, the switching one as it was — and, as
  ``services``, the home's service that makes the switch;
- a *quiet row* (only with ``quiet`` minutes) where a feature's value (its bin or category)
  changes and no device switched within ``quiet`` minutes before or after: the context then,
  ``services`` empty. Changes at one moment make one row; a clock feature read from the
  timestamp changes no row.

A row is written only once every device's state is known (else it counts as ``incomplete``);
a feature with no reading yet is written ``unknown``, a missing reading. Presence features
(:class:`Presence`) change by themselves, when an entity's hold ends: that is a moment of its own.

>>> from datetime import datetime
>>> from homecog.home import load_home
>>> home = load_home("tests/homes/studio.yaml")
>>> home.feature_names, home.device_names
(('time', 'light', 'activity'), ('blind', 'desk_lamp', 'radio'))
>>> readers = {"lux": [Reader("light", "feature", lambda r: r.state)],
...            "act": [Reader("activity", "feature", lambda r: r.state)],
...            **{d: [Reader(d, "device", lambda r: r.state == "on")] for d in home.device_names}}
>>> stream = EventStream(home, readers, quiet=10)
>>> at = lambda m: datetime(2024, 3, 1, 7, m)
>>> for m, entity, state in [(0, "lux", "50"), (0, "act", "work"), *((0, d, "off") for d in
...         home.device_names), (1, "desk_lamp", "on"), (30, "act", "relax")]:
...     stream.feed(LogRow(at(m), entity, state))
>>> for row in stream.rows():
...     print(",".join(row))
2024-03-01T07:01:00,07:01,50,work,off,off,off,LampOn
2024-03-01T07:30:00,07:30,50,relax,off,on,off,
"""

from __future__ import annotations

import bisect
import csv
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from pathlib import Path
from typing import Any, Literal

from homecog.home.clock import format_clock
from homecog.home.codec import UNKNOWN
from homecog.home.model import Home
from homecog.home.states import state_word


class Skip(Exception):  # noqa: N818 - a reason, not a failure
    """A state a reader cannot read: counted under ``reason`` and skipped."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class LogRow:
    """One state change: when, which entity, its state, who made it.

    ``counted``: False for a row that only gives the context (before the period asked for);
    ``switchable``: False for a state that is no one's switch (what an instance restores);
    ``skip``: why a switch made by this row is no event (an automation's, the robot's own).
    """

    at: datetime
    entity: str
    state: str
    user: str | None = None
    extra: Any = None  # what a reader may need besides the state (Home Assistant: attributes)
    counted: bool = True
    switchable: bool = True
    skip: str | None = None


@dataclass(frozen=True)
class Reader:
    """How an entity's state reads: a feature's value (a text of the feature), a device's state
    or a presence entity's (a bool); ``read`` raises :class:`Skip`."""

    target: str
    kind: Literal["feature", "device", "presence"]
    read: Callable[[LogRow], Any]


@dataclass
class Presence:
    """A feature made from presence entities: the room of the live entity that turned on last.
    An entity is live from when it turns on until ``hold`` minutes after it last turned on or
    off: a door left open, or a mat pressed all night, holds no longer than one that closes.

    >>> p = Presence("location", {"pir_bed": "bed", "pir_desk": "desk"}, hold=5, unknown="unknown")
    >>> at = lambda m: datetime(2024, 3, 1, 7, m)
    >>> p.fire("pir_bed", True, at(0)); p.fire("pir_desk", True, at(1)); p.value
    'desk'
    >>> p.fire("pir_bed", False, at(4)); p.next_expiry()  # the desk's hold ends first
    datetime.datetime(2024, 3, 1, 7, 6)
    >>> p.expire(at(6)); p.value, p.next_expiry()
    ('bed', datetime.datetime(2024, 3, 1, 7, 9))
    >>> p.expire(at(9)); p.value
    'unknown'
    >>> both = Presence("location", {"pir_bed": "bed", "pir_desk": "desk"}, 5, "unknown", several="both")
    >>> both.fire("pir_bed", True, at(0)); both.fire("pir_desk", True, at(1)); both.value
    'both'
    """

    feature: str
    rooms: Mapping[str, str]
    hold: float  # minutes
    unknown: str | None  # the value with no entity live; None: the last room stays
    several: str | None = None  # the value while live entities are in several rooms; None: the latest
    value: str | None = None
    until: dict[str, datetime] = field(default_factory=dict)  # live entities: until when
    turned_on: dict[str, int] = field(default_factory=dict)  # entity: the order it last turned on
    on: set[str] = field(default_factory=set)
    seq: int = 0

    def __post_init__(self) -> None:
        self.value = self.unknown

    def fire(self, entity: str, on: bool, at: datetime) -> None:
        """An entity turned on (again) or off."""
        if on:
            self.seq += 1
            self.turned_on[entity] = self.seq
            self.on.add(entity)
        elif entity in self.on:
            self.on.discard(entity)
        else:
            return
        self.until[entity] = at + timedelta(minutes=self.hold)
        self._update()

    def next_expiry(self) -> datetime | None:
        """When the next hold ends (None: none is running)."""
        return min(self.until.values(), default=None)

    def expire(self, at: datetime) -> None:
        """End the holds that end by ``at``."""
        ended = [e for e, until in self.until.items() if until <= at]
        for entity in ended:
            del self.until[entity]
        if ended:
            self._update()

    def _update(self) -> None:
        if self.several is not None and len({self.rooms[e] for e in self.until}) > 1:
            self.value = self.several
        elif self.until:
            self.value = self.rooms[max(self.until, key=self.turned_on.__getitem__)]
        elif self.unknown is not None:
            self.value = self.unknown


def _window(minutes: float) -> timedelta:
    """``quiet`` minutes as a time span; more than a span can hold (``--quiet 1e308``, ``inf``) is
    the longest: no change is then quiet.

    >>> _window(10), _window(1e308) == _window(float("inf")) == timedelta.max
    (datetime.timedelta(seconds=600), True)
    """
    return timedelta.max if minutes >= timedelta.max / timedelta(minutes=1) else timedelta(minutes=minutes)


class EventStream:
    """The context kept over a log's rows, and the switch and quiet rows it makes."""

    def __init__(
        self,
        home: Home,
        readers: Mapping[str, Sequence[Reader]],
        presence: Iterable[Presence] = (),
        *,
        quiet: float | None = None,
        reasons: Sequence[str] = (),
        timespec: str = "auto",
    ) -> None:
        self.home, self.readers, self.quiet, self.timespec = home, readers, quiet, timespec
        self.presence = {p.feature: p for p in presence}
        read = {r.target for rs in readers.values() for r in rs if r.kind == "feature"} | set(self.presence)
        self.clocks = [f.name for f in home.features if f.kind == "clock" and f.name not in read]
        self.watched = [f for f in home.features if f.name not in self.clocks]
        self.values: dict[str, str] = {}
        self.states: dict[str, bool] = {}
        self.skipped: dict[str, int] = dict.fromkeys(reasons, 0)
        self.switches = dict.fromkeys(home.device_names, 0)
        self.near_switch = 0
        self.quiet_rows = 0
        self._rows: list[tuple[datetime, bool, list[str]]] = []  # when, quiet, cells
        self._switched: list[datetime] = []  # every device change, in time order
        self._moment: datetime | None = None
        self._before: tuple[int | None, ...] = ()
        self._counted = False

    # -- feeding ------------------------------------------------------------------------------
    def feed(self, row: LogRow) -> None:
        """Take one row (rows come in time order)."""
        if row.at != self._moment:
            self._close()
            self._expire_before(row.at)
            self._open(row.at)
        self._counted |= row.counted
        for reader in self.readers.get(row.entity, ()):
            try:
                value = reader.read(row)
            except Skip as e:
                self.count(e.reason, row.counted)
                continue
            if reader.kind == "feature":
                self.values[reader.target] = value
            elif reader.kind == "presence":
                self.presence[reader.target].fire(row.entity, value, row.at)
            else:
                self._device(reader.target, value, row)

    def count(self, reason: str, n: int = 1) -> None:
        """Count ``n`` things left out for ``reason``."""
        self.skipped[reason] = self.skipped.get(reason, 0) + n

    def _device(self, device: str, on: bool, row: LogRow) -> None:
        before, self.states[device] = self.states.get(device), on
        if before is None or before == on:
            return
        self._switched.append(row.at)
        if not row.counted or not row.switchable:
            return
        if row.skip:
            self.count(row.skip)
        elif (service := service_for(self.home, device, on)) is None:
            self.count("no_service")
        elif not self._complete():
            self.count("incomplete")
        else:
            cells = self._context(row.at, {device: before})
            self._rows.append((row.at, False, [*cells, service]))
            self.switches[device] += 1

    # -- moments ------------------------------------------------------------------------------
    def _open(self, at: datetime) -> None:
        self._moment, self._counted = at, False
        if self.quiet is not None:
            self._before = self._codes()
        for p in self.presence.values():
            p.expire(at)

    def _close(self) -> None:
        if self._moment is None or self.quiet is None or not self._counted:
            return
        after = self._codes()
        if any(a is not None and b is not None and a != b for a, b in zip(self._before, after, strict=True)):
            if self._complete():
                self._rows.append((self._moment, True, [*self._context(self._moment, {}), ""]))
            else:
                self.count("incomplete")

    def _expire_before(self, at: datetime) -> None:
        """The moments before ``at`` where a presence hold ends."""
        while True:
            ends = [e for p in self.presence.values() if (e := p.next_expiry()) is not None and e < at]
            if not ends:
                return
            self._open(min(ends))
            self._counted = True
            self._close()

    def _codes(self) -> tuple[int | None, ...]:
        out: list[int | None] = []
        for f in self.watched:
            value = self.presence[f.name].value if f.name in self.presence else self.values.get(f.name)
            out.append(None if value is None else f.discretize(value))
        return tuple(out)

    def _complete(self) -> bool:
        """Whether every device's state is known (a feature with no reading yet is ``unknown``)."""
        return len(self.states) == len(self.home.devices)

    def _context(self, at: datetime, before: Mapping[str, bool]) -> list[str]:
        clock = format_clock(at.hour + at.minute / 60 + at.second / 3600)
        row = {
            **dict.fromkeys(self.home.feature_names, UNKNOWN),
            **self.values,
            **{n: p.value for n, p in self.presence.items() if p.value is not None},
            **dict.fromkeys(self.clocks, clock),
        }
        row.update({d: state_word(s) for d, s in {**self.states, **before}.items()})
        names = (*self.home.feature_names, *self.home.device_names)
        return [at.isoformat(timespec=self.timespec), *(str(row[n]) for n in names)]

    # -- out ----------------------------------------------------------------------------------
    def rows(self) -> list[list[str]]:
        """The event file's rows in time order: every switch row, and the quiet rows with no
        switch within ``quiet`` minutes."""
        self._close()
        self._moment = None
        window = _window(self.quiet or 0)
        out, self.near_switch, self.quiet_rows = [], 0, 0
        for at, is_quiet, cells in self._rows:
            if is_quiet:
                i = bisect.bisect_left(self._switched, at)  # the switches around: before and at/after
                if any(abs(s - at) <= window for s in self._switched[max(i - 1, 0) : i + 1]):
                    self.near_switch += 1
                    continue
                self.quiet_rows += 1
            out.append(cells)
        return out

    @property
    def header(self) -> list[str]:
        """The event file's header."""
        return ["timestamp", *self.home.feature_names, *self.home.device_names, "services"]

    def write(self, path: Path) -> int:
        """Write the event file; returns the number of rows."""
        rows = self.rows()
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(self.header)
            writer.writerows(rows)
        return len(rows)


def service_for(home: Home, device: str, on: bool) -> str | None:
    """The service that makes a switch: the one that sets only that device to that state, else
    the one that sets it with the fewest other devices (the first in the home's order).

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> service_for(home, "ceiling_light", True), service_for(home, "window", False)
    ('TurnOnLight', 'CloseWindow')
    """
    setters = [s for s in home.services if (device, on) in s.sets]
    return min(setters, key=lambda s: len(s.sets)).name if setters else None
