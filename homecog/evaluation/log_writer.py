"""What the real-data adapters share: sensor firings and labelled activities as the state
changes of a log (``timestamp,entity,state``), which ``homecog log events`` reads.

A sensor that fires from one time to another is ``on`` at the start and ``off`` at the end; its
firings that overlap or touch are one. Labelled activities become the states of one entity: at
each start or end, the label of the activity under way that started last, or ``idle`` when none
is. A log covers a span — the labelled days — and a device's state at its start is written
first, so that its first switch is one.

>>> from datetime import datetime
>>> at = lambda m: datetime(2008, 2, 25, 9, m)
>>> merged([(at(5), at(9)), (at(0), at(2)), (at(2), at(3))])
[(datetime.datetime(2008, 2, 25, 9, 0), datetime.datetime(2008, 2, 25, 9, 3)), \
(datetime.datetime(2008, 2, 25, 9, 5), datetime.datetime(2008, 2, 25, 9, 9))]
>>> [(t.minute, s) for t, s in timeline([(at(0), at(10), "cook"), (at(4), at(6), "drink")])]
[(0, 'cook'), (4, 'drink'), (6, 'cook'), (10, 'idle')]
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from homecog.errors import RealDataError
from homecog.home.states import state_word
from homecog.names import home_name_problem

Interval = tuple[datetime, datetime]
#: the years a data set's dates may be of (the real ones: 2003, 2008 and 2009)
YEARS = range(1900, 2101)
#: the most days a data set's labelled activities may span (the real ones: two to four weeks);
#: the MIT adapter writes an illumination reading every 10 minutes of it
MAX_SPAN_DAYS = 366
# the order of rows at one time: a device's first state, then the activity, presence, devices
FIRST, ACTIVITY, PRESENCE, DEVICE = range(4)


def slug(text: str) -> str:
    """A name as an identifier: ``Hall-Toilet door`` → ``hall_toilet_door``."""
    return re.sub(r"[^a-z0-9]+", "_", text.strip().lower()).strip("_")


def home_name(given: str | None, default: str) -> str:
    """The name of a converted home, ``given`` (``--name``) or ``default``, checked before a file is
    named after it: a name is never a path.

    >>> home_name(None, "mit_subject1"), home_name("den", "mit_subject1")
    ('mit_subject1', 'den')
    >>> home_name("../../x", "mit_subject1")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    homecog.errors.RealDataError: --name: '../../x' is not a home name: 1 to 64 letters, digits, ...
    """
    name = default if given is None else given
    problem = home_name_problem(name)
    if problem is not None:
        raise RealDataError(problem if given is None else f"--name: {problem}")
    return name


def small_numbers(text: str, sep: str, widths: Sequence[int]) -> tuple[int, ...]:
    """The numbers of ``text`` split at ``sep``, each of at most its width in ASCII digits;
    ValueError otherwise (never a 5,000-digit integer, never a year past a date's range).

    >>> small_numbers("4/31/2003", "/", (2, 2, 4))
    (4, 31, 2003)
    >>> small_numbers("4/1/99999", "/", (2, 2, 4))
    Traceback (most recent call last):
    ...
    ValueError: not 3 numbers of at most 2, 2, 4 digits
    """
    parts = [p.strip() for p in text.strip().split(sep)]
    fits = len(parts) == len(widths) and all(
        0 < len(p) <= w and p.isascii() and p.isdigit() for p, w in zip(parts, widths, strict=False)
    )
    if not fits:
        raise ValueError(f"not {len(widths)} numbers of at most {', '.join(map(str, widths))} digits")
    return tuple(int(p) for p in parts)


def check_span(start: datetime, end: datetime, path: Path) -> None:
    """Refuse labelled activities (of the file ``path``) that span more than
    :data:`MAX_SPAN_DAYS` days: a log, and readings, over centuries of a hostile file."""
    days = (end - start).days
    if days > MAX_SPAN_DAYS:
        raise RealDataError(
            f"{path}: the activities span {days:,} days, {start:%Y-%m-%d} to {end:%Y-%m-%d}; "
            f"a data set may span at most {MAX_SPAN_DAYS}"
        )


def camel(text: str) -> str:
    """A name as a service's part: ``washing machine`` → ``WashingMachine``."""
    return "".join(part.capitalize() for part in slug(text).split("_"))


def merged(intervals: Iterable[Interval]) -> list[Interval]:
    """Intervals in time order, those that overlap or touch made one."""
    out: list[Interval] = []
    for start, end in sorted(intervals):
        if out and start <= out[-1][1]:
            out[-1] = (out[-1][0], max(out[-1][1], end))
        else:
            out.append((start, end))
    return out


def timeline(
    activities: Sequence[tuple[datetime, datetime, str]], idle: str = "idle"
) -> list[tuple[datetime, str]]:
    """The label under way at every start and end (the one that started last; ``idle`` for
    none), where it changes."""
    moments = sorted({t for start, end, _ in activities for t in (start, end)})
    out: list[tuple[datetime, str]] = []
    for t in moments:
        going = [(start, i, label) for i, (start, end, label) in enumerate(activities) if start <= t < end]
        label = max(going)[2] if going else idle
        if not out or out[-1][1] != label:
            out.append((t, label))
    return out


@dataclass
class LogWriter:
    """The rows of a log over a span, written in time order."""

    start: datetime
    end: datetime
    rows: list[tuple[datetime, int, int, str, str]] = field(default_factory=list)
    left_out: int = 0  # state changes outside the span

    def add(self, at: datetime, entity: str, state: str, rank: int) -> None:
        """One state change (left out, and counted, outside the span)."""
        if not self.start <= at <= self.end:
            self.left_out += 1
            return
        self.rows.append((at, rank, len(self.rows), entity, state))

    def firings(self, entity: str, intervals: Iterable[Interval], rank: int) -> None:
        """A sensor's firings: on at each start, off at each end; a device's state at the span's
        start first."""
        intervals = merged(intervals)
        if rank == DEVICE:
            under_way = any(start <= self.start < end for start, end in intervals)
            self.add(self.start, entity, state_word(under_way), FIRST)
        for start, end in intervals:
            self.add(start, entity, "on", rank)
            self.add(end, entity, "off", rank)

    def activities(self, entity: str, activities: Sequence[tuple[datetime, datetime, str]]) -> None:
        """Labelled activities as the states of one entity."""
        for at, label in timeline(activities):
            self.add(at, entity, label, ACTIVITY)

    def write(self, path: Path) -> int:
        """Write the log; returns its number of rows."""
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(["timestamp", "entity", "state"])
            for at, _, _, entity, state in sorted(self.rows):
                writer.writerow([at.isoformat(), entity, state])
        return len(self.rows)
