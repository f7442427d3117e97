"""Real data: the MIT home-activity data (Munguia Tapia et al., Pervasive 2004) as a home and events.

Each subject's folder (``sensors.csv``, ``activities_data.csv``) becomes

- a home file: the time of day, the outdoor illumination, where the subject is and what they do;
  their light switches, lamps, TVs and exhaust fan as devices, with a service to switch each
  on and off; and common-sense comfort rules written without looking at the events (light where
  the user is when it is not bright, the TV for watching, the fan for the bathroom, everything
  off when the user is out);
- an event file (SPEC §9): one row per labelled activity, at its start: the context (the time
  of its start; the outdoor illumination then; ``behavior`` from the activity's label;
  ``location`` the room whose *other* sensors — cabinets, doors, appliances, never the devices
  the robot is to switch — fired most during the activity, ``out`` when the label says the
  subject went out), the devices' states then (a reed switch on a light switch is activated
  when the light goes on and deactivated when it goes off), and as ``services`` what the
  subject switched during the activity — the services this person really wanted.

Illumination is the clear-sky global horizontal irradiance of pvlib's Haurwitz model at the
flats' city (Cambridge, Massachusetts) and the real dates and times, times 110 lx per W/m²: the
real sun, not a measured sky. The data hold no temperature and no weather record for those
weeks is available offline, so the home has no temperature feature — none of the subjects'
recorded devices depends on it.
"""

from __future__ import annotations

import csv
import re
import warnings
from dataclasses import dataclass, field
from datetime import date, datetime, timedelta
from pathlib import Path

from homecog.errors import RealDataError

PLACE = {"latitude": 42.3601, "longitude": -71.0942, "tz": "America/New_York", "name": "Cambridge, MA"}
LUX_PER_WATT = 110.0

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


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "_", text.strip().lower()).strip("_")


def camel(text: str) -> str:
    return "".join(part.capitalize() for part in slug(text).split("_"))


@dataclass
class Activity:
    name: str
    start: datetime
    end: datetime
    firings: list[tuple[str, datetime, datetime]] = field(default_factory=list)  # sensor id, on, off


def _time(day: date, text: str, path: Path, line: int) -> datetime:
    parts = text.strip().split(":")
    try:
        h, m, s = (int(p) for p in parts)
        return datetime(day.year, day.month, day.day) + timedelta(hours=h, minutes=m, seconds=s)
    except ValueError:
        raise RealDataError(f"{path}: line {line}: {text!r} is not a time H:M:S") from None


def read_sensors(path: Path) -> dict[str, tuple[str, str]]:
    """sensor id -> (room, object)."""
    out = {}
    try:
        with path.open(newline="", encoding="utf-8", errors="replace") as f:
            for line, row in enumerate(csv.reader(f), start=1):
                if len(row) < 3:
                    raise RealDataError(f"{path}: line {line}: expected SENSOR_ID,LOCATION,OBJECT")
                out[row[0].strip()] = (row[1].strip(), row[2].strip())
    except OSError as e:
        raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
    return out


def read_activities(path: Path) -> list[Activity]:
    """The activities, in blocks of five lines: name,date,start,end / ids / names / on / off."""
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError as e:
        raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
    while lines and not lines[-1].strip():
        lines.pop()
    if len(lines) % 5:
        raise RealDataError(f"{path}: {len(lines)} lines; expected blocks of 5 lines per activity")
    out = []
    for i in range(0, len(lines), 5):
        head = lines[i].split(",")
        if len(head) != 4:
            raise RealDataError(f"{path}: line {i + 1}: expected NAME,DATE,START,END")
        try:
            month, mday, year = (int(x) for x in head[1].strip().split("/"))
            # the data has 4/31/2003: a day past the month's end rolls over, as a clock would
            day = date(year, month, 1) + timedelta(days=mday - 1)
        except ValueError:
            raise RealDataError(f"{path}: line {i + 1}: {head[1]!r} is not a date M/D/YYYY") from None
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
        out.append(activity)
    return out


def behavior_of(name: str) -> str:
    for behavior, names in BEHAVIOR.items():
        if name in names:
            return behavior
    return "chores"


def location_of(activity: Activity, sensors: dict[str, tuple[str, str]], device_of: dict[str, str]) -> str:
    """The room whose sensors fired most during an activity, among the sensors that are not
    devices: a light switched during the activity is what the robot is to predict, so it must not
    say where the user is. Ties go to the room first in alphabetical order; none fired: unknown."""
    counts: dict[str, int] = {}
    for sid, _, _ in activity.firings:
        if sid in sensors and sid not in device_of:
            room = slug(sensors[sid][0])
            counts[room] = counts.get(room, 0) + 1
    return max(sorted(counts), key=lambda r: counts[r]) if counts else "unknown"


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
    """Write ``<name>.yaml`` and ``<name>-events.csv`` for a subject's folder; returns the paths
    and the number of events."""
    sensors = read_sensors(folder / "sensors.csv")
    activities = sorted(read_activities(folder / "activities_data.csv"), key=lambda a: a.start)
    name = name or f"mit_{slug(folder.name)}"
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
    rooms = sorted({slug(r) for r, _ in sensors.values()})
    on_intervals: dict[str, list[tuple[datetime, datetime]]] = {d: [] for d in devices}
    for a in activities:
        for sid, on, off in a.firings:
            if sid in device_of:
                on_intervals[device_of[sid]].append((on, off))

    def state(device: str, t: datetime) -> bool:
        return any(on <= t < off for on, off in on_intervals[device])

    lux = illumination([a.start for a in activities])
    rows = []
    for a, light in zip(activities, lux, strict=True):
        behavior = behavior_of(a.name)
        location = "out" if behavior == "out" else location_of(a, sensors, device_of)
        # what the subject wanted at the start: a device switched on during the activity that was
        # off, or one that was on and is off by its end
        wanted = []
        for device in devices:
            before = state(device, a.start)
            switched_on = any(a.start <= on <= a.end for on, _ in on_intervals[device])
            if not before and switched_on:
                wanted.append(f"TurnOn{camel(device)}")
            elif before and not state(device, a.end):
                wanted.append(f"TurnOff{camel(device)}")
        rows.append(
            {
                "timestamp": a.start.isoformat(),
                "time": a.start.strftime("%H:%M"),
                "illumination": f"{light:g}",
                "location": location,
                "behavior": behavior,
                **{d: "on" if state(d, a.start) else "off" for d in devices},
                "services": ";".join(wanted),
            }
        )

    out.mkdir(parents=True, exist_ok=True)
    locations = [*rooms, "out", "unknown"]
    behaviors = list(BEHAVIOR)
    home_path = out / f"{name}.yaml"
    home_path.write_text(_home_yaml(name, folder, locations, behaviors, devices), encoding="utf-8")
    events_path = out / f"{name}-events.csv"
    columns = ["timestamp", "time", "illumination", "location", "behavior", *devices, "services"]
    with events_path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    return home_path, events_path, len(rows)


def _home_yaml(
    name: str, folder: Path, locations: list[str], behaviors: list[str], devices: dict[str, tuple[str, str]]
) -> str:
    lines = [
        f"# Made by `homecog adapt-mit` from {folder.name} of the MIT home-activity data",
        "# (Munguia Tapia, Intille, Larson, Pervasive 2004). Illumination: pvlib clear-sky at "
        f"{PLACE['name']}.",
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
        f"  behavior: {{kind: categorical, values: [{', '.join(behaviors)}]}}",
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
    return "\n".join(lines) + "\n"
