"""The user's day: the ``routine`` section of a home file.

A routine is a list of steps in time order. Each step starts at ``at`` (``"HH:MM"`` or decimal
hours) and holds until the next one; the last holds until the first one of the next day, so
the day wraps midnight. A step gives values of the home's *categorical* context features (the
user's location, posture, behavior, …); a feature a step leaves out keeps its value from the
step before (around the clock). ``set`` lists the devices the user switches by hand when the
step starts; devices otherwise keep their state::

    routine:
      - {at: "07:00", location: bed, posture: lie, behavior: sleep}
      - {at: "07:20", location: table, posture: sit, behavior: read, set: {curtain: on}}
      - {at: "22:30", location: bed, posture: lie, behavior: sleep, set: {lamp: off}}

Clock and numeric features (time, temperature, illumination) come from the clock and the
weather (:mod:`homecog.context.weather`), not from the routine. A home without a routine gets
:func:`default_routine`: one step at 00:00 holding the first value of every categorical feature.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> routine = home.routine
>>> routine.values_at(7.0)["behavior"], routine.values_at(23.5)["location"]
('sleep', 'bed')
>>> routine.values_at(3.0) == routine.values_at(23.9)     # the night wraps midnight
True
"""

from __future__ import annotations

import bisect
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from homecog.errors import HomeFileError
from homecog.home.clock import clock_hours
from homecog.home.states import STATE_WORDS

if TYPE_CHECKING:  # homecog.home imports this module while it loads
    from homecog.home.model import Device, Feature


@dataclass(frozen=True)
class Step:
    """One step of the routine: from ``at`` (hours) the user is in ``values`` and switches ``sets``."""

    at: float
    values: dict[str, str]
    sets: dict[str, bool] = field(default_factory=dict)


@dataclass(frozen=True)
class Routine:
    """The steps of a day, in time order, each with every categorical feature resolved."""

    steps: tuple[Step, ...]

    def index_at(self, hours: float) -> int:
        """The step that holds at ``hours`` (0 ≤ hours < 24): the last one started, wrapping."""
        starts = [round(s.at * 3600) for s in self.steps]  # whole seconds: 07:20 is not 07:19:59.99
        return (bisect.bisect_right(starts, (hours % 24) * 3600 + 1e-6) - 1) % len(self.steps)

    def step_at(self, hours: float) -> Step:
        """The step that holds at ``hours``."""
        return self.steps[self.index_at(hours)]

    def values_at(self, hours: float) -> dict[str, str]:
        """The categorical feature values at ``hours``."""
        return dict(self.step_at(hours).values)


def default_routine(features: Sequence[Feature]) -> Routine:
    """A routine that holds the first value of every categorical feature all day.

    >>> from homecog.home import load_home
    >>> default_routine(load_home("paper").features).values_at(12)
    {'location': 'table', 'posture': 'sit', 'behavior': 'read'}
    """
    values = {f.name: f.values[0] for f in features if f.kind == "categorical"}
    return Routine((Step(0.0, values),))


def _fail(path: str, message: str) -> HomeFileError:
    return HomeFileError(f"<home>: {path}: {message}")


def _hours(value: object, path: str, fail: Callable[[str, str], HomeFileError]) -> float:
    try:
        hours = clock_hours(value)  # type: ignore[arg-type]
    except (ValueError, TypeError):
        raise fail(path, f'expected a time "HH:MM", got {value!r}') from None
    if not 0 <= hours < 24:
        raise fail(path, f"time {value!r} out of range; expected 00:00 to 23:59")
    return hours


