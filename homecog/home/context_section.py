"""The ``context`` section of a home file: its features, their values or bins.

A categorical feature lists its values; a numeric feature has bins that must neither overlap nor
leave gaps between them (they need not cover the whole line); a clock feature has bins that
must tile the whole day, one of them may wrap midnight (``night: [21, 7]``).

>>> from homecog.home import load_home_text
>>> load_home_text('''
... name: den
... context: {time: {kind: clock, bins: {day: [7, 21], night: [21, 6]}}}
... devices: {lamp: {}}
... services: {LampOn: {category: on, set: {lamp: on}}}
... comfort: {lamp: [{want: on}]}
... ''', "den.yaml")
Traceback (most recent call last):
...
homecog.errors.HomeFileError: den.yaml: context.time.bins: gap between bins 'night' and 'day' (06:00 to 07:00)
"""

from __future__ import annotations

import itertools
import math

from homecog.home.model import Feature, format_number
from homecog.home.pacing import default_deadband
from homecog.home.shapes import ShapeChecks, kind_of

_KINDS = ("clock", "numeric", "categorical")


class ContextSection(ShapeChecks):
    """The validation of the ``context`` section."""

    def features(self, section: object) -> tuple[Feature, ...]:
        section = self.mapping(section, "context")
        return tuple(self.feature(name, spec, f"context.{name}") for name, spec in section.items())

    def feature(self, name: str, spec: object, path: str) -> Feature:
        self.name(name, path, "feature")
        spec = self.mapping(spec, path)
        self.keys(spec, path, ("kind", "unit", "bins", "values", "description", "deadband"), ("kind",))
        kind = spec["kind"]
        if kind not in _KINDS:
            raise self.fail(f"{path}.kind", f"unknown kind {kind!r}; expected one of {', '.join(_KINDS)}")
        unit = spec.get("unit")
        if unit is not None:
            unit = str(unit)
        if kind == "categorical":
            return Feature(
                name=name, kind="categorical", values=self.categorical_values(spec, path), unit=unit
            )
        if "deadband" in spec and kind != "numeric":
            raise self.fail(f"{path}.deadband", f"a deadband is for numeric features, not {kind} ones")
        names, bins = self.bins(spec, path, kind)
        deadband = default_deadband(unit) if kind == "numeric" else 0.0
        if "deadband" in spec:
            deadband = self.number(spec["deadband"], f"{path}.deadband")
            if not 0 <= deadband < math.inf:
                raise self.fail(f"{path}.deadband", f"{format_number(deadband)}; expected 0 or more")
        return Feature(name=name, kind=kind, values=names, bins=bins, unit=unit, deadband=deadband)

    def categorical_values(self, spec: dict[str, object], path: str) -> tuple[str, ...]:
        """The values of a categorical feature: names, each once."""
        if "bins" in spec:
            raise self.fail(f"{path}.bins", "a categorical feature has values, not bins")
        if "values" not in spec:
            raise self.fail(path, "missing key 'values'")
        values = spec["values"]
        if not isinstance(values, list):
            raise self.fail(f"{path}.values", f"expected a list, got {kind_of(values)}")
        if not values:
            raise self.fail(f"{path}.values", "empty value list")
        names: list[str] = []
        for i, v in enumerate(values):
            if isinstance(v, (dict, list)) or v is None:
                raise self.fail(f"{path}.values[{i}]", f"expected a value name, got {kind_of(v)}")
            text = str(v).strip()
            if not text or any(c in text for c in ",=;\n"):
                raise self.fail(f"{path}.values[{i}]", f"value {text!r} may not be empty or contain , = ;")
            if text in names:
                raise self.fail(f"{path}.values[{i}]", f"duplicate value {text!r}")
            names.append(text)
        return tuple(names)

    def bins(
        self, spec: dict[str, object], path: str, kind: str
    ) -> tuple[tuple[str, ...], tuple[tuple[float, float], ...]]:
        """The names and bounds of the bins of a numeric or clock feature, checked to cover."""
        if "values" in spec:
            raise self.fail(f"{path}.values", f"a {kind} feature has bins, not values")
        if "bins" not in spec:
            raise self.fail(path, "missing key 'bins'")
        names, bins = [], []
        for bin_name, bounds in self.mapping(spec["bins"], f"{path}.bins").items():
            bpath = f"{path}.bins.{bin_name}"
            self.name(bin_name, bpath, "bin")
            names.append(bin_name)
            bins.append(self.bounds(bounds, bpath, kind))
        if kind == "clock":
            self.check_clock_cover(names, bins, f"{path}.bins")
        else:
            self.check_numeric_cover(names, bins, f"{path}.bins")
        return tuple(names), tuple(bins)

    def bounds(self, bounds: object, path: str, kind: str) -> tuple[float, float]:
        """``[low, high]`` of one bin: hours of the day (wrapping midnight) or numbers."""
        if not isinstance(bounds, list) or len(bounds) != 2:
            raise self.fail(path, f"expected [low, high], got {bounds!r}")
        if kind == "clock":
            low, high = (self.hours(b, f"{path}[{i}]") for i, b in enumerate(bounds))
            if low == high:  # [0, 24] and [24, 0] are the whole day, not empty
                raise self.fail(path, f"empty bin [{format_number(low)}, {format_number(high)}]")
            return low % 24, high % 24
        low, high = (self.number(b, f"{path}[{i}]") for i, b in enumerate(bounds))
        if low >= high:
            raise self.fail(
                path, f"bins reversed: low {format_number(low)} is not below high {format_number(high)}"
            )
        return low, high

    def check_numeric_cover(self, names: list[str], bins: list[tuple[float, float]], path: str) -> None:
        order = sorted(range(len(bins)), key=lambda k: bins[k])
        for a, b in itertools.pairwise(order):
            (_, a_high), (b_low, _) = bins[a], bins[b]
            if a_high > b_low:
                raise self.fail(
                    path,
                    f"bins '{names[a]}' and '{names[b]}' overlap "
                    f"({format_number(b_low)} to {format_number(a_high)})",
                )
            if a_high < b_low:
                raise self.fail(
                    path,
                    f"gap between bins '{names[a]}' and '{names[b]}' "
                    f"({format_number(a_high)} to {format_number(b_low)})",
                )

    def check_clock_cover(self, names: list[str], bins: list[tuple[float, float]], path: str) -> None:
        # Cut wrapping bins at midnight, then the pieces must tile [0, 24) exactly.
        pieces: list[tuple[float, float, int]] = []
        for k, (low, high) in enumerate(bins):
            if low < high:
                pieces.append((low, high, k))
            else:
                pieces.append((low, 24.0, k))
                if high > 0:
                    pieces.append((0.0, high, k))
        pieces.sort()
        hhmm = _hhmm
        if pieces[0][0] > 0:
            raise self.fail(path, f"the clock bins leave a gap from 00:00 to {hhmm(pieces[0][0])}")
        for (_, a_high, a), (b_low, _, b) in itertools.pairwise(pieces):
            if a_high > b_low:
                raise self.fail(
                    path,
                    f"bins '{names[a]}' and '{names[b]}' overlap "
                    f"({hhmm(b_low)} to {hhmm(min(a_high, 24.0))})",
                )
            if a_high < b_low:
                raise self.fail(
                    path, f"gap between bins '{names[a]}' and '{names[b]}' ({hhmm(a_high)} to {hhmm(b_low)})"
                )
        if pieces[-1][1] < 24:
            raise self.fail(path, f"the clock bins leave a gap from {hhmm(pieces[-1][1])} to 24:00")


def _hhmm(hours: float) -> str:
    minutes = round(hours * 60)
    return f"{minutes // 60:02d}:{minutes % 60:02d}"
