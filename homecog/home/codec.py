"""The context codec: a context as people write it, as every stage reads it, and back.

The space of a home is its context features followed by its devices (the knowledge tree's
input space, the paper's Table 5). A context as people write it (``{"time": "7:00",
"temperature": 25, ..., "window": "off"}``) becomes a :class:`Point`: one discrete code per
dimension (a feature's bin or value, a device's 0/1) and the raw numeric readings, which the
paper's clusters keep as mean ± range (Table 6). :func:`normalize` writes one value as the
context writes it (MQTT payloads, values set by hand, Home Assistant states).

>>> from homecog.home import load_home
>>> space = Space(load_home("paper"))
>>> p = space.point({"time": "22:00", "temperature": 19, "illumination": 200,
...     "location": "table", "posture": "sit", "behavior": "read", "window": "on",
...     "curtain": "on", "tv_living": "off", "tv_bedroom": "off", "ac_living": "off",
...     "ac_bedroom": "off", "lamp": "on", "ceiling_light": "on"})
>>> p.codes
(5, 0, 1, 0, 0, 0, 1, 1, 0, 0, 0, 0, 1, 1)
>>> space.describe(p)["time"]
'22:00 (night)'
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from homecog.errors import ContextError
from homecog.home.clock import format_clock, parse_clock
from homecog.home.model import Feature, Home, format_number
from homecog.home.recent import Recent
from homecog.home.states import STATE_WORDS, parse_state, state_word
from homecog.names import shown


@dataclass(frozen=True)
class Dimension:
    """One input dimension: a context feature or a device."""

    name: str
    kind: str  # clock, numeric, categorical or device
    values: tuple[str, ...]  # bin names, categories, or ("off", "on")

    @property
    def numeric(self) -> bool:
        return self.kind in ("clock", "numeric")


@dataclass(frozen=True)
class Point:
    """A context in the input space: codes per dimension, raw readings of numeric ones, and
    the recent past where a stream says it (:mod:`homecog.home.recent`; None: a snapshot)."""

    codes: tuple[int, ...]
    readings: tuple[float | None, ...]
    recent: Recent | None = None
    # the features whose reading is missing (``unknown``): their code is a placeholder (0) that
    # no stage may read as a value, their reading None
    missing: frozenset[int] = frozenset()


#: what a missing reading is written as (an empty cell reads as it too)
UNKNOWN = "unknown"


def is_missing(feature: Feature, value: object) -> bool:
    """Whether a context's value for a feature says its reading is missing: ``unknown`` or
    empty, where the feature has no value of that name (a categorical feature may list
    ``unknown`` as one of its values, and then it is that value).

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> temperature = home.features[1]
    >>> is_missing(temperature, "unknown"), is_missing(temperature, ""), is_missing(temperature, 25)
    (True, True, False)
    """
    if value is None or not isinstance(value, str):
        return value is None
    word = value.strip().lower()
    return word in (UNKNOWN, "") and not (feature.values and word in feature.values and feature.bins is None)


class Space:
    """The dimensions of a home's knowledge: its features, then its devices."""

    def __init__(self, home: Home) -> None:
        self.home = home
        dims = [Dimension(f.name, f.kind, f.values) for f in home.features]
        dims += [Dimension(d.name, "device", ("off", "on")) for d in home.devices]
        self.dims = tuple(dims)
        self.names = tuple(d.name for d in dims)
        self.index = {name: i for i, name in enumerate(self.names)}
        self.n_features = len(home.features)
        self._parsers = [self._parser(f) for f in home.features]
        states: dict[object, int] = {w: int(on) for w, on in STATE_WORDS.items()} | {True: 1, False: 0}
        self._parsers += [(d.name, "device", states) for d in home.devices]

    @staticmethod
    def _parser(f: Feature) -> tuple[str, str, Any]:
        if f.kind == "categorical":
            return f.name, "categorical", {v: k for k, v in enumerate(f.values)}
        # sorted cut points; a reading maps to the bin that starts at the last cut below it
        cuts: list[tuple[float, int]] = []
        for k, (low, high) in enumerate(f.bins or ()):
            cuts.append((low, k))
            if low > high:  # a clock bin wrapping midnight also starts at 00:00
                cuts.append((0.0, k))
            cuts.append((high, -1))
        cuts.sort(key=lambda c: (c[0], c[1] < 0))
        edges, order = [], []
        for x, k in cuts:  # at a shared bound the starting bin wins over the ending one
            if edges and edges[-1] == x:
                if k >= 0:
                    order[-1] = k
                continue
            edges.append(x)
            order.append(k)
        return f.name, f.kind, (edges, order)

    def __len__(self) -> int:
        return len(self.dims)

    def point(self, context: Mapping[str, object]) -> Point:
        """A full context (every feature and device, as in a scenario file) as a point; a
        feature's value ``unknown`` (or empty) is a missing reading (:func:`is_missing`)."""
        features = self.home.features
        missing = frozenset(j for j, f in enumerate(features) if is_missing(f, context.get(f.name, 0)))
        if missing:
            return self._point_missing(context, missing)
        if len(context) == len(self.names):
            try:
                return self._fast_point(context)
            except (KeyError, ValueError, TypeError, IndexError):
                pass  # the validating path below names what is wrong
        codes, states = self.home.discretize(context)
        readings: list[float | None] = []
        for f in self.home.features:
            readings.append(None if f.is_discrete else float(f.parse(context[f.name])))  # type: ignore[arg-type]
        readings += [None] * len(states)
        return Point(codes=codes + tuple(int(s) for s in states), readings=tuple(readings))

    def _point_missing(self, context: Mapping[str, object], missing: frozenset[int]) -> Point:
        """A point with missing readings: the others read as usual, the missing ones a
        placeholder code (0) and no reading."""
        filled = dict(context)
        for j in missing:
            f = self.home.features[j]
            filled[f.name] = f.values[0] if f.bins is None else bin_reading(f.bins[0])
        p = self.point(filled)
        codes = tuple(0 if j in missing else c for j, c in enumerate(p.codes))
        readings = tuple(None if j in missing else r for j, r in enumerate(p.readings))
        return Point(codes=codes, readings=readings, missing=missing)

    def word(self, p: Point, j: int) -> str:
        """Dimension ``j`` of a point as one word: its value or bin, ``on``/``off``, or ``unknown``."""
        return UNKNOWN if j in p.missing else self.dims[j].values[p.codes[j]]

    def _fast_point(self, context: Mapping[str, object]) -> Point:
        """The common case, well-formed input, without the validation of Home.discretize."""
        codes = []
        readings: list[float | None] = []
        for name, kind, lookup in self._parsers:
            value = context[name]
            if kind == "categorical":
                codes.append(lookup[value])
                readings.append(None)
            elif kind == "device":
                codes.append(lookup[value if isinstance(value, bool) else str(value).lower()])
                readings.append(None)
            else:
                if kind == "clock":  # the home's one clock parser, so both read a time alike
                    x = parse_clock(value)  # type: ignore[arg-type]
                else:
                    x = float(value)  # type: ignore[arg-type]
                    if isinstance(value, bool) or x != x:
                        raise ValueError(value)
                edges, order = lookup
                k = order[bisect.bisect_right(edges, x) - 1]
                if k < 0:
                    raise ValueError(value)
                codes.append(k)
                readings.append(x)
        return Point(codes=tuple(codes), readings=tuple(readings))

    def describe(self, p: Point) -> dict[str, str]:
        """A point as readable values: ``{"time": "22:00 (night)", "window": "on", ...}``."""
        out = {}
        for j, (dim, code, reading) in enumerate(zip(self.dims, p.codes, p.readings, strict=True)):
            value = UNKNOWN if j in p.missing else dim.values[code]
            if reading is None:
                out[dim.name] = value
            elif dim.kind == "clock":
                out[dim.name] = f"{format_clock(reading)} ({value})"
            else:
                out[dim.name] = f"{format_number(round(reading, 2))} ({value})"
        return out

    def context(self, p: Point) -> dict[str, str]:
        """A point as a context mapping (readings as text, devices on/off), as a scenario row."""
        out = {}
        for j, (dim, code, reading) in enumerate(zip(self.dims, p.codes, p.readings, strict=True)):
            if j in p.missing:
                out[dim.name] = UNKNOWN
            elif reading is None:
                out[dim.name] = dim.values[code]
            elif dim.kind == "clock":
                out[dim.name] = format_clock(reading)
            else:
                out[dim.name] = format_number(round(reading, 4))
        return out


