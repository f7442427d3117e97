"""``homecog log events``: a home's log of state changes as an event file.

The log is a CSV with the header ``timestamp,entity,state`` (and optionally ``user``): one row
per state an entity took, the timestamp in ISO 8601. The home's ``log:`` section
(:mod:`homecog.home.log_section`) says which entities are its features and devices; the
conversion core (:mod:`~homecog.evaluation.event_stream`) makes a switch row per switch of a
device, with the context just before it and the service that makes it, and a quiet row where a
feature changes with no switch within ``quiet`` minutes. A clock feature without an entity is
the timestamp's own local time.

Logs are noisy, and what does not fit is counted, by reason, and skipped: an entity the section
does not map (``unknown_entity``), a row that repeats another exactly (``duplicate``), a state
that is no word of its entity (``unmapped_state``), a number or time outside the feature's bins
or not one at all (``out_of_range``), a switch no service makes (``no_service``), a row before
every feature and device has a value (``incomplete``), a switch by a user left out
(``excluded_user``). Rows out of time order are sorted (stably) and counted. What cannot be read
at all — a missing column, a bad timestamp, a file that is not UTF-8 text — is one error naming
the file and the line.

>>> import tempfile
>>> from homecog.home import load_home
>>> home = load_home("tests/homes/studio_log.yaml")
>>> with tempfile.TemporaryDirectory() as folder:
...     log = Path(folder) / "log.csv"
...     _ = log.write_text("timestamp,entity,state\\n2024-03-01T07:00,sensor.lux,50\\n"
...         "2024-03-01T07:00,activity,Working\\n2024-03-01T07:00,x10.blind,closed\\n"
...         "2024-03-01T07:00,x10.lamp,off\\n2024-03-01T07:00,x10.radio,off\\n"
...         "2024-03-01T07:02,x10.lamp,on\\n2024-03-01T07:03,pir_desk,on\\n"
...         "2024-03-01T07:04,sensor.co2,410\\n")
...     result = convert_log(home, log, Path(folder) / "events.csv")
...     text = (Path(folder) / "events.csv").read_text()
>>> print(text.splitlines()[1])
2024-03-01T07:02:00,07:02,50,work,unknown,off,off,off,LampOn
>>> result.switches, result.quiet, result.near_switch, result.skipped["unknown_entity"]
(1, 0, 1, 1)
"""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from datetime import datetime
from functools import partial
from pathlib import Path
from typing import Any

from homecog.errors import ContextError, LogFileError
from homecog.evaluation.event_stream import EventStream, LogRow, Presence, Reader, Skip
from homecog.home.home_assistant import FeatureEntity
from homecog.home.home_assistant import feature_value as entity_value
from homecog.home.log_section import LogDevice, LogFeature, LogMap
from homecog.home.model import Feature, Home
from homecog.text_files import ROWS_FILE_LIMIT, check_header_unique, check_zone, read_text, timestamp_cell

COLUMNS = ("timestamp", "entity", "state")
REASONS = (
    "unknown_entity",
    "duplicate",
    "unmapped_state",
    "out_of_range",
    "no_service",
    "incomplete",
    "excluded_user",
)


@dataclass
class LogEvents:
    """What ``log events`` wrote and what it left out, and why."""

    path: Path
    log_rows: int
    switches: int
    quiet: int
    devices: dict[str, int]
    skipped: dict[str, int]
    reordered: int  # rows that came after a later one, sorted into place
    near_switch: int  # feature changes with a switch within the quiet minutes: no row
    unknown_entities: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def rows(self) -> int:
        return self.switches + self.quiet

    def as_dict(self) -> dict[str, Any]:
        return {
            "out": str(self.path),
            "log_rows": self.log_rows,
            "rows": self.rows,
            "switches": self.switches,
            "quiet": self.quiet,
            "devices": self.devices,
            "skipped": self.skipped,
            "reordered": self.reordered,
            "near_switch": self.near_switch,
            "unknown_entities": self.unknown_entities,
            "seconds": round(self.seconds, 3),
        }


def convert_log(
    home: Home,
    log: Path,
    out: Path,
    *,
    quiet: float | None = None,
    exclude_users: Iterable[str] = (),
) -> LogEvents:
    """Write the event file of a log; ``quiet`` minutes (default: the section's)."""
    begin = time.perf_counter()
    mapping = home.log
    if mapping is None:
        raise LogFileError(
            f"{home.source}: no log section; it maps a log's entities to the home's features and devices"
        )
    rows, duplicates, reordered = read_log(log)
    readers, presence = readers_of(home, mapping)
    stream = EventStream(
        home, readers, presence, quiet=mapping.quiet if quiet is None else quiet, reasons=REASONS
    )
    stream.count("duplicate", duplicates)
    unknown: dict[str, int] = {}
    excluded = set(exclude_users)
    for row in rows:
        if row.entity not in readers:
            unknown[row.entity] = unknown.get(row.entity, 0) + 1
            continue
        if row.user is not None and row.user in excluded:
            row = replace(row, skip="excluded_user")
        stream.feed(row)
    stream.count("unknown_entity", sum(unknown.values()))
    stream.write(out)
    return LogEvents(
        path=out,
        log_rows=len(rows) + duplicates,
        switches=sum(stream.switches.values()),
        quiet=stream.quiet_rows,
        devices={d: n for d, n in stream.switches.items() if n},
        skipped=dict(stream.skipped),
        reordered=reordered,
        near_switch=stream.near_switch,
        unknown_entities=dict(sorted(unknown.items(), key=lambda kv: (-kv[1], kv[0]))),
        seconds=time.perf_counter() - begin,
    )


