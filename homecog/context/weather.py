"""Outdoor temperature and daylight from real weather data, and the light indoors.

The weather is a typical meteorological year: pvlib's bundled TMY3 file of Greensboro, North
Carolina (``pvlib/data/723170TYA.CSV``, read with :func:`pvlib.iotools.read_tmy3`), hourly
dry-bulb temperature (°C) and global horizontal irradiance (GHI, W/m²) in local standard time,
each value labelled with the hour that ends its interval. :class:`Weather` interpolates linearly
between the hours, for any day of the year (29 February reads as 28 February's successor, day
365 at most) and wraps from 31 December to 1 January.

The model of the home:

* **temperature** — the room follows the outdoor temperature; devices neither heat nor cool
  it, so the comfort rules see the weather as it is (an AC that cooled the room would flip its
  own rule and make the robot switch it on and off in turn).
* **illumination** — daylight through the window plus the lights:
  ``GHI × 120 lx per W/m² (luminous efficacy of daylight) × 0.02 (daylight factor of a room)
  × transmission``, where transmission is the share of open curtains/blinds (devices whose
  name holds ``curtain`` or ``blind``; closed ones still let 10 % through; 1 when the home has
  none), plus 300 lx for each light that is on (a device whose name holds ``light``) and
  150 lx for each lamp (``lamp``).

Readings go only to features that exist: a numeric feature with unit °C (or named
``temperature``) gets the temperature, one with unit lx (or named ``illumination``/``light``)
the illumination; any other numeric feature holds a value inside its first bin. Every reading is
kept inside the feature's bins.

>>> from datetime import datetime
>>> w = Weather()
>>> w.temperature(datetime(2021, 6, 17, 12))       # the file's own value at that hour
25.0
>>> w.ghi(datetime(2021, 6, 17, 0)), w.ghi(datetime(2021, 6, 17, 12))
(0.0, 750.0)
>>> indoor_illumination(750.0, {"curtain": True, "lamp": False})
1800.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from datetime import datetime
from functools import lru_cache
from pathlib import Path

import numpy as np

from homecog.home.model import Feature, Home

LUX_PER_W_M2 = 120.0  # luminous efficacy of daylight, lm/W
DAYLIGHT_FACTOR = 0.02  # share of the outdoor illuminance that reaches the room's work plane
CLOSED_TRANSMISSION = 0.1  # what a closed curtain still lets through
LIGHT_LUX = 300.0  # a ceiling light on
LAMP_LUX = 150.0  # a lamp on
_HOURS_PER_YEAR = 8760


def tmy_path() -> Path:
    """The TMY3 file bundled with pvlib (Greensboro, NC)."""
    import pvlib

    return Path(pvlib.__file__).parent / "data" / "723170TYA.CSV"


@lru_cache(maxsize=4)
def _load(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    from pvlib.iotools import read_tmy3

    data, _ = read_tmy3(path, coerce_year=2001, map_variables=True)
    start = data.index[0].replace(month=1, day=1, hour=0)
    hours = ((data.index - start).total_seconds() / 3600).to_numpy() % _HOURS_PER_YEAR
    order = np.argsort(hours, kind="stable")
    return (
        hours[order],
        data["temp_air"].to_numpy(float)[order],
        data["ghi"].to_numpy(float)[order],
    )


def hour_of_year(when: datetime) -> float:
    """Hours since 1 January 00:00 of a typical (365-day) year.

    >>> hour_of_year(datetime(2021, 1, 2, 6, 30))
    30.5
    """
    day = min(when.timetuple().tm_yday, 365)
    return (day - 1) * 24 + when.hour + when.minute / 60 + when.second / 3600


class Weather:
    """Hourly typical-year weather, interpolated; ``path`` a TMY3 file (default pvlib's)."""

    def __init__(self, path: str | Path | None = None) -> None:
        self.path = path

    def _series(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _load(str(self.path if self.path is not None else tmy_path()))

    def temperature(self, when: datetime) -> float:
        """Outdoor dry-bulb temperature (°C) at ``when`` (local standard time)."""
        hours, temp, _ = self._series()
        return float(np.interp(hour_of_year(when), hours, temp, period=_HOURS_PER_YEAR))

    def ghi(self, when: datetime) -> float:
        """Global horizontal irradiance (W/m²) at ``when``."""
        hours, _, ghi = self._series()
        return float(np.interp(hour_of_year(when), hours, ghi, period=_HOURS_PER_YEAR))


def indoor_illumination(ghi: float, states: Mapping[str, bool]) -> float:
    """Illuminance (lx) in the room from daylight ``ghi`` and the devices' ``states``.

    >>> indoor_illumination(0.0, {"ceiling_light": True, "lamp": True})
    450.0
    >>> indoor_illumination(500.0, {"curtain": False})
    120.0
    """
    shades = [on for name, on in states.items() if "curtain" in name or "blind" in name]
    if shades:
        open_share = sum(shades) / len(shades)
        transmission = open_share + (1 - open_share) * CLOSED_TRANSMISSION
    else:
        transmission = 1.0
    lux = max(ghi, 0.0) * LUX_PER_W_M2 * DAYLIGHT_FACTOR * transmission
    for name, on in states.items():
        if on and "light" in name:
            lux += LIGHT_LUX
        elif on and "lamp" in name:
            lux += LAMP_LUX
    return round(lux, 1)


def clamp(feature: Feature, x: float) -> float:
    """``x`` kept inside the feature's bins (just below a finite upper bound).

    >>> from homecog.home import load_home
    >>> clamp(load_home("paper").feature("illumination"), -3.0)
    0.0
    """
    assert feature.bins is not None
    low = min(b[0] for b in feature.bins)
    high = max(b[1] for b in feature.bins)
    x = max(x, low)
    if x >= high:
        x = high - min(0.1, (high - low) / 10 if math.isfinite(low) else 0.1)
    return x


def _steady(feature: Feature) -> float:
    assert feature.bins is not None
    low, high = feature.bins[0]
    if math.isfinite(low) and math.isfinite(high):
        return (low + high) / 2
    return low + 1 if math.isfinite(low) else high - 1


def numeric_readings(
    home: Home, when: datetime, states: Mapping[str, bool], weather: Weather | None = None
) -> dict[str, float]:
    """The reading of every numeric feature of ``home`` at ``when`` with devices ``states``.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> off = {d: False for d in home.device_names}
    >>> numeric_readings(home, datetime(2021, 6, 17, 12), off)
    {'temperature': 25.0, 'illumination': 180.0}
    """
    weather = weather or Weather()
    out: dict[str, float] = {}
    for f in home.features:
        if f.kind != "numeric":
            continue
        unit = (f.unit or "").strip().lower()
        if unit in ("°c", "c", "degc", "celsius") or f.name == "temperature":
            x = weather.temperature(when)
        elif unit in ("lx", "lux") or f.name in ("illumination", "light"):
            x = indoor_illumination(weather.ghi(when), states)
        else:
            x = _steady(f)
        out[f.name] = clamp(f, x)
    return out
