"""Real data: the MIT home-activity data (Munguia Tapia et al., Pervasive 2004) as a home, a log
and events.

Each subject's folder (``sensors.csv``, ``activities_data.csv``) becomes

- a home file: the time of day, the outdoor illumination, where the subject is and what they do;
  their light switches, lamps, TVs and exhaust fan as devices, with a service to switch each
  on and off; common-sense comfort rules written without looking at the events (light where
  the user is when it is not bright, the TV for watching, the fan for the bathroom, everything
  off when the user is out); and a ``log:`` section mapping the log's entities;
- a log (``timestamp,entity,state``, :mod:`~homecog.evaluation.log_writer`) from the first
  labelled activity's start to the last one's end: every sensor that is not a device an entity
  ``<object>_<id>`` in its room, every device one entity named as the device (a room's two
  light switches are one), ``on`` when its reed switch is activated and ``off`` when it is
  deactivated (a light switch's goes on with the light); the activities' labels the states of
  the entity ``activity`` (the label of the activity under way that started last, ``idle``
  between activities); ``outdoor_illumination`` every 10 minutes; each device ``off`` at the
  start;
- the event file, made from the log by ``homecog log events``: a row per switch of a device,
  with the context just before it and the service that makes it, and a quiet row where the
  location, the behavior or the illumination's bin changes with no switch within 10 minutes.
  ``location`` is the room of the sensor that is not a device and was activated last among
  those activated or deactivated less than 30 minutes ago (``unknown`` when none was): the
  devices the robot is to switch never say where the user is. ``behavior`` is the activity's
  label, grouped.

Illumination is the clear-sky global horizontal irradiance of pvlib's Haurwitz model at the
flats' city (Cambridge, Massachusetts) and the real dates and times, times 110 lx per W/m²: the
real sun, not a measured sky. The data hold no temperature and no weather record for those
weeks is available offline, so the home has no temperature feature — none of the subjects'
recorded devices depends on it.
"""

from __future__ import annotations

import csv
import json
import warnings
from dataclasses import dataclass, field
from datetime import date, datetime, timedelta
from pathlib import Path

from homecog.errors import RealDataError
from homecog.evaluation.log_events import convert_log
from homecog.evaluation.log_writer import (
    ACTIVITY,
    DEVICE,
    PRESENCE,
    YEARS,
    LogWriter,
    camel,
    check_span,
    home_name,
    slug,
    small_numbers,
)
from homecog.home import load_home
from homecog.home.shapes import quoted
from homecog.text_files import check_file

__all__ = ["behavior_of", "convert", "illumination", "read_activities", "read_sensors"]

PLACE = {"latitude": 42.3601, "longitude": -71.0942, "tz": "America/New_York", "name": "Cambridge, MA"}
LUX_PER_WATT = 110.0
READING_MINUTES, HOLD, QUIET = 10, 30, 10

BEHAVIOR = {
    "hygiene": ["Toileting", "Bathing", "Grooming", "Washing hands", "Taking medication"],
    "cooking": [
        "Preparing breakfast",
        "Preparing lunch",
        "Preparing dinner",
        "Preparing a snack",
        "Preparing a beverage",
        "Washing dishes",
        "Putting away dishes",
        "Putting away groceries",
    ],
    "dressing": ["Dressing"],
    "chores": ["Cleaning", "Doing laundry", "Putting away laundry", "Lawnwork", "Other"],
    "leisure": ["Watching TV", "Listening to music", "Talking on telephone"],
    "working": ["Working at computer", "Home education", "Work at home", "Studying"],
    "out": ["Going out to work", "Going out for shopping", "Going out for entertainment"],
}
DEVICE_KINDS = {"light switch": "light", "lamp": "lamp", "tv": "tv", "exhaust fan": "fan"}


@dataclass
class Activity:
    name: str
    start: datetime
    end: datetime
    firings: list[tuple[str, datetime, datetime]] = field(default_factory=list)  # sensor id, on, off


def _time(day: date, text: str, path: Path, line: int) -> datetime:
    """A time of ``day``, H:M:S (hours below 24, minutes and seconds below 60)."""
    try:
        h, m, s = small_numbers(text, ":", (2, 2, 2))
        if h > 23 or m > 59 or s > 59:
            raise ValueError(text)
    except ValueError:
        raise RealDataError(f"{path}: line {line}: {quoted(text)} is not a time H:M:S") from None
    return datetime(day.year, day.month, day.day) + timedelta(hours=h, minutes=m, seconds=s)


def read_sensors(path: Path) -> dict[str, tuple[str, str]]:
    """sensor id -> (room, object)."""
    out = {}
    check_file(path, what="a data set's file", error=RealDataError)  # a regular file, bounded
    try:
        with path.open(newline="", encoding="utf-8", errors="replace") as f:
            for line, row in enumerate(csv.reader(f), start=1):
                if len(row) < 3:
                    raise RealDataError(f"{path}: line {line}: expected SENSOR_ID,LOCATION,OBJECT")
                out[row[0].strip()] = (row[1].strip(), row[2].strip())
    except OSError as e:
        raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
    except csv.Error as e:  # a quoted cell that never ends, or one over the field limit
        raise RealDataError(f"{path}: not CSV: {e}") from None
    return out