def parse_context(text: str, space: Space) -> Point:
    """A context as text: comma-separated ``name=value`` for every feature and device.

    >>> from homecog.home import load_home
    >>> space = Space(load_home("paper"))
    >>> text = ("time=7:00,temperature=25,illumination=100,location=bed,posture=lie,"
    ...         "behavior=sleep,window=off,curtain=off,tv_living=off,tv_bedroom=off,"
    ...         "ac_living=off,ac_bedroom=off,lamp=off,ceiling_light=off")
    >>> parse_context(text, space).codes[:6]
    (0, 1, 1, 2, 1, 2)
    """
    pairs: dict[str, str] = {}
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        name, equals, value = (s.strip() for s in part.partition("="))
        if not equals or not name:
            raise ContextError(f"context: {shown(part)} is malformed: expected name=value")
        if name in pairs:
            raise ContextError(f"context: {name} given twice")
        pairs[name] = value
    return space.point(pairs)


def parse_services(text: str | list[str], home: Home) -> list[str]:
    """A list of services wanted (comma-separated names), validated; an empty string is none."""
    names = [s.strip() for s in text.split(",")] if isinstance(text, str) else [s.strip() for s in text]
    names = [n for n in names if n]
    known = set(home.service_names)
    for n in names:
        if n not in known:
            raise ContextError(f"unknown service {n!r}; expected some of {', '.join(home.service_names)}")
    seen: list[str] = []
    for n in names:
        if n not in seen:
            seen.append(n)
    return seen


