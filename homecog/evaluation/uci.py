"""Real data: the UCI occupancy-detection office (Candanedo and Feldheim, 2016) as a home, a log
and events.

The data set is one office room over two weeks of February 2015, one row a minute in three
files (``datatest.txt``, ``datatraining.txt``, ``datatest2.txt``: CSV, the header
``date,Temperature,Humidity,Light,CO2,HumidityRatio,Occupancy`` and a row number first). It has
no switch log, but its illuminance tells when the ceiling light was switched: an office light
switched on lifts the reading by hundreds of lux within a minute or two, where daylight drifts.
So:

- the light is switched **on** where the reading rises by at least :data:`STEP` lx within
  :data:`WINDOW` minutes to at least :data:`ON_LUX`, and **off** where it falls by at least
  :data:`STEP` lx within them to under :data:`OFF_LUX` (a gap in the data is never a switch);
- the occupancy column (0/1) is the state of the entity ``occupancy``, written where it changes;
- the home: the time of day and ``occupancy`` (``present``, ``absent``), the ``ceiling_light``
  with ``TurnOnCeilingLight`` and ``TurnOffCeilingLight``, a comfort rule written without
  looking at the events (the light on while someone is there, off when nobody is), and a
  ``log:`` section mapping the two entities;
- the event file, made from the log by ``homecog log events``: a switch row per switch, with
  the context just before it, and a quiet row where the occupancy changed with no switch
  within 10 minutes (someone came or went and left the light as it was).

>>> step_switches([(0, 5.0), (1, 420.0), (2, 433.0), (3, 0.0)])
[(1, True), (3, False)]
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from homecog.errors import RealDataError
from homecog.evaluation.log_events import LogEvents, convert_log
from homecog.evaluation.log_writer import ACTIVITY, DEVICE, FIRST, YEARS, LogWriter, check_span, home_name
from homecog.home import load_home
from homecog.text_files import check_file

FILES = ("datatest.txt", "datatraining.txt", "datatest2.txt")
COLUMNS = ("date", "Light", "Occupancy")
#: lux a switch moves the reading by, at least, within WINDOW minutes
STEP = 200.0
WINDOW = 3
#: a light switched on reads at least ON_LUX after; one switched off under OFF_LUX
ON_LUX, OFF_LUX = 300.0, 150.0
QUIET = 10  # minutes
#: a row: its time (or minute number), the illuminance
Reading = tuple[object, float]


@dataclass
class Office:
    """What was written for the office."""

    home: Path
    log: Path
    events: Path
    minutes: int  # rows of the data read
    switches: int  # switches of the light found in them
    result: LogEvents


def step_switches(readings: list[Reading], window: float = WINDOW) -> list[tuple[int, bool]]:
    """Where the light was switched (the row's index, on or off): a step of :data:`STEP` lx
    within ``window`` minutes of rows (times, or minute numbers) to above :data:`ON_LUX` or
    under :data:`OFF_LUX`. The light starts as its first reading says."""
    out: list[tuple[int, bool]] = []
    on = bool(readings) and readings[0][1] >= ON_LUX
    start = 0
    for i, (at, lux) in enumerate(readings):
        while _minutes(readings[start][0], at) > window:
            start += 1
        recent = [value for _, value in readings[start : i + 1]]
        if not on and lux >= ON_LUX and lux - min(recent) >= STEP:
            on = True
            out.append((i, True))
        elif on and lux < OFF_LUX and max(recent) - lux >= STEP:
            on = False
            out.append((i, False))
    return out


def _minutes(a: object, b: object) -> float:
    if isinstance(a, datetime) and isinstance(b, datetime):
        return (b - a).total_seconds() / 60
    return float(b) - float(a)  # type: ignore[arg-type]


def read_rows(folder: Path) -> list[tuple[datetime, float, str]]:
    """Every row of the three files: time, illuminance, occupancy (``0``/``1``), in time order,
    a time read twice kept once."""
    rows: dict[datetime, tuple[float, str]] = {}
    for name in FILES:
        path = folder / name
        check_file(path, what="a data set's file", error=RealDataError)
        try:
            text = path.read_text(encoding="utf-8", errors="replace")
        except OSError as e:
            raise RealDataError(f"{path}: cannot read: {e.strerror}") from None
        lines = list(csv.reader(text.splitlines()))
        if not lines or not all(c in lines[0] for c in COLUMNS):
            raise RealDataError(f"{path}: line 1: expected the columns {', '.join(COLUMNS)}")
        header = lines[0]
        for n, cells in enumerate(lines[1:], start=2):
            if not cells:
                continue
            cells = cells[len(cells) - len(header) :] if len(cells) > len(header) else cells
            rows.setdefault(*_row(dict(zip(header, cells, strict=False)), path, n))
    if not rows:
        raise RealDataError(f"{folder}: no rows in {', '.join(FILES)}")
    return [(at, lux, occupied) for at, (lux, occupied) in sorted(rows.items())]


def _row(cells: dict[str, str], path: Path, line: int) -> tuple[datetime, tuple[float, str]]:
    try:
        at = datetime.fromisoformat(cells["date"].strip())
        lux = float(cells["Light"])
        occupied = cells["Occupancy"].strip()
        if at.year not in YEARS or not 0 <= lux < 1e6 or occupied not in ("0", "1"):
            raise ValueError
    except (KeyError, ValueError):
        raise RealDataError(
            f"{path}: line {line}: expected a time, an illuminance (lx) and an occupancy of 0 or 1"
        ) from None
    return at, (lux, occupied)


def convert(folder: Path, out: Path, name: str | None = None) -> Office:
    """Write ``<name>.yaml``, ``<name>-log.csv`` and ``<name>-events.csv`` for the office."""
    name = home_name(name, "uci_office")
    rows = read_rows(folder)
    first, last = rows[0][0], rows[-1][0]
    check_span(first, last, folder / FILES[0])
    switches = step_switches([(at, lux) for at, lux, _ in rows])
    log = LogWriter(first, last)
    log.add(first, "ceiling_light", "on" if rows[0][1] >= ON_LUX else "off", FIRST)
    for i, on in switches:
        log.add(rows[i][0], "ceiling_light", "on" if on else "off", DEVICE)
    previous = None
    for at, _, occupied in rows:
        if occupied != previous:
            log.add(at, "occupancy", occupied, ACTIVITY)
            previous = occupied
    out.mkdir(parents=True, exist_ok=True)
    home_path, log_path, events_path = (out / f"{name}{end}" for end in (".yaml", "-log.csv", "-events.csv"))
    home_path.write_text(home_yaml(name), encoding="utf-8")
    log.write(log_path)
    result = convert_log(load_home(home_path), log_path, events_path)
    return Office(home_path, log_path, events_path, len(rows), len(switches), result)


def home_yaml(name: str) -> str:
    """The office's home file (see the module docstring)."""
    return f"""# Made from the UCI occupancy-detection office (Candanedo and Feldheim, Energy and Buildings
# 2016): the light's switches found in its illuminance, its occupancy as a context feature.
name: {name}
context:
  time:
    kind: clock
    bins: {{night: [22, 6], morning: [6, 10], day: [10, 17], evening: [17, 22]}}
  occupancy: {{kind: categorical, values: [present, absent]}}
devices:
  ceiling_light: {{room: office, iot: true}}
services:
  TurnOnCeilingLight: {{category: switch_on, set: {{ceiling_light: on}}}}
  TurnOffCeilingLight: {{category: switch_off, set: {{ceiling_light: off}}}}
comfort:
  ceiling_light:
    - {{when: {{occupancy: [absent]}}, want: off}}
    - {{when: {{occupancy: [present]}}, want: on}}
log:
  quiet: {QUIET}
  devices:
    ceiling_light: {{entity: ceiling_light}}
  features:
    occupancy:
      entity: occupancy
      values: {{"1": present, "0": absent}}
"""