def read_activities(path: Path) -> list[Activity]:
    """The activities, in blocks of five lines: name,date,start,end / ids / names / on / off."""
    check_file(path, what="a data set's file", error=RealDataError)  # a regular file, bounded
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as e:
        raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
    while lines and not lines[-1].strip():
        lines.pop()
    if len(lines) % 5:
        raise RealDataError(f"{path}: {len(lines)} lines; expected blocks of 5 lines per activity")
    return [_activity(path, lines, i) for i in range(0, len(lines), 5)]


def _activity(path: Path, lines: list[str], i: int) -> Activity:
    """The activity of the block of five lines from line ``i`` (from 0)."""
    head = lines[i].split(",")
    if len(head) != 4:
        raise RealDataError(f"{path}: line {i + 1}: expected NAME,DATE,START,END")
    day = _day(path, i + 1, head[1])
    start = _time(day, head[2], path, i + 1)
    end = _time(day, head[3], path, i + 1)
    if end < start:
        end += timedelta(days=1)
    ids, ons, offs = (lines[i + k].split(",") if lines[i + k].strip() else [] for k in (1, 3, 4))
    if not len(ids) == len(ons) == len(offs):
        raise RealDataError(f"{path}: lines {i + 2}-{i + 5}: sensor ids and times do not pair up")
    activity = Activity(name=head[0].strip(), start=start, end=end)
    for sensor, on_text, off_text in zip(ids, ons, offs, strict=True):
        on = _time(day, on_text, path, i + 4)
        if on < start - timedelta(hours=12):
            on += timedelta(days=1)
        off = _time(day, off_text, path, i + 5)
        while off < on:
            off += timedelta(days=1)
        activity.firings.append((sensor.strip(), on, off))
    return activity


def _day(path: Path, line: int, text: str) -> date:
    """An activity's date, M/D/YYYY of the years :data:`YEARS`."""
    try:
        month, mday, year = small_numbers(text, "/", (2, 2, 4))
        if year not in YEARS or not 1 <= mday <= 31:
            raise ValueError(text)
        # the data has 4/31/2003: a day past the month's end rolls over, as a clock would
        return date(year, month, 1) + timedelta(days=mday - 1)
    except ValueError:
        raise RealDataError(
            f"{path}: line {line}: {quoted(text)} is not a date M/D/YYYY of the years "
            f"{YEARS[0]} to {YEARS[-1]}"
        ) from None


def behavior_of(name: str) -> str:
    for behavior, names in BEHAVIOR.items():
        if name in names:
            return behavior
    return "chores"


def illumination(times: list[datetime]) -> list[float]:
    """Clear-sky outdoor illuminance (lx) at the flats' city for local times."""
    import pandas as pd
    from pvlib.location import Location

    where = Location(PLACE["latitude"], PLACE["longitude"], tz=PLACE["tz"])
    index = pd.DatetimeIndex(times).tz_localize(PLACE["tz"], ambiguous="NaT", nonexistent="shift_forward")
    with warnings.catch_warnings():  # pvlib 0.16 still calls a pandas 3 deprecated name
        warnings.simplefilter("ignore", FutureWarning)
        warnings.simplefilter("ignore", DeprecationWarning)
        ghi = where.get_clearsky(index, model="haurwitz")["ghi"].fillna(0.0)
    return [round(float(g) * LUX_PER_WATT, 1) for g in ghi]


def convert(folder: Path, out: Path, name: str | None = None) -> tuple[Path, Path, int]:
    """Write ``<name>.yaml``, ``<name>-log.csv`` and ``<name>-events.csv`` for a subject's folder;
    returns the home's and the event file's paths and the number of events."""
    name = home_name(name, f"mit_{slug(folder.name)}")
    sensors = read_sensors(folder / "sensors.csv")
    activities = sorted(read_activities(folder / "activities_data.csv"), key=lambda a: a.start)
    if not activities:
        raise RealDataError(f"{folder / 'activities_data.csv'}: no activities")
    devices: dict[str, tuple[str, str]] = {}  # device -> (room slug, kind)
    device_of: dict[str, str] = {}
    for sid, (room, obj) in sensors.items():
        kind = DEVICE_KINDS.get(obj.lower())
        if kind:
            device = f"{kind}_{slug(room)}"
            devices[device] = (slug(room), kind)
            device_of[sid] = device
    if not devices:
        raise RealDataError(f"{folder}: no light switch, lamp, TV or fan among the sensors")
    check_span(activities[0].start, max(a.end for a in activities), folder / "activities_data.csv")
    log = LogWriter(activities[0].start, max(a.end for a in activities))
    log.activities("activity", [(a.start, a.end, a.name) for a in activities])
    firings: dict[str, list[tuple[datetime, datetime]]] = {d: [] for d in devices}
    for a in activities:
        for sid, on, off in a.firings:
            firings.setdefault(device_of.get(sid) or entity_of(sid, sensors), []).append((on, off))
    for entity, intervals in firings.items():
        log.firings(entity, intervals, DEVICE if entity in devices else PRESENCE)
    times = readings_times(log.start, log.end)
    for t, lux in zip(times, illumination(times), strict=True):
        log.add(t, "outdoor_illumination", f"{lux:g}", ACTIVITY)
    out.mkdir(parents=True, exist_ok=True)
    home_path, log_path, events_path = (out / f"{name}{end}" for end in (".yaml", "-log.csv", "-events.csv"))
    presence = {
        entity_of(sid, sensors): slug(room) for sid, (room, _) in sensors.items() if sid not in device_of
    }
    labels = {a.name: behavior_of(a.name) for a in activities}
    rooms = sorted({slug(r) for r, _ in sensors.values()})
    home_path.write_text(
        _home_yaml(name, folder, [*rooms, "unknown"], devices, presence, labels), encoding="utf-8"
    )
    log.write(log_path)
    result = convert_log(load_home(home_path), log_path, events_path)
    return home_path, events_path, result.rows