def parse_routine(
    section: object,
    features: Sequence[Feature],
    devices: Sequence[Device],
    fail: Callable[[str, str], HomeFileError] = _fail,
) -> Routine:
    """Validate a ``routine`` section against a home's features and devices.

    ``None`` gives :func:`default_routine`. ``fail(key_path, message)`` makes the error (the
    loader's names the file). Steps must be strictly later than the one before.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> r = parse_routine([{"at": "06:00", "behavior": "eat", "set": {"tv_living": "on"}}],
    ...                   home.features, home.devices)
    >>> r.steps[0].values["behavior"], r.steps[0].values["location"], r.steps[0].sets
    ('eat', 'table', {'tv_living': True})
    >>> parse_routine([{"at": "25:00"}], home.features, home.devices)
    Traceback (most recent call last):
    ...
    homecog.errors.HomeFileError: <home>: routine[0].at: time '25:00' out of range; expected 00:00 to 23:59
    """
    if section is None:
        return default_routine(features)
    if not isinstance(section, list) or not section:
        raise fail("routine", 'expected a non-empty list of steps ({at: "07:00", location: bed, ...})')
    by_name = {f.name: f for f in features}
    categorical = [f.name for f in features if f.kind == "categorical"]
    device_names = [d.name for d in devices]
    raw: list[tuple[float, dict[str, str], dict[str, bool]]] = []
    for i, step in enumerate(section):
        raw.append(_step(step, f"routine[{i}]", raw[-1][0] if raw else None, by_name, device_names, fail))
    # a feature a step leaves out keeps the value of the step before, around the clock
    current = {name: by_name[name].values[0] for name in categorical}
    for _ in range(2):
        resolved = []
        for at, values, sets in raw:
            current = {**current, **values}
            resolved.append(Step(at, dict(current), sets))
    return Routine(tuple(resolved))


def _step(
    step: object,
    path: str,
    before: float | None,
    by_name: dict[str, Feature],
    devices: list[str],
    fail: Callable[[str, str], HomeFileError],
) -> tuple[float, dict[str, str], dict[str, bool]]:
    """``(hours, values, sets)`` of one step, later than the one ``before``."""
    if not isinstance(step, dict):
        raise fail(path, f"expected a mapping with 'at', got {type(step).__name__}")
    if "at" not in step:
        raise fail(path, "missing key 'at'")
    at = _hours(step["at"], f"{path}.at", fail)
    if before is not None and at <= before:
        raise fail(f"{path}.at", "steps must be in time order; this one is not after the one before")
    values: dict[str, str] = {}
    sets: dict[str, bool] = {}
    for key, value in step.items():
        if key == "set":
            sets = _sets(value, f"{path}.set", devices, fail)
        elif key != "at":
            values[key] = _value(by_name, key, value, f"{path}.{key}", fail)
    return at, values, sets


def _value(
    by_name: dict[str, Feature],
    key: object,
    value: object,
    path: str,
    fail: Callable[[str, str], HomeFileError],
) -> str:
    """The value a step gives a categorical feature."""
    feature = by_name.get(key) if isinstance(key, str) else None
    if feature is None:
        categorical = [f.name for f in by_name.values() if f.kind == "categorical"]
        raise fail(path, f"unknown feature; expected at, set or one of {', '.join(categorical) or '(none)'}")
    if feature.kind != "categorical":
        raise fail(path, f"a {feature.kind} feature comes from the clock or the weather")
    if not isinstance(value, str) or value not in feature.values:
        raise fail(path, f"unknown value {value!r}; expected one of {', '.join(feature.values)}")
    return value


def _sets(
    value: object, path: str, devices: list[str], fail: Callable[[str, str], HomeFileError]
) -> dict[str, bool]:
    if not isinstance(value, dict):
        raise fail(path, "expected a mapping of devices to on/off")
    out: dict[str, bool] = {}
    for device, state in value.items():
        if device not in devices:
            raise fail(f"{path}.{device}", f"unknown device; expected one of {', '.join(devices)}")
        word: Any = state
        if isinstance(word, str):
            word = STATE_WORDS.get(word.strip().lower())
        if not isinstance(word, bool):
            raise fail(f"{path}.{device}", f"unknown state {state!r}; expected on or off")
        out[device] = word
    return out
