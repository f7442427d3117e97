"""``homecog ha history``: a household's own switches, read from a Home Assistant recorder, as an
event file (SPEC §9, §12) that ``homecog replay`` evaluates on and the robot learns from.

The recorder keeps every state of every entity (``states`` joined with ``states_meta``) with the
context that made it: ``context_user_id_bin``, the user whose call it was, and
``context_parent_id_bin``, set when the change follows from another one (an automation or a
script reacting to a trigger). A row of the event file is one switch of a mapped device, on to
off or off to on, *made by a person*:

- not by an automation: the change has no parent context;
- not by homecog itself: the change's user is not the robot's (the user of its token, asked over
  the WebSocket API when ``home_assistant_url`` is given);
- a change within a running instance (the row has an ``old_state_id``, and the entity's state
  before it was readable): what an instance restores when it starts is nobody's switch.

A switch without a user is a person's too: a wall switch or a device's own button reports the
new state with no user behind it. The row gives the context as it was just before the switch —
every feature's last readable state (a clock feature without an entity: the local time), every
device's state — and, as ``services``, the home's service that makes that switch.

The recorder is read with SQLAlchemy: a SQLite file (read-only) or a MariaDB/PostgreSQL URL.
Schemas 38 and later have what is needed (tested with 42, Home Assistant 2024.3); another is
refused with one line saying which.
"""

from __future__ import annotations

import csv
import json
import logging
import time
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

from homecog.errors import ContextError, HomeAssistantError
from homecog.home.clock import format_clock
from homecog.home.home_assistant import NO_READING, DeviceEntity, FeatureEntity, feature_value, nearest
from homecog.home.model import Home

log = logging.getLogger(__name__)

MIN_SCHEMA = 38  # states_meta and the binary context columns: Home Assistant 2023.4 and later
TESTED_SCHEMA = 42  # Home Assistant 2024.3
NEEDED = {
    "states": ("state", "last_updated_ts", "old_state_id", "metadata_id", "attributes_id",
               "context_user_id_bin", "context_parent_id_bin"),
    "states_meta": ("metadata_id", "entity_id"),
}  # fmt: skip


@dataclass
class HistoryResult:
    """What ``ha history`` wrote and what it left out, and why."""

    path: Path
    events: int
    devices: dict[str, int]
    skipped: dict[str, int]
    schema: int
    seconds: float
    unrecorded: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "events": self.events,
            "devices": self.devices,
            "skipped": self.skipped,
            "schema": self.schema,
            "seconds": round(self.seconds, 3),
            "out": str(self.path),
            "unrecorded": self.unrecorded,
        }


def recorder_url(recorder: str) -> str:
    """A SQLAlchemy URL for a recorder given as a SQLite file path or a URL.

    >>> recorder_url("mysql+pymysql://ha:secret@db/homeassistant")
    'mysql+pymysql://ha:secret@db/homeassistant'
    >>> recorder_url("/no/such/home-assistant_v2.db")
    Traceback (most recent call last):
    ...
    homecog.errors.HomeAssistantError: recorder /no/such/home-assistant_v2.db: no such file
    """
    if "://" in recorder:
        return recorder
    path = Path(recorder)
    if not path.is_file():
        raise HomeAssistantError(f"recorder {recorder}: {'is a folder' if path.is_dir() else 'no such file'}")
    return f"sqlite:///file:{path.resolve()}?mode=ro&uri=true"  # read-only: Home Assistant may be writing


def service_for(home: Home, device: str, on: bool) -> str | None:
    """The service that makes a switch: the one that sets only that device to that state, else
    the one that sets it with the fewest other devices (the first in the home's order).

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> service_for(home, "ceiling_light", True), service_for(home, "window", False)
    ('TurnOnLight', 'CloseWindow')
    """
    setters = [s for s in home.services if (device, on) in s.sets]
    return min(setters, key=lambda s: len(s.sets)).name if setters else None


def _parse_time(text: str | None, option: str) -> float | None:
    if text is None:
        return None
    try:
        moment = datetime.fromisoformat(text.strip())
    except ValueError:
        raise HomeAssistantError(
            f"{option} {text!r}: expected an ISO 8601 date or time, e.g. 2024-03-01T07:00"
        ) from None
    return moment.astimezone().timestamp()  # a time without a zone is local


