"""The checks every section of a home file is validated with: shapes (a mapping, a name, a
number, hours of the day, a device state) and errors that name the file and the key path.

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
from typing import Any

from homecog.errors import HomeFileError
from homecog.home.clock import clock_hours
from homecog.home.model import format_number
from homecog.home.states import STATE_WORDS

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


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


def kind_of(value: object) -> str:
    """What a value is, as an error message says it (``a mapping``, ``the text 'x'``)."""
    if value is None:
        return "nothing"
    return {dict: "a mapping", list: "a list", str: f"the text {value!r}", bool: f"{value}"}.get(
        type(value), f"{value!r}"
    )


class ShapeChecks:
    """Checks of shapes that fail with the file and the key path; each section builds on them."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, message: str) -> HomeFileError:
        where = f"{path}: " if path else ""
        return HomeFileError(f"{self.source}: {where}{message}")

    def mapping(self, value: object, path: str, *, allow_empty: bool = False) -> dict[Any, Any]:
        if value is None and allow_empty:
            return {}
        if not isinstance(value, dict):
            raise self.fail(path, f"expected a mapping, got {kind_of(value)}")
        if not value and not allow_empty:
            raise self.fail(path, "is empty; expected at least one entry")
        for key in value:
            if not isinstance(key, str):
                raise self.fail(path, f"key {key!r} is not a name")
        return value

    def keys(
        self, value: dict[Any, Any], path: str, allowed: tuple[str, ...], required: tuple[str, ...] = ()
    ) -> None:
        for key in value:
            if key not in allowed:
                raise self.fail(join_path(path, key), f"unknown key; expected one of {', '.join(allowed)}")
        for key in required:
            if key not in value:
                raise self.fail(path, f"missing key '{key}'")

    def name(self, value: object, path: str, what: str) -> str:
        if not isinstance(value, str) or not _NAME.match(value):
            raise self.fail(
                path, f"{what} name {value!r} must be letters, digits and _ and not start with a digit"
            )
        return value

    def number(self, value: object, path: str) -> float:
        if isinstance(value, bool):
            raise self.fail(path, f"expected a number, got {value!r}")
        if isinstance(value, str):
            try:
                value = float(value.strip().replace(".inf", "inf").replace(".Inf", "inf"))
            except ValueError:
                raise self.fail(path, f"expected a number, got {value!r}") from None
        if not isinstance(value, (int, float)) or math.isnan(value):
            raise self.fail(path, f"expected a number, got {value!r}")
        return float(value)

    def hours(self, value: object, path: str) -> float:
        if isinstance(value, str) and ":" in value:
            try:
                value = clock_hours(value)
            except ValueError:
                raise self.fail(path, f'expected hours (7.5 or "07:30"), got {value!r}') from None
        x = self.number(value, path)
        if not 0 <= x <= 24:
            raise self.fail(path, f"hour {format_number(x)} out of range; expected 0 to 24")
        return x

    def state(self, value: object, path: str) -> bool:
        state = parse_device_state(value)
        if state is None:
            raise self.fail(path, f"unknown state {value!r}; expected on or off")
        return state
