"""Real data: van Kasteren's three houses (UbiComp 2008; 2011) as a home, a log and events.

A house's files in the folder — ``houseX-ss.txt`` (sensor firings ``start<TAB>end<TAB>id``),
``houseX-as.txt`` (activities ``start<TAB>end<TAB>id``), ``sensorMapX-ids.txt``
(``id,name,place``) and ``actionMapX.txt`` (``id,activity``) — become

- a home file: the time of day, where the person is (``location``) and what they do
  (``behavior``); the appliances a robot could switch as devices — microwave (``magnetron`` in
  house B), toaster, dishwasher, washing machine, as far as the house has them — with a
  ``TurnOnX`` and a ``TurnOffX`` service each; common-sense comfort rules written without looking
  at the events (the microwave for preparing a meal in the kitchen, the toaster for breakfast,
  the dishwasher at night while the person sleeps, the washing machine in the day and never
  while they are out or asleep); and a ``log:`` section mapping the log's entities;
- a log (``timestamp,entity,state``) over the labelled days, from the first activity's start to
  the last one's end (firings outside them are left out and counted): every sensor an entity
  named ``<name>_<id>`` from the sensor map (an id the map lacks: ``sensor_<id>``, which the
  section does not map, so ``log events`` counts its rows as unknown), ``on`` when it starts
  firing and ``off`` when it stops (firings of one sensor that overlap or touch made one); the
  activities the states of the entity ``activity`` (the label of the activity under way that
  started last, ``idle`` between activities); each device's state at the log's start first;
- the event file, made from the log by ``homecog log events``, whose columns are made from:

  - ``timestamp``, ``time``: the switch's time (a quiet row's: the change's), the clock as
    the data give it (local time in the Netherlands);
  - ``location``: the place (the sensor map's third column: Kitchen, KitchHeat and KitchStor are
    ``kitchen``, Toilet ``toilet``, Bathroom and BathroomDoor ``bathroom``, Sleep and SleepDoor
    ``bedroom``, Outside the ``entrance``, Other the ``living`` room) of the sensor that is not
    a device and started firing last among those that started or stopped less than 30 minutes
    ago; ``unknown`` when none did. Doors, cupboards, the fridge and freezer, the flush, pressure mats
    and motion sensors say where the person is; the devices never do;
  - ``behavior``: the activity under way: leave-house → ``out``, use-toilet → ``toilet``,
    take-shower → ``shower``, brush-teeth → ``brush_teeth``, go-to-bed → ``sleep``,
    prep-breakfast → ``breakfast``, prep-dinner → ``dinner``, get-drink → ``drink``, none → ``idle``;
  - one column per device: on while its sensor fires (the sensor is on the appliance's door or
    switch: on means the person is using it), the switching one as it was just before;
  - ``services``: ``TurnOnX`` when the device's sensor starts firing, ``TurnOffX`` when it stops;
    empty on a quiet row (a change of location or behavior with no switch within 10 minutes).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from homecog.errors import RealDataError
from homecog.evaluation.log_events import LogEvents, convert_log
from homecog.evaluation.log_writer import (
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

HOUSES = ("A", "B", "C")
MONTHS = {
    m: i
    for i, m in enumerate(
        ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"), start=1
    )
}
# the appliances a robot could switch, by a word of the sensor's name
APPLIANCES = {
    "microwave": "microwave",
    "magnetron": "microwave",
    "toaster": "toaster",
    "dishwasher": "dishwasher",
    "washing machine": "washing_machine",
}
PLACES = {
    "Kitchen": "kitchen",
    "KitchHeat": "kitchen",
    "KitchStor": "kitchen",
    "Toilet": "toilet",
    "Bathroom": "bathroom",
    "BathroomDoor": "bathroom",
    "Sleep": "bedroom",
    "SleepDoor": "bedroom",
    "Outside": "entrance",
    "Other": "living",
}
BEHAVIOR = {
    "leave-house": "out",
    "use-toilet": "toilet",
    "take-shower": "shower",
    "brush-teeth": "brush_teeth",
    "go-to-bed": "sleep",
    "prep-breakfast": "breakfast",
    "prep-dinner": "dinner",
    "get-drink": "drink",
    "idle": "idle",
}
COMFORT = {
    "microwave": [
        "{when: {behavior: [out, sleep]}, want: off}",
        "{when: {behavior: [breakfast, dinner], location: [kitchen]}, want: on}",
        "{want: off}",
    ],
    "toaster": ["{when: {behavior: [breakfast], location: [kitchen]}, want: on}", "{want: off}"],
    "dishwasher": ["{when: {time: [night], behavior: [sleep]}, want: on}", "{want: off}"],
    "washing_machine": [
        "{when: {behavior: [out, sleep]}, want: off}",
        "{when: {time: [morning, day]}, want: on}",
    ],
}
HOLD, QUIET = 30, 10  # minutes


@dataclass(frozen=True)
class Sensor:
    """A line of the sensor map, as the log and the home name it."""

    id: str
    name: str
    room: str
    device: str | None  # the appliance it is, if it is one

    @property
    def entity(self) -> str:
        return f"{slug(self.name)}_{self.id}"


def parse_time(text: str, path: Path, line: int) -> datetime:
    """``25-Feb-2008 00:20:14`` (month names in English whatever the locale).

    >>> parse_time("25-Feb-2008 09:33:41", Path("houseA-ss.txt"), 2)
    datetime.datetime(2008, 2, 25, 9, 33, 41)
    """
    try:
        day, month, rest = text.strip().split("-")
        year, clock = rest.split(" ")
        hour, minute, second = small_numbers(clock, ":", (2, 2, 2))
        (mday,), (number,) = small_numbers(day, "-", (2,)), small_numbers(year, "-", (4,))
        if number not in YEARS:
            raise ValueError(year)
        return datetime(number, MONTHS[month], mday, hour, minute, second)
    except (ValueError, KeyError):
        raise RealDataError(
            f"{path}: line {line}: {quoted(text.strip())} is not a time DD-Mon-YYYY HH:MM:SS of the "
            f"years {YEARS[0]} to {YEARS[-1]}"
        ) from None


def _lines(path: Path) -> list[tuple[int, str]]:
    check_file(path, what="a data set's file", error=RealDataError)  # a regular file, bounded
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
    return [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=1) if line.strip()]


def read_map(path: Path, fields: int) -> list[tuple[int, list[str]]]:
    """The comma-separated lines of a map file: the first field, the last ones, the rest between."""
    out = []
    for n, line in _lines(path):
        parts = [p.strip() for p in line.split(",")]
        if len(parts) < fields or not all(parts):
            raise RealDataError(f"{path}: line {n}: expected {fields} comma-separated fields")
        out.append(
            (n, [parts[0], ",".join(parts[1 : len(parts) - fields + 2]), *parts[len(parts) - fields + 2 :]])
        )
    return out


def read_sensors(path: Path) -> dict[str, Sensor]:
    """Sensor id → its name, room and appliance."""
    out = {}
    for _, (sid, name, place) in read_map(path, 3):
        device = next((d for word, d in APPLIANCES.items() if word in name.lower()), None)
        out[sid] = Sensor(sid, name, PLACES.get(place, slug(place)), device)
    return out


def read_intervals(path: Path) -> list[tuple[datetime, datetime, str]]:
    """``start<TAB>end<TAB>id`` lines; an end before its start is an error naming the line."""
    out = []
    for n, line in _lines(path):
        parts = [p.strip() for p in line.split("\t") if p.strip()]
        if len(parts) != 3:
            raise RealDataError(f"{path}: line {n}: expected START<TAB>END<TAB>ID")
        start, end = parse_time(parts[0], path, n), parse_time(parts[1], path, n)
        if end < start:
            raise RealDataError(f"{path}: line {n}: ends before it starts")
        out.append((start, end, parts[2]))
    if not out:
        raise RealDataError(f"{path}: no lines")
    return out


@dataclass
class House:
    """What was written for a house."""

    home: Path
    log: Path
    events: Path
    log_rows: int
    left_out: int  # firings' starts and ends outside the labelled days
    result: LogEvents


def convert(folder: Path, house: str, out: Path, name: str | None = None) -> House:
    """Write ``<name>.yaml``, ``<name>-log.csv`` and ``<name>-events.csv`` for a house."""
    house = house.strip().upper()
    if house not in HOUSES:
        raise RealDataError(f"house {house!r}: expected one of {', '.join(HOUSES)}")
    name = home_name(name, f"kasteren_{house.lower()}")

    def path(stem: str) -> Path:
        return folder / f"{stem}.txt"

    sensors = read_sensors(path(f"sensorMap{house}-ids"))
    labels = {aid: label for _, (aid, label) in read_map(path(f"actionMap{house}"), 2)}
    activities = [(s, e, labels.get(a, a)) for s, e, a in read_intervals(path(f"house{house}-as"))]
    firings = read_intervals(path(f"house{house}-ss"))
    devices = {s.device: s for s in sensors.values() if s.device}
    if not devices:
        raise RealDataError(f"{path(f'sensorMap{house}-ids')}: no appliance among the sensors")
    first, last = min(s for s, _, _ in activities), max(e for _, e, _ in activities)
    check_span(first, last, path(f"house{house}-as"))
    log = LogWriter(first, last)
    log.activities("activity", activities)
    per_sensor: dict[str, list[tuple[datetime, datetime]]] = {}
    for start, end, sid in firings:
        per_sensor.setdefault(sid, []).append((start, end))
    for sid, intervals in per_sensor.items():
        sensor = sensors.get(sid)
        entity = sensor.entity if sensor else f"sensor_{sid}"
        log.firings(entity, intervals, DEVICE if sensor and sensor.device else PRESENCE)
    out.mkdir(parents=True, exist_ok=True)
    home_path, log_path, events_path = (out / f"{name}{end}" for end in (".yaml", "-log.csv", "-events.csv"))
    home_path.write_text(home_yaml(name, house, sensors, labels), encoding="utf-8")
    rows = log.write(log_path)
    result = convert_log(load_home(home_path), log_path, events_path)
    return House(home_path, log_path, events_path, rows, log.left_out, result)


def home_yaml(name: str, house: str, sensors: dict[str, Sensor], labels: dict[str, str]) -> str:
    """The home file of a house (see the module docstring)."""
    devices = {s.device: s for s in sensors.values() if s.device}
    presence = [s for s in sensors.values() if not s.device]
    rooms = list(dict.fromkeys(s.room for s in presence))
    words = {label: BEHAVIOR.get(label, "idle") for label in [*labels.values(), "idle"]}
    lines = [
        f"# Made by `homecog adapt-kasteren` from house {house} of van Kasteren's data",
        "# (van Kasteren, Noulas, Englebienne, Kröse, UbiComp 2008). Its log: the sensor firings and",
        "# the labelled activities; its events: `homecog log events` of that log.",
        f"name: {name}",
        "context:",
        "  time:",
        "    kind: clock",
        "    bins: {night: [22, 6], morning: [6, 10], day: [10, 17], evening: [17, 22]}",
        f"  location: {{kind: categorical, values: [{', '.join([*rooms, 'unknown'])}]}}",
        f"  behavior: {{kind: categorical, values: [{', '.join(dict.fromkeys(BEHAVIOR.values()))}]}}",
        "devices:",
        *(f"  {d}: {{room: {s.room}, iot: true}}" for d, s in devices.items()),
        "services:",
    ]
    for d in devices:
        lines.append(f"  TurnOn{camel(d)}: {{category: switch_on, set: {{{d}: on}}}}")
        lines.append(f"  TurnOff{camel(d)}: {{category: switch_off, set: {{{d}: off}}}}")
    lines.append("comfort:")
    for d in devices:
        lines += [f"  {d}:", *(f"    - {rule}" for rule in COMFORT[d])]
    lines += ["log:", f"  quiet: {QUIET}", "  devices:"]
    lines += [f"    {d}: {{entity: {s.entity}}}" for d, s in devices.items()]
    lines += ["  features:", "    behavior:", "      entity: activity", "      values:"]
    lines += [f'        "{label}": {value}' for label, value in words.items()]
    lines += ["    location:", f"      hold: {HOLD}", "      presence:"]
    lines += [f"        {s.entity}: {s.room}  # {s.name}" for s in presence]
    return "\n".join(lines) + "\n"
