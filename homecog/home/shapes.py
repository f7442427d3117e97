"""The checks every section of a home file is validated with: shapes (a mapping, its keys, a
name, a number, a list of numbers, hours of the day, a device state) and errors that name the
file and the key path.

The functions check a value and fail through ``fail(key path, message)``, the error maker a
section is given (:data:`Fail`); :class:`ShapeChecks` is the same checks with the file's own
error maker, which the top-level sections are built on.

Paths index lists from 0 (``comfort.lamp[2].when``):

>>> checks = ShapeChecks("den.yaml")
>>> checks.hours("07:30", "routine.wake")
7.5
>>> checks.state("yes", "devices.lamp.iot")
True
>>> checks.mapping([1], join_path("comfort", "lamp"))
Traceback (most recent call last):
...
homecog.errors.HomeFileError: den.yaml: comfort.lamp: expected a mapping, got a list
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from homecog.errors import HomeFileError
from homecog.home.clock import clock_hours
from homecog.home.home_file import number_in_range, number_out_of_range
from homecog.home.model import Device, Feature, format_number
from homecog.home.states import STATE_WORDS

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
Fail = Callable[[str, str], HomeFileError]


def parse_device_state(value: object) -> bool | None:
    """A state in the one vocabulary (:mod:`homecog.home.states`); None when it is none of it."""
    if isinstance(value, bool):
        return value
    if isinstance(value, str):
        return STATE_WORDS.get(value.strip().lower())
    return None


def join_path(path: str, key: object) -> str:
    """The key path one step deeper: ``comfort.lamp``, ``comfort.lamp[2]``."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


#: the most characters of a value an error message quotes
QUOTED = 40


def quoted(value: object) -> str:
    """A value as an error message quotes it: its repr, of at most :data:`QUOTED` characters of
    the value (a whole file read as one text is not echoed back).

    >>> quoted("lamp"), quoted("x" * 50)
    ("'lamp'", "'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx…'")
    """
    text = value if isinstance(value, str) else repr(value)
    short = text if len(text) <= QUOTED else text[:QUOTED] + "…"
    return repr(short) if isinstance(value, str) else short


def kind_of(value: object) -> str:
    """What a value is, as an error message says it (``a mapping``, ``the text 'x'``).

    >>> kind_of(None), kind_of([1]), kind_of("on"), kind_of(3.5)
    ('nothing', 'a list', "the text 'on'", '3.5')
    """
    if value is None:
        return "nothing"
    return {dict: "a mapping", list: "a list", str: f"the text {quoted(value)}", bool: f"{value}"}.get(
        type(value), quoted(value)
    )


def mapping_of(
    value: object, path: str, fail: Fail, *, empty: bool = False, kind: Callable[[object], str] = kind_of
) -> dict[Any, Any]:
    """``value`` as a mapping (``None`` is an empty one where ``empty``); ``kind`` words what
    it is instead."""
    if value is None and empty:
        return {}
    if not isinstance(value, dict):
        raise fail(path, f"expected a mapping, got {kind(value)}")
    return value


def check_keys(
    spec: Mapping[Any, Any], path: str, allowed: tuple[str, ...], fail: Fail, required: tuple[str, ...] = ()
) -> None:
    """Every key of ``spec`` one of ``allowed``, and the ``required`` ones there."""
    for key in spec:
        if key not in allowed:
            raise fail(
                f"{path}.{key}" if path else str(key), f"unknown key; expected one of {', '.join(allowed)}"
            )
    for key in required:
        if key not in spec:
            raise fail(path, f"missing key '{key}'")


def mapping_with_keys(
    value: object, path: str, allowed: tuple[str, ...], fail: Fail, *, kind: Callable[[object], str] = kind_of
) -> dict[Any, Any]:
    """``value`` as a mapping (``kind`` words what it is instead) whose every key is one of
    ``allowed``."""
    value = mapping_of(value, path, fail, kind=kind)
    check_keys(value, path, allowed, fail)
    return value


def numbers(value: object, path: str, fail: Fail, n: int, unit: str = "metres") -> tuple[float, ...]:
    """A list of ``n`` finite numbers (a point, a size, a segment in ``unit``).

    >>> numbers([1, 2.5], "layout.size", ShapeChecks("den.yaml").fail, 2)
    (1.0, 2.5)
    """
    ok = isinstance(value, (list, tuple)) and len(value) == n
    ok = ok and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)  # type: ignore[union-attr]
    if not ok or not all(math.isfinite(v) for v in value):  # type: ignore[union-attr]
        raise fail(path, f"expected a list of {n} numbers ({unit}), got {quoted(value)}")
    return tuple(float(v) for v in value)  # type: ignore[union-attr]