# -- the log file --------------------------------------------------------------------------------
def read_log(path: Path) -> tuple[list[LogRow], int, int]:
    """The rows of a log in time order, the number of exact duplicates left out and the number
    of rows that were out of order; :class:`LogFileError` naming the file and line."""
    reader = csv.reader(io.StringIO(_text(path), newline=""))
    try:
        return _read_rows(path, reader)
    except csv.Error as e:  # a quoted cell that never ends, or one over the field limit
        raise LogFileError(f"{path}: line {reader.line_num}: not CSV: {e}") from None


def _read_rows(path: Path, reader: Any) -> tuple[list[LogRow], int, int]:
    """:func:`read_log`'s work, from the header on."""
    header = [c.strip() for c in next(reader, [])]
    where = _columns(path, header)
    rows: list[LogRow] = []
    seen: set[tuple[datetime, str, str, str | None]] = set()
    duplicates = reordered = 0
    latest: datetime | None = None
    zoned: tuple[bool, int] | None = None  # whether the first timestamp had a zone, its line
    for cells in reader:
        if not any(c.strip() for c in cells):
            continue
        row = _row(path, reader.line_num, cells, where, len(header))
        zoned = zoned or (row.at.tzinfo is not None, reader.line_num)
        check_zone(path, reader.line_num, row.at, zoned, LogFileError)
        key = (row.at, row.entity, row.state, row.user)
        if key in seen:
            duplicates += 1
            continue
        seen.add(key)
        if latest is not None and row.at < latest:
            reordered += 1
        else:
            latest = row.at
        rows.append(row)
    if not rows:
        raise LogFileError(f"{path}: no rows after the header")
    if reordered:
        rows.sort(key=lambda r: r.at)  # stable: rows at one time keep their order
    return rows, duplicates, reordered


def _columns(path: Path, header: list[str]) -> dict[str, int]:
    """Where each column of a log's header is; :class:`LogFileError` for a missing or unknown one."""
    if not header:
        raise LogFileError(f"{path}: empty file; expected the header {','.join(COLUMNS)}[,user]")
    check_header_unique(header, path, LogFileError)
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise LogFileError(f"{path}: line 1: missing column(s) {', '.join(missing)}")
    unknown = [c for c in header if c not in (*COLUMNS, "user")]
    if unknown:
        raise LogFileError(f"{path}: line 1: unknown column(s) {', '.join(unknown)}")
    return {c: header.index(c) for c in header}


def _row(path: Path, line: int, cells: list[str], where: dict[str, int], width: int) -> LogRow:
    """One line of a log (``width`` fields) as a row."""
    if len(cells) != width:
        raise LogFileError(f"{path}: line {line}: expected {width} fields, got {len(cells)}")
    at = timestamp_cell(cells[where["timestamp"]].strip(), path, line, LogFileError)
    user = (cells[where["user"]].strip() or None) if "user" in where else None
    return LogRow(at, cells[where["entity"]].strip(), cells[where["state"]].strip(), user)


def _text(path: Path) -> str:
    return read_text(path, limit=ROWS_FILE_LIMIT, what="a log file", error=LogFileError)


# -- how states read -------------------------------------------------------------------------------
def readers_of(home: Home, mapping: LogMap) -> tuple[dict[str, list[Reader]], list[Presence]]:
    """Per entity, how its states read; and the presence features."""
    out: dict[str, list[Reader]] = {}
    for f in mapping.features:
        out.setdefault(f.entity, []).append(
            Reader(f.feature, "feature", partial(feature_value, home.feature(f.feature), f))
        )
    for d in mapping.devices:
        out.setdefault(d.entity, []).append(Reader(d.device, "device", partial(device_state, d)))
    presence = []
    for p in mapping.presence:
        values = home.feature(p.feature).values
        presence.append(
            Presence(p.feature, dict(p.rooms), p.hold, "unknown" if "unknown" in values else None, p.several)
        )
        for entity, _ in p.rooms:
            words = LogDevice(p.feature, entity, p.on, p.off)
            out.setdefault(entity, []).append(Reader(p.feature, "presence", partial(device_state, words)))
    return out, presence


def device_state(mapping: LogDevice, row: LogRow) -> bool:
    """Whether a state reads as on; :class:`Skip` (``unmapped_state``) when it is neither word.

    >>> device_state(LogDevice("lamp", "x10.a1", ("on", "1"), ("off", "0")), LogRow(None, "x10.a1", "1"))
    True
    """
    if row.state in mapping.on:
        return True
    if row.state in mapping.off:
        return False
    raise Skip("unmapped_state")


def feature_value(feature: Feature, mapping: LogFeature, row: LogRow) -> str:
    """A state as the feature's value, written as in an event file; :class:`Skip` when it is no
    word of a categorical feature (``unmapped_state``) or outside every bin (``out_of_range``).

    >>> from homecog.home import load_home
    >>> home = load_home("tests/homes/studio_log.yaml")
    >>> light = home.log.features[0]
    >>> feature_value(home.feature("light"), light, LogRow(None, "sensor.lux", "150.0"))
    '150'
    """
    text = row.state
    if feature.kind == "categorical":
        value = dict(mapping.values).get(text, text)
        if value not in feature.values:
            raise Skip("unmapped_state")
        return value
    try:  # a reading as Home Assistant's states are read
        return entity_value(feature, FeatureEntity(mapping.feature, mapping.entity), text)
    except ContextError:
        raise Skip("out_of_range") from None
