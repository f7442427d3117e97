"""A home's point and its recent past as one row of numbers, for a learner that wants a matrix.

The columns, by kinds, never by a feature's name (so every home gets them):

- every dimension's code (a feature's bin or value, a device's 0/1) as a number;
- every numeric feature's reading (a clock's hour of day, a temperature …);
- every categorical feature of at most :data:`ONE_HOT` values once more, one column a value
  (a tree then separates any value from the others with one split);
- the recent past (:mod:`homecog.home.recent`): the event's hour and weekday, the minutes since
  the previous event, every followed feature's previous value and minutes in the current one,
  per service whether it was wanted at the previous event, per device how long ago it switched
  (the durations as the index of their span, ``<5`` … ``>4h``).

What is unknown — a missing reading, the first event's past, a snapshot without one — is NaN,
which gradient-boosted trees send down the side learned for missing values.

>>> from homecog.home import load_home
>>> from homecog.home.codec import Space
>>> home = load_home("tests/homes/studio.yaml")
>>> columns = Columns(home)
>>> point = Space(home).point({"time": "21:00", "light": "50", "activity": "work",
...     "blind": "on", "desk_lamp": "off", "radio": "off"})
>>> row = columns.row(point)
>>> len(row) == len(columns.names), float(row[columns.names.index("activity=work")])
(True, 1.0)
>>> float(row[columns.names.index("reading time")]), bool(np.isnan(row[columns.names.index("weekday")]))
(21.0, True)
"""

from __future__ import annotations

import numpy as np

from homecog.home.codec import Point, Space
from homecog.home.model import Home
from homecog.home.recent import SPAN_NAMES, UNKNOWN, WEEKDAYS, Recent, recent_names

#: a categorical feature of at most this many values also gets one column a value
ONE_HOT = 32
_SPANS = {name: float(k) for k, name in enumerate(SPAN_NAMES)}
_WEEKDAYS = {name: float(k) for k, name in enumerate(WEEKDAYS)}


class Columns:
    """The row of numbers of a home's points (see the module docstring)."""

    def __init__(self, home: Home) -> None:
        self.home = home
        self.space = Space(home)
        self.numeric = [j for j, dim in enumerate(self.space.dims) if dim.numeric]
        self.hot = [
            (j, f.values)
            for j, f in enumerate(home.features)
            if f.kind == "categorical" and len(f.values) <= ONE_HOT
        ]
        self.recent = recent_names(home)
        # a followed feature's previous value: the index of the value among the feature's own
        self._values = {
            f"previous {f.name}": {v: float(k) for k, v in enumerate(f.values)} for f in home.features
        }
        self.devices = home.device_names
        self.services = home.service_names
        self.names = [
            *self.space.names,
            *(f"reading {self.space.names[j]}" for j in self.numeric),
            *(f"{self.space.names[j]}={v}" for j, values in self.hot for v in values),
            "hour",
            *self.recent,
            *(f"previously {s}" for s in self.services),
            *(f"since {d} switched" for d in self.devices),
        ]

    def row(self, point: Point) -> np.ndarray:
        """The row of a point (its recent past, where it has one)."""
        codes = np.array(point.codes, dtype=np.float64)
        readings = np.array([np.nan if r is None else r for r in point.readings], dtype=np.float64)
        missing = list(point.missing)
        codes[missing] = np.nan
        readings[missing] = np.nan
        return np.concatenate([codes, readings[self.numeric], self._hot(codes), self._past(point.recent)])

    def rows(self, codes: np.ndarray, readings: np.ndarray) -> np.ndarray:
        """The rows of snapshots (samples: codes, and readings with NaN where unknown); their
        recent past is unknown."""
        n = len(codes)
        codes = codes.astype(np.float64)
        hot = [codes[:, j : j + 1] == np.arange(len(values)) for j, values in self.hot]
        past = np.full((n, len(self.names) - len(self.space.names) - len(self.numeric)), np.nan)
        if hot:
            past[:, : sum(len(v) for _, v in self.hot)] = np.concatenate(hot, axis=1)
        return np.concatenate([codes, readings[:, self.numeric].astype(np.float64), past], axis=1)

    def _hot(self, codes: np.ndarray) -> np.ndarray:
        out: list[float] = []
        for j, values in self.hot:
            code = codes[j]
            out += (
                [np.nan] * len(values) if np.isnan(code) else [float(code == k) for k in range(len(values))]
            )
        return np.array(out)

    def _past(self, recent: Recent | None) -> np.ndarray:
        """The recent past's columns: all NaN without one."""
        width = 1 + len(self.recent) + len(self.services) + len(self.devices)
        if recent is None:
            return np.full(width, np.nan)
        at = recent.at
        hour = np.nan if at is None else at.hour + at.minute / 60 + at.second / 3600
        values = [self._word(name, recent.value(name)) for name in self.recent]
        previous = recent.previous
        wanted = [np.nan if previous is None else float(s in previous) for s in self.services]
        ago = [self._word("since", recent.since_switched(d)) for d in self.devices]
        return np.array([hour, *values, *wanted, *ago], dtype=np.float64)

    def _word(self, name: str, word: str) -> float:
        """A recent-past word as a number: a weekday's, a span's or a value's index."""
        if word == UNKNOWN:
            return np.nan
        if name == "weekday":
            return _WEEKDAYS.get(word, np.nan)
        lookup = self._values.get(name, _SPANS)
        return lookup.get(word, np.nan)