def mapped_names(
    section: dict[str, Any],
    path: str,
    features: Sequence[Feature],
    devices: Sequence[Device],
    fail: Fail,
    *,
    kind: Callable[[object], str] = kind_of,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The ``features`` and ``devices`` mappings of a section that maps every feature (but the
    clock ones) and every device of the home to something, such as an entity."""
    by_feature = {f.name: f for f in features}
    by_device = {d.name: d for d in devices}
    fmaps = mapping_of(section.get("features"), f"{path}.features", fail, empty=True, kind=kind)
    dmaps = mapping_of(section.get("devices"), f"{path}.devices", fail, empty=True, kind=kind)
    for given, known, what in ((fmaps, by_feature, "feature"), (dmaps, by_device, "device")):
        for name in given:
            if name not in known:
                raise fail(
                    f"{path}.{what}s.{name}", f"unknown {what} {name!r}; expected one of {', '.join(known)}"
                )
    missing = [n for n, f in by_feature.items() if f.kind != "clock" and n not in fmaps]
    if missing:
        raise fail(
            f"{path}.features", f"no entity for {', '.join(missing)}; every feature but the clock needs one"
        )
    missing = [n for n in by_device if n not in dmaps]
    if missing:
        raise fail(f"{path}.devices", f"no entity for {', '.join(missing)}; every device needs one")
    return fmaps, dmaps


class ShapeChecks:
    """Checks of shapes that fail with the file and the key path; each section builds on them."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, message: str) -> HomeFileError:
        where = f"{path}: " if path else ""
        return HomeFileError(f"{self.source}: {where}{message}")

    def mapping(self, value: object, path: str, *, allow_empty: bool = False) -> dict[Any, Any]:
        value = mapping_of(value, path, self.fail, empty=allow_empty)
        if not value and not allow_empty:
            raise self.fail(path, "is empty; expected at least one entry")
        for key in value:
            if not isinstance(key, str):
                raise self.fail(path, f"key {key!r} is not a name")
        return value

    def keys(
        self, value: dict[Any, Any], path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
    ) -> None:
        check_keys(value, path, allowed, self.fail, required)

    def name(self, value: object, path: str, what: str) -> str:
        if not isinstance(value, str) or not _NAME.match(value):
            raise self.fail(
                path, f"{what} name {quoted(value)} must be letters, digits and _ and not start with a digit"
            )
        return value

    def number(self, value: object, path: str) -> float:
        """A number, or its text (``.inf``, ``1e3``), within ±:data:`MAX_NUMBER`."""
        if isinstance(value, bool):
            raise self.fail(path, f"expected a number, got {quoted(value)}")
        text = value.strip() if isinstance(value, str) else repr(value)
        if isinstance(value, str):
            try:
                value = float(text.replace(".inf", "inf").replace(".Inf", "inf"))
            except ValueError:
                raise self.fail(path, f"expected a number, got {quoted(value)}") from None
        if not isinstance(value, (int, float)) or math.isnan(value):
            raise self.fail(path, f"expected a number, got {quoted(value)}")
        if not number_in_range(value, text):
            raise self.fail(path, number_out_of_range(text))
        return float(value)

    def minutes(self, value: object, path: str) -> float:
        """A time in minutes, 0 to a day."""
        x = self.number(value, path)
        if not 0 <= x <= 1440:
            raise self.fail(path, f"{format_number(x)} minutes; expected 0 to 1440")
        return x

    def hours(self, value: object, path: str) -> float:
        if isinstance(value, str) and ":" in value:
            try:
                value = clock_hours(value)
            except ValueError:
                raise self.fail(path, f'expected hours (7.5 or "07:30"), got {quoted(value)}') from None
        x = self.number(value, path)
        if not 0 <= x <= 24:
            raise self.fail(path, f"hour {format_number(x)} out of range; expected 0 to 24")
        return x

    def state(self, value: object, path: str) -> bool:
        state = parse_device_state(value)
        if state is None:
            raise self.fail(path, f"unknown state {quoted(value)}; expected on or off")
        return state
