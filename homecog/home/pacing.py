"""How fast a device may be switched, and how far a reading must move before its bin does.

A device may give ``min_on`` / ``min_off`` in the home file (minutes): once switched on, the
robot leaves it on at least ``min_on``; once off, off at least ``min_off``. A numeric feature may
give a ``deadband`` (in its unit): a reading changes bin for the robot only once it is past the
bin's edge by the deadband (hysteresis). Climate devices — heating, cooling, fans: a device whose
name has one of :data:`CLIMATE_WORDS` among its ``_``-separated words — default to
:data:`CLIMATE_MINUTES` either way; a numeric feature in a temperature unit defaults to
:data:`TEMPERATURE_DEADBAND` of it. Everything else defaults to none.

>>> is_climate("ac_living"), is_climate("bedroom_radiator"), is_climate("ceiling_fan"), is_climate("lamp")
(True, True, True, False)
>>> default_deadband("°C"), default_deadband("°F"), default_deadband("lx")
(0.5, 1.0, 0.0)
"""

from __future__ import annotations

import re

#: words of a device's name that make it a climate device
CLIMATE_WORDS = frozenset(
    {
        "ac", "aircon", "airco", "hvac", "climate", "fan", "fans", "heat", "heater", "heaters",
        "heating", "radiator", "radiators", "boiler", "thermostat", "cooler", "cooling", "underfloor",
    }
)  # fmt: skip
#: a climate device's minimum time on and off unless the home file says (minutes)
CLIMATE_MINUTES = 10.0
#: a temperature feature's deadband unless the home file says, per unit
TEMPERATURE_DEADBAND = {"°c": 0.5, "c": 0.5, "degc": 0.5, "celsius": 0.5, "k": 0.5, "°f": 1.0, "f": 1.0}


def is_climate(device: str) -> bool:
    """Whether a device's name says it heats, cools or moves air."""
    words = re.split(r"[_\-\s]+|(?<=[a-z0-9])(?=[A-Z])", device)
    return any(w.lower() in CLIMATE_WORDS for w in words)


def default_minutes(device: str) -> float:
    """A device's minimum time on and off when the home file gives none (minutes)."""
    return CLIMATE_MINUTES if is_climate(device) else 0.0


def default_deadband(unit: str | None) -> float:
    """A numeric feature's deadband when the home file gives none (in its unit)."""
    return TEMPERATURE_DEADBAND.get((unit or "").strip().lower(), 0.0)
