"""The history of corrections, read from the store's experience log.

Each correction row of the log holds what the user wanted and what the correction added and
rejected; what the robot had proposed is the wanted services less the added ones plus the
rejected ones, and the robot agreed when nothing was added or rejected. So the history and the
agreement curve need nothing but the log, and outlive the server that took the corrections.
One query, on the index of ``(kind, user, id)``, reads the latest ``limit`` of them.

>>> from homecog.home import load_home
>>> from homecog.knowledge.store import Store
>>> correction_history(Store.open("sqlite://", load_home("paper"))).total
0
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from datetime import UTC, date, datetime, timedelta
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.exc import SQLAlchemyError

from homecog.errors import StoreError
from homecog.knowledge.database import READ_ONLY, redact
from homecog.knowledge.schema import ExperienceRow
from homecog.knowledge.store import Store


@dataclass(frozen=True)
class Logged:
    """One correction as the log has it, with what it changed."""

    id: int
    at: float  # seconds since 1970, UTC
    user: str
    want: list[str]
    added: list[str]
    rejected: list[str]
    kind: str = "explicit"  # explicit, observed (a person's switch) or undo (of the robot's)
    weight: int = 1
    concerns: list[str] | None = None  # the services it speaks of (None: every one)
    note: dict[str, Any] | None = None  # observed and undo: the device, the robot's action

    @property
    def predicted(self) -> list[str]:
        """What the robot had proposed before the correction (of the services it concerns)."""
        return [s for s in self.want if s not in self.added] + self.rejected

    @property
    def agreed(self) -> bool:
        """Whether the robot had proposed just what the user wanted."""
        return not self.added and not self.rejected


@dataclass(frozen=True)
class History:
    """The latest corrections, oldest first, how many the log holds in all, and the ``before``
    of the page older than these (``None``: there is none)."""

    total: int
    corrections: list[Logged]
    before: int | None = None


@dataclass(frozen=True)
class Agreement:
    """The running agreement after the ``n``-th correction."""

    n: int
    user: str
    agreed: bool
    rate: float


def correction_history(
    store: Store, *, user: str | None = None, limit: int = 500, before: int | None = None
) -> History:
    """The latest ``limit`` corrections (of ``user``, or of everyone; older than the one whose id
    is ``before``), oldest first, and the ``before`` of the page older than these.

    Raises :class:`StoreError` when the database cannot be used.
    """
    if user is not None and "\x00" in user:
        return History(0, [])  # no correction is by such a name, and PostgreSQL refuses to look
    where = [ExperienceRow.home == store.home.name, ExperienceRow.kind == "correction"]
    if user is not None:
        where.append(ExperienceRow.user == user)
    page = [*where, ExperienceRow.id < before] if before is not None else where
    latest = (
        select(ExperienceRow.id, ExperienceRow.user, ExperienceRow.created_at, ExperienceRow.payload)
        .where(*page)
        .order_by(ExperienceRow.id.desc())
        .limit(limit + 1)  # one more: whether there is an older page
    )
    try:
        with store.engine.connect().execution_options(**{READ_ONLY: True}) as conn:
            total = conn.execute(select(func.count()).select_from(ExperienceRow).where(*where)).scalar_one()
            rows = conn.execute(latest).all()
            older, rows = len(rows) > limit, rows[:limit]
    except SQLAlchemyError as e:
        raise _unusable(store, e) from None
    corrections = []
    for row in reversed(rows):
        payload = json.loads(row.payload)
        corrections.append(
            Logged(
                id=row.id,
                at=row.created_at.replace(tzinfo=UTC).timestamp(),
                user=row.user or "",
                want=list(payload["want"]),
                added=list(payload["added"]),
                rejected=list(payload["rejected"]),
                kind=payload.get("kind", "explicit"),
                weight=int(payload.get("weight", 1)),
                concerns=payload.get("concerns"),
                note=payload.get("note"),
            )
        )
    return History(total=total, corrections=corrections, before=corrections[0].id if older else None)


def agreement(history: History) -> list[Agreement]:
    """Per correction in order: whether the robot had already proposed what the user wanted,
    and the running rate of that agreement.

    >>> c = [Logged(i, 0.0, "kim", ["A"], [], []) for i in (1, 2)]
    >>> [a.rate for a in agreement(History(2, [Logged(0, 0.0, "kim", ["A"], ["A"], []), *c]))]
    [0.0, 0.5, 0.6666666666666666]
    """
    out, agreed = [], 0
    for n, c in enumerate(history.corrections, start=1):
        agreed += c.agreed
        out.append(Agreement(n=n, user=c.user, agreed=c.agreed, rate=agreed / n))
    return out


def _unusable(store: Store, e: SQLAlchemyError) -> StoreError:
    """The store error that says why the database could not be read, in one line."""
    orig = getattr(e, "orig", None) or e
    first = (str(orig).strip().splitlines() or [type(orig).__name__])[0]
    return StoreError(f"database {redact(store.url)}: cannot use the database: {first}")


@dataclass(frozen=True)
class SwitchDay:
    """What the household did by hand on one day (the server's local date)."""

    day: date
    switches: int  # a person's switches of a device the robot learned from (undos by hand too)
    undos: int  # the robot's actions undone, by hand or from the page


#: the most correction rows one look at the days reads (a busy household's weeks)
MAX_ROWS = 100_000


def switches_per_day(store: Store, *, days: int = 14, today: date | None = None) -> list[SwitchDay]:
    """The household's switches by hand and its undos of the robot's actions, per day, over the
    last ``days`` days up to ``today`` (the server's local date), oldest first, days without any
    included. Read from the experience log: an observed correction of a device is a person's
    switch, an undo correction a switch back of the robot's (one per action undone, however many
    services it rejected). Raises :class:`StoreError` when the database cannot be used.

    >>> from homecog.home import load_home
    >>> from homecog.knowledge.store import Store
    >>> [d.switches for d in switches_per_day(Store.open("sqlite://", load_home("paper")), days=3)]
    [0, 0, 0]
    """
    today = today or date.today()
    first = today - timedelta(days=days - 1)
    since = datetime.combine(first, datetime.min.time()).astimezone(UTC).replace(tzinfo=None)
    switches: Counter[date] = Counter()
    undone: set[tuple[date, object]] = set()
    where = [ExperienceRow.home == store.home.name, ExperienceRow.kind == "correction"]
    newest = (
        select(ExperienceRow.created_at, ExperienceRow.payload)
        .where(*where)
        .order_by(ExperienceRow.id.desc())
    )
    try:
        with store.engine.connect().execution_options(**{READ_ONLY: True}) as conn:
            for at, payload in conn.execute(newest.limit(MAX_ROWS).execution_options(yield_per=500)):
                if at < since:  # the log is in time order: the rest is older still
                    break
                day = at.replace(tzinfo=UTC).astimezone().date()
                _count(json.loads(payload), day, switches, undone)
    except SQLAlchemyError as e:
        raise _unusable(store, e) from None
    undos = Counter(day for day, _ in undone)
    return [SwitchDay(d, switches[d], undos[d]) for d in (first + timedelta(days=i) for i in range(days))]


def _count(
    payload: dict[str, Any], day: date, switches: Counter[date], undone: set[tuple[date, object]]
) -> None:
    """Count one correction of the log: a person's switch, an undo, or neither."""
    note, kind = payload.get("note") or {}, payload.get("kind", "explicit")
    if kind == "observed" and "device" in note:
        switches[day] += 1
    elif kind == "undo":
        undone.add((day, note.get("action")))
        if note.get("by") == "person":
            switches[day] += 1