def entity_of(sid: str, sensors: dict[str, tuple[str, str]]) -> str:
    """The log's entity of a sensor that is not a device: ``<object>_<id>``.

    >>> entity_of("57", {"57": ("Bathroom", "Medicine cabinet")}), entity_of("9", {})
    ('medicine_cabinet_57', 'sensor_9')
    """
    return f"{slug(sensors[sid][1])}_{sid}" if sid in sensors else f"sensor_{sid}"


def readings_times(start: datetime, end: datetime, every: int = READING_MINUTES) -> list[datetime]:
    """The times of the illumination's readings: the start, then every ``every`` minutes of the
    clock to the end.

    >>> [t.strftime("%H:%M:%S") for t in readings_times(datetime(2003, 4, 1, 7, 3, 5),
    ...     datetime(2003, 4, 1, 7, 25))]
    ['07:03:05', '07:10:00', '07:20:00']
    """
    times = [start]
    t = start.replace(minute=start.minute - start.minute % every, second=0, microsecond=0)
    while (t := t + timedelta(minutes=every)) <= end:
        times.append(t)
    return times


def _home_yaml(
    name: str,
    folder: Path,
    locations: list[str],
    devices: dict[str, tuple[str, str]],
    presence: dict[str, str],
    labels: dict[str, str],
) -> str:
    lines = [
        f"# Made by `homecog adapt-mit` from {folder.name} of the MIT home-activity data",
        "# (Munguia Tapia, Intille, Larson, Pervasive 2004). Illumination: pvlib clear-sky at "
        f"{PLACE['name']}.",
        "# Its log: the sensors' activations and the labelled activities; its events:",
        "# `homecog log events` of that log.",
        f"name: {name}",
        "context:",
        "  time:",
        "    kind: clock",
        "    bins: {night: [22, 6], morning: [6, 10], day: [10, 17], evening: [17, 22]}",
        "  illumination:",
        "    kind: numeric",
        "    unit: lx",
        "    bins: {dark: [0, 10], dim: [10, 10000], bright: [10000, .inf]}",
        f"  location: {{kind: categorical, values: [{', '.join(locations)}]}}",
        f"  behavior: {{kind: categorical, values: [{', '.join([*BEHAVIOR, 'idle'])}]}}",
        "devices:",
    ]
    lines += [f"  {d}: {{room: {room}, iot: true}}" for d, (room, _) in devices.items()]
    lines.append("services:")
    for d in devices:
        lines.append(f"  TurnOn{camel(d)}: {{category: switch_on, set: {{{d}: on}}}}")
        lines.append(f"  TurnOff{camel(d)}: {{category: switch_off, set: {{{d}: off}}}}")
    lines.append("comfort:")
    for d, (room, kind) in devices.items():
        rule = {
            "light": "{when: {location: [%s], illumination: [dark, dim]}, want: on}",
            "lamp": "{when: {location: [%s], illumination: [dark, dim], "
            "behavior: [leisure, working]}, want: on}",
            "tv": "{when: {location: [%s], behavior: [leisure]}, want: on}",
            "fan": "{when: {location: [%s], behavior: [hygiene]}, want: on}",
        }[kind] % room
        lines += [f"  {d}:", "    - {when: {behavior: [out]}, want: off}", f"    - {rule}"]
    lines += ["log:", f"  quiet: {QUIET}", "  devices:", *(f"    {d}: {{entity: {d}}}" for d in devices)]
    lines += ["  features:", "    illumination: {entity: outdoor_illumination}", "    behavior:"]
    lines += ["      entity: activity", "      values:"]
    lines += [f"        {json.dumps(label)}: {group}" for label, group in {**labels, "idle": "idle"}.items()]
    lines += ["    location:", f"      hold: {HOLD}", "      presence:"]
    lines += [f"        {entity}: {room}" for entity, room in presence.items()]
    return "\n".join(lines) + "\n"