def read_history(
    home: Home,
    recorder: str,
    out: Path,
    *,
    exclude_users: tuple[str, ...] = (),
    since: str | None = None,
    until: str | None = None,
) -> HistoryResult:
    """Write the event file of a home's recorded switches by people; see the module docstring."""
    from sqlalchemy import create_engine, text
    from sqlalchemy.exc import SQLAlchemyError

    begin = time.perf_counter()
    mapping = home.home_assistant
    if mapping is None:
        raise HomeAssistantError(
            f"{home.source}: no home_assistant section (SPEC §12); see homecog ha scaffold"
        )
    start, end = _parse_time(since, "--since"), _parse_time(until, "--until")
    url = recorder_url(recorder)
    shown = recorder if "://" not in recorder else recorder.split("@")[-1]
    engine = create_engine(url)
    try:
        with engine.connect() as db:
            schema = _check_schema(db, shown)
            metas = dict(db.execute(text("SELECT entity_id, metadata_id FROM states_meta")).all())
            rows = _rows(db, [metas[e] for e in mapping.entities if e in metas], start, end, text)
    except SQLAlchemyError as e:
        first = (str(getattr(e, "orig", None) or e).strip().splitlines() or [type(e).__name__])[0]
        raise HomeAssistantError(f"recorder {shown}: cannot be read: {first}") from None
    finally:
        engine.dispose()
    unrecorded = [
        f"{e} was never recorded" + (f"; nearest: {', '.join(n)}" if (n := nearest(e, sorted(metas))) else "")
        for e in mapping.entities
        if e not in metas
    ]
    robots = {bytes.fromhex(u) for u in exclude_users}
    readers: dict[str, list[FeatureEntity | DeviceEntity]] = {}
    for m in (*mapping.features, *mapping.devices):
        readers.setdefault(m.entity, []).append(m)
    clocks = [
        f.name
        for f in home.features
        if f.kind == "clock" and f.name not in {m.feature for m in mapping.features}
    ]
    values: dict[str, str] = {}
    states: dict[str, bool] = {}
    readable: dict[str, bool] = {}  # entity -> whether its last state could be read
    counts = dict.fromkeys(home.device_names, 0)
    skipped = dict.fromkeys(("by_automation", "by_homecog", "unreadable", "incomplete", "no_service"), 0)
    out.parent.mkdir(parents=True, exist_ok=True)
    names = [*home.feature_names, *home.device_names]
    needed = [f for f in home.feature_names if f not in clocks]
    with out.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(["timestamp", *names, "services"])
        for entity, state, at, old_id, user, parent, attrs in rows:
            counted = start is None or at >= start  # rows before the period only give the context
            was_readable = readable.get(entity, False)
            readable[entity] = state not in NO_READING
            for m in readers[entity]:
                if isinstance(m, FeatureEntity):
                    raw = (
                        state
                        if m.attribute is None
                        else (json.loads(attrs) if attrs else {}).get(m.attribute)
                    )
                    try:
                        values[m.feature] = feature_value(home.feature(m.feature), m, raw)
                    except ContextError:
                        skipped["unreadable"] += counted
                    continue
                try:
                    on = m.state(state)
                except ContextError:
                    skipped["unreadable"] += counted
                    continue
                before, states[m.device] = states.get(m.device), on
                if not counted or before is None or before == on or old_id is None or not was_readable:
                    continue
                if parent:
                    skipped["by_automation"] += 1
                elif user and bytes(user) in robots:
                    skipped["by_homecog"] += 1
                elif (service := service_for(home, m.device, on)) is None:
                    skipped["no_service"] += 1
                elif any(f not in values for f in needed) or len(states) < len(home.devices):
                    skipped["incomplete"] += 1
                else:
                    moment = datetime.fromtimestamp(at).astimezone()
                    clock = format_clock(moment.hour + moment.minute / 60 + moment.second / 3600)
                    row = {**values, **dict.fromkeys(clocks, clock)}
                    row.update({d: "on" if s else "off" for d, s in states.items()})
                    row[m.device] = "on" if before else "off"  # the context is the moment before
                    writer.writerow(
                        [moment.isoformat(timespec="milliseconds"), *(row[n] for n in names), service]
                    )
                    counts[m.device] += 1
    return HistoryResult(
        path=out,
        events=sum(counts.values()),
        devices={d: n for d, n in counts.items() if n},
        skipped=skipped,
        schema=schema,
        seconds=time.perf_counter() - begin,
        unrecorded=unrecorded,
    )


def _check_schema(db: Any, shown: str) -> int:
    from sqlalchemy import inspect, text

    tables = set(inspect(db).get_table_names())
    if "schema_changes" not in tables:
        raise HomeAssistantError(
            f"recorder {shown}: not a Home Assistant recorder database (no table schema_changes)"
        )
    schema = db.execute(text("SELECT MAX(schema_version) FROM schema_changes")).scalar()
    lacking = [
        f"{t}.{c}"
        for t, columns in NEEDED.items()
        for c in columns
        if t not in tables or c not in {col["name"] for col in inspect(db).get_columns(t)}
    ]
    if schema is None or schema < MIN_SCHEMA or lacking:
        raise HomeAssistantError(
            f"recorder {shown}: schema {schema} is not one homecog reads (it reads {MIN_SCHEMA} and later, "
            f"Home Assistant 2023.4 on{'; it lacks ' + ', '.join(lacking[:3]) if lacking else ''})"
        )
    if schema > TESTED_SCHEMA:
        log.warning(
            "recorder %s: schema %d is newer than the one tested (%d); reading it",
            shown,
            schema,
            TESTED_SCHEMA,
        )
    return int(schema)


def _rows(db: Any, metadata_ids: list[int], start: float | None, end: float | None, text: Any) -> list[tuple]:
    """The mapped entities' states in time order: those from ``start`` to ``end``, and before
    ``start`` the last one of each entity, for the context at the first switch."""
    if not metadata_ids:
        return []
    select = (
        "SELECT m.entity_id, s.state, s.last_updated_ts, s.old_state_id, s.context_user_id_bin, "
        "s.context_parent_id_bin, a.shared_attrs, s.state_id FROM states s "
        "JOIN states_meta m ON s.metadata_id = m.metadata_id "
        "LEFT JOIN state_attributes a ON s.attributes_id = a.attributes_id "
    )
    ids = ", ".join(str(int(i)) for i in metadata_ids)
    where, params = [f"s.metadata_id IN ({ids})"], {}
    if start is not None:
        where.append("s.last_updated_ts >= :start")
        params["start"] = start
    if end is not None:
        where.append("s.last_updated_ts < :end")
        params["end"] = end
    rows = list(db.execute(text(select + "WHERE " + " AND ".join(where)), params).all())
    if start is not None:
        for i in metadata_ids:  # each entity's state when the period begins
            before = db.execute(
                text(
                    select + "WHERE s.metadata_id = :id AND s.last_updated_ts < :start "
                    "ORDER BY s.last_updated_ts DESC, s.state_id DESC LIMIT 1"
                ),
                {"id": i, "start": start},
            ).all()
            rows.extend(before)
    rows.sort(key=lambda r: (r[2], r[7]))  # time, then the order of writing
    return [tuple(r[:7]) for r in rows]