def finite_span(bins: tuple[tuple[float, float], ...]) -> tuple[float, ...]:
    """Bounds to draw random readings from for each bin (infinite ends made finite).

    An open end reaches three times the widest finite bin beyond the outermost finite bound,
    e.g. temperature ``cold: [-inf, 25)`` with a 5-degree ``suitable`` bin draws from [10, 25).
    """
    finite = [b for b in bins if not (math.isinf(b[0]) or math.isinf(b[1]))]
    width = max((b[1] - b[0] for b in finite), default=1.0) * 3 or 1.0
    out = []
    for low, high in bins:
        if math.isinf(low):
            low = high - width
        if math.isinf(high):
            high = low + width
        out.extend([low, high])
    return tuple(out)


def reading_in_bin(feature: Feature, code: Any, u: Any) -> Any:
    """A reading of a numeric feature inside its bin ``code`` from a uniform draw ``u`` in
    [0, 1) (arrays of both give an array): two decimals, rounded down so that a reading never
    leaves its half-open bin; a clock bin that wraps midnight is drawn on its unwrapped span.

    >>> from homecog.home import load_home
    >>> temperature = load_home("paper").feature("temperature")   # cold: [10, 25) drawn
    >>> float(reading_in_bin(temperature, 0, 0.5))
    17.5
    """
    bounds = np.array(finite_span(feature.bins)).reshape(-1, 2)  # type: ignore[arg-type]
    low, high = bounds[code, 0], bounds[code, 1]
    if feature.kind == "clock":
        high = np.where(high <= low, high + 24, high)
    values = np.maximum(np.floor((low + (high - low) * u) * 100) / 100, low)
    return values % 24 if feature.kind == "clock" else values


def normalize(home: Home, name: str, value: object) -> str:
    """One value of a feature or device as the context writes it: a clock ``HH:MM``, a number
    without trailing zeros, a category, ``on``/``off``; ContextError naming what does not fit.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> normalize(home, "time", "7:30"), normalize(home, "temperature", "25.0"), normalize(home, "lamp", "ON")
    ('07:30', '25', 'on')
    """
    for f in home.features:
        if f.name == name:
            f.discretize(value)  # raises naming the feature when the value fits no bin
            parsed = f.parse(value)
            if f.kind == "clock":
                return format_clock(float(parsed))
            if f.kind == "numeric":
                return format_number(float(parsed))
            return str(parsed)
    if name in home.device_names:
        return state_word(parse_state(value, name))
    raise ContextError(
        f"unknown feature or device {name!r}; expected {', '.join(home.feature_names + home.device_names)}"
    )


def json_context(home: Home, values: Mapping[str, object]) -> dict[str, str | float]:
    """Context values as the contract writes them (the clock ``HH:MM``, numbers as numbers,
    devices ``on``/``off``), from text as a context source or a scenario file has them.
    Raises :class:`~homecog.errors.ContextError` (or ``ValueError``) for a value that does not fit.

    >>> from homecog.home import load_home
    >>> json_context(load_home("paper"), {"time": "7:05", "temperature": "25", "lamp": "ON"})
    {'time': '07:05', 'temperature': 25.0, 'lamp': 'on'}
    """
    out: dict[str, str | float] = {}
    for name, value in values.items():
        kind = _kind(home, name)
        if kind == "clock":
            out[name] = format_clock(parse_clock(value))  # type: ignore[arg-type]
        elif kind == "numeric":
            out[name] = float(home.feature(name).parse(value))
        elif kind == "device":
            out[name] = state_word(parse_state(value, name))
        else:
            out[name] = str(value)
    return out


def _kind(home: Home, name: str) -> str:
    if name in home.device_names:
        return "device"
    return home.feature(name).kind


def bin_reading(bin_: tuple[float, float]) -> float:
    """A reading inside a bin ``[low, high)``: its middle where both ends are finite (a clock
    bin may wrap midnight), else one unit inside its finite end.

    >>> bin_reading((25.0, 30.0)), bin_reading((-math.inf, 25.0)), bin_reading((22.0, 6.0))
    (27.5, 24.0, 2.0)
    >>> bin_reading((30.0, math.inf))
    31.0
    """
    low, high = bin_
    if math.isinf(low):
        return high - 1.0
    if math.isinf(high):
        return low + 1.0
    if low > high:  # a clock bin over midnight
        return (low + (high + 24 - low) / 2) % 24
    return (low + high) / 2
