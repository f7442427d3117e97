"""Times of day, one parser for all of homecog: home files, contexts, scenario and event files,
the HTTP API, MQTT and Home Assistant states.

A time is ``HH:MM`` or ``HH:MM:SS`` (hours 0–24, minutes and seconds below 60) or decimal hours
(``7.5``); ``24:00`` is the end of the day, which is midnight again.

>>> clock_hours("7:30"), clock_hours("07:30:36"), clock_hours(" 19.25 ")
(7.5, 7.51, 19.25)
>>> parse_clock("24:00"), format_clock(21.5)
(0.0, '21:30')
>>> parse_clock("7:-5")
Traceback (most recent call last):
...
ValueError: not a time: '7:-5'; expected HH:MM or decimal hours
"""

from __future__ import annotations

import math


def clock_hours(text: str | float | int) -> float:
    """A time as decimal hours, unchecked for range: ``"7:30"``, ``"07:30:00"``, ``7.5`` or
    ``"7.5"``; ValueError for anything else."""
    if isinstance(text, bool):
        raise ValueError(f"not a time: {text!r}")
    if isinstance(text, (int, float)):
        return float(text)
    s = str(text).strip()
    if ":" in s:
        parts = s.split(":")
        digits = all(p.strip().isdigit() and len(p.strip()) <= 9 for p in parts)  # 10**5000: no int
        if len(parts) not in (2, 3) or not digits:
            raise ValueError(f"not a time: {text!r}; expected HH:MM or decimal hours")
        h, m = int(parts[0]), int(parts[1])
        sec = int(parts[2]) if len(parts) == 3 else 0
        if m >= 60 or sec >= 60:
            raise ValueError(f"not a time: {text!r}; minutes and seconds must be below 60")
        return h + m / 60 + sec / 3600
    try:
        return float(s)
    except ValueError:
        raise ValueError(f"not a time: {text!r}; expected HH:MM or decimal hours") from None


def format_clock(hours: float) -> str:
    """Decimal hours as ``HH:MM``.

    >>> format_clock(21.5)
    '21:30'
    """
    minutes = round(hours * 60) % (24 * 60)
    return f"{minutes // 60:02d}:{minutes % 60:02d}"


def parse_clock(text: str | float | int) -> float:
    """A time of day as decimal hours in [0, 24): ``"7:30"``, ``"07:30"``, ``7.5`` or ``"7.5"``.

    >>> parse_clock("7:30"), parse_clock(22), parse_clock("24:00")
    (7.5, 22.0, 0.0)
    """
    hours = clock_hours(text)
    if not (0 <= hours <= 24) or math.isnan(hours):
        raise ValueError(f"time {text!r} out of range; expected 00:00 to 24:00")
    return hours % 24
