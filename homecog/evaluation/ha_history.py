"""``homecog ha history``: a household's own switches, read from a Home Assistant recorder, as an
event file that ``homecog replay`` evaluates on and the robot learns from.

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
device's state — and, as ``services``, the home's service that makes that switch. The rows
become the conversion core's (:func:`log_rows`), which keeps the context and makes the rows
(:mod:`~homecog.evaluation.event_stream`, as ``homecog log events`` does); asked for ``quiet``
minutes, it adds quiet rows where a feature changes and no device switched near it.

The recorder is read with SQLAlchemy: a SQLite file (read-only) or a MariaDB/PostgreSQL URL.
Schemas 38 and later have what is needed (tested with 42, Home Assistant 2024.3); another is
refused with one line saying which.
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from datetime import datetime
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from homecog.errors import ContextError, HomeAssistantError
from homecog.evaluation.event_stream import EventStream, LogRow, Reader, Skip
from homecog.home.home_assistant import NO_READING, DeviceEntity, FeatureEntity, feature_value, nearest
from homecog.home.model import Feature, Home
from homecog.text_files import not_regular

if TYPE_CHECKING:
    from sqlalchemy import Engine

log = logging.getLogger(__name__)

MIN_SCHEMA = 38  # states_meta and the binary context columns: Home Assistant 2023.4 and later
TESTED_SCHEMA = 42  # Home Assistant 2024.3
NEEDED = {
    "states": ("state", "last_updated_ts", "old_state_id", "metadata_id", "attributes_id",
               "context_user_id_bin", "context_parent_id_bin"),
    "states_meta": ("metadata_id", "entity_id"),
}  # fmt: skip
REASONS = ("by_automation", "by_homecog", "unreadable", "incomplete", "no_service")
__all__ = ["HistoryResult", "log_rows", "read_history", "recorder_url"]


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
    quiet: int | None = None  # quiet rows, where they were asked for

    def as_dict(self) -> dict[str, Any]:
        extra = {} if self.quiet is None else {"quiet": self.quiet}
        return {
            "events": self.events,
            "devices": self.devices,
            "skipped": self.skipped,
            "schema": self.schema,
            "seconds": round(self.seconds, 3),
            "out": str(self.path),
            "unrecorded": self.unrecorded,
            **extra,
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
        kind = not_regular(path)
        raise HomeAssistantError(
            f"recorder {recorder}: "
            + (
                "no such file"
                if kind is None
                else "is a folder"
                if path.is_dir()
                else f"is {kind}, not a file"
            )
        )
    return f"sqlite:///file:{path.resolve()}?mode=ro&uri=true"  # read-only: Home Assistant may be writing


def _engine(url: str, shown: str) -> Engine:
    """The recorder's engine; a URL SQLAlchemy cannot use is one line naming it."""
    from sqlalchemy import create_engine
    from sqlalchemy.exc import ArgumentError, NoSuchModuleError

    from homecog.knowledge.database import server_connect_args

    try:
        return create_engine(url, connect_args=server_connect_args(url))
    except (ArgumentError, NoSuchModuleError, ValueError) as e:
        raise HomeAssistantError(f"recorder {shown}: not a database URL ({e})") from None
    except ImportError as e:
        raise HomeAssistantError(
            f"recorder {shown}: driver missing ({e.name}); install it with pip"
        ) from None


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
    quiet: float | None = None,
) -> HistoryResult:
    """Write the event file of a home's recorded switches by people; see the module docstring.
    With ``quiet`` minutes it adds quiet rows (:mod:`~homecog.evaluation.event_stream`)."""
    from sqlalchemy import text
    from sqlalchemy.exc import SQLAlchemyError

    begin = time.perf_counter()
    mapping = home.home_assistant
    if mapping is None:
        raise HomeAssistantError(f"{home.source}: no home_assistant section; see homecog ha scaffold")
    start, end = _parse_time(since, "since"), _parse_time(until, "until")
    url = recorder_url(recorder)
    shown = recorder if "://" not in recorder else recorder.split("@")[-1]
    engine = _engine(url, shown)
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
    stream = EventStream(home, _readers(home), quiet=quiet, reasons=REASONS, timespec="milliseconds")
    for row in log_rows(rows, start, {bytes.fromhex(u) for u in exclude_users}):
        stream.feed(row)
    written = stream.write(out)
    return HistoryResult(
        path=out,
        events=sum(stream.switches.values()),
        devices={d: n for d, n in stream.switches.items() if n},
        skipped={k: stream.skipped[k] for k in REASONS},
        schema=schema,
        seconds=time.perf_counter() - begin,
        unrecorded=unrecorded,
        quiet=None if quiet is None else written - sum(stream.switches.values()),
    )


def log_rows(rows: Iterable[tuple], start: float | None, robots: set[bytes]) -> Iterator[LogRow]:
    """The recorder's state rows as the core's rows: a change that follows from another (an
    automation's) or that is homecog's own is no person's switch; one without an earlier
    readable state of its entity (what an instance restores) is no switch at all; a row before
    ``start`` only gives the context."""
    readable: dict[str, bool] = {}  # entity -> whether its last state could be read
    for entity, state, at, old_id, user, parent, attrs in rows:
        was_readable, readable[entity] = readable.get(entity, False), state not in NO_READING
        yield LogRow(
            at=datetime.fromtimestamp(at).astimezone(),
            entity=entity,
            state=state,
            extra=attrs,
            counted=start is None or at >= start,
            switchable=old_id is not None and was_readable,
            skip="by_automation" if parent else "by_homecog" if user and bytes(user) in robots else None,
        )


def _readers(home: Home) -> dict[str, list[Reader]]:
    """Per entity, how its states read as the home's features and devices."""
    assert home.home_assistant is not None
    out: dict[str, list[Reader]] = {}
    for m in (*home.home_assistant.features, *home.home_assistant.devices):
        if isinstance(m, FeatureEntity):
            reader = Reader(m.feature, "feature", partial(_feature, home.feature(m.feature), m))
        else:
            reader = Reader(m.device, "device", partial(_device, m))
        out.setdefault(m.entity, []).append(reader)
    return out


def _feature(feature: Feature, mapping: FeatureEntity, row: LogRow) -> str:
    raw = (
        row.state
        if mapping.attribute is None
        else (json.loads(row.extra) if row.extra else {}).get(mapping.attribute)
    )
    try:
        return feature_value(feature, mapping, raw)
    except ContextError:
        raise Skip("unreadable") from None


def _device(mapping: DeviceEntity, row: LogRow) -> bool:
    try:
        return mapping.state(row.state)
    except ContextError:
        raise Skip("unreadable") from None


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
