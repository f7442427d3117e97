"""Scenario and event files: CSV with a column per context feature and per device, a
row per context; the services wanted there come from a ``services`` column or from a truth home.

Every stage that reads such a file reads it here: ``homecog eval --scenarios`` and ``homecog
replay`` (evaluation), ``homecog correct --events`` (knowledge). A file is checked whole; an
error names the file, the line and the column.

>>> import tempfile
>>> from pathlib import Path
>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> header = ",".join(home.feature_names + home.device_names)
>>> with tempfile.TemporaryDirectory() as folder:
...     path = Path(folder) / "one.csv"
...     _ = path.write_text(header + "\\n23:00,21,5,bed,lie,sleep,off,off,off,off,off,off,off,off\\n")
...     (row,) = load_scenarios(path, home, home)
>>> row.context["behavior"], sorted(row.truth)
('sleep', [])
"""

from __future__ import annotations

import csv
import itertools
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from datetime import datetime
from operator import attrgetter
from pathlib import Path
from typing import Any

from homecog.errors import ContextError, EvaluationError
from homecog.home.codec import Point, Space, is_missing, parse_services
from homecog.home.model import Home
from homecog.home.states import parse_state
from homecog.home.truth import TruthChoices, truth_with_choices
from homecog.names import user_name_problem
from homecog.text_files import LINE_LIMIT, check_header_unique, check_zone, text_lines, timestamp_cell


@dataclass(frozen=True)
class Scenario:
    """A context as a scenario-file row, its point, and the services the truth home wants.

    ``truth`` is the canonical optimal set; ``choices``, where more than one set is optimal
    (services that set several devices), the groups' optimal sets
    (:class:`~homecog.home.truth.TruthChoices`).
    """

    context: dict[str, str]
    point: Point
    truth: frozenset[str]
    choices: TruthChoices | tuple[()] = ()
    user: str | None = None  # an event file's ``user`` column, where it may have one
    timestamp: datetime | None = None  # an event file's ``timestamp``

    def truth_for(self, predicted: Sequence[str]) -> frozenset[str]:
        """The optimal set that agrees best with a prediction: most services in common, then
        fewest differences (:meth:`~homecog.home.truth.TruthChoices.pick`)."""
        return self.choices.pick(predicted) if self.choices else self.truth


def truth_of(home: Home, point: Point) -> tuple[frozenset[str], TruthChoices | tuple[()]]:
    """The canonical optimal set of a point under ``home`` and, where several are optimal, the
    choices."""
    n_f = len(home.features)
    return truth_with_choices(home, point.codes[:n_f], tuple(bool(c) for c in point.codes[n_f:]))


def load_scenarios(
    path: Path, home: Home, truth: Home, *, events: bool = False, corrections: bool = False
) -> list[Scenario]:
    """Scenarios (or events) from a CSV file; errors name the file, line and column.

    ``corrections``: events to learn, which must say the services wanted and may name the
    household member of each row in a ``user`` column.

    The file is read twice: first every row is checked, in batches and in bounded memory
    (:class:`_Check`), so that a bad row anywhere is refused before a scenario is made; then
    the scenarios are made.
    """
    space = Space(home)
    what = "an event file" if events or corrections else "a scenario file"
    stamped = events or corrections
    with text_lines(path, what=what, error=EvaluationError) as lines:
        reader = csv.reader(lines)
        try:
            header = next(reader, [])
        except csv.Error as e:  # a quoted cell that never ends, or over the field limit
            raise EvaluationError(f"{path}: line {reader.line_num}: not CSV: {e}") from None
        _check_header(path, header, list(space.names), events=events, corrections=corrections)
        _Check(path, header, space, home, truth, stamped=stamped).rows(lines, reader.line_num)
    with text_lines(path, what=what, error=EvaluationError) as lines:
        dict_reader = csv.DictReader(lines)
        try:
            out = _rows(path, dict_reader, space, home, truth, events=events, corrections=corrections)
        except csv.Error as e:
            raise EvaluationError(f"{path}: line {dict_reader.line_num}: not CSV: {e}") from None
    if not out:
        raise EvaluationError(f"{path}: no rows after the header")
    return out


Zoned = tuple[bool, int] | None  # whether a file's first timestamp had a zone, and its line


def _rows(
    path: Path,
    reader: csv.DictReader[str],
    space: Space,
    home: Home,
    truth: Home,
    *,
    events: bool,
    corrections: bool,
) -> list[Scenario]:
    """The rows of a scenario or event file, each checked."""
    header = reader.fieldnames or []
    _check_header(path, header, list(space.names), events=events, corrections=corrections)
    out = []
    zoned: Zoned = None
    for line, row in enumerate(reader, start=2):
        scenario, zoned = _row(path, line, row, len(header), space, home, truth, events or corrections, zoned)
        out.append(scenario)
    return out


def _row(
    path: Path,
    line: int,
    row: dict[str | None, Any],
    width: int,
    space: Space,
    home: Home,
    truth: Home,
    stamped: bool,
    zoned: Zoned,
) -> tuple[Scenario, Zoned]:
    """One row of a scenario or event file, checked, as a scenario (``row`` as
    :class:`csv.DictReader` makes it); the file's zone as it stands after it."""
    needed = space.names
    if None in row or any(row.get(c) is None for c in needed):
        raise EvaluationError(f"{path}: line {line}: expected {width} fields")
    _check_readings(path, line, row, space, home)  # type: ignore[arg-type]
    timestamp = None
    if stamped:  # all with a time zone or all without: others cannot be compared
        timestamp = timestamp_cell(row["timestamp"], path, line, EvaluationError)
        zoned = zoned or (timestamp.tzinfo is not None, line)
        check_zone(path, line, timestamp, zoned, EvaluationError)
    user = (row.get("user") or "").strip() or None  # a blank cell: the user the caller gives
    problem = None if user is None else user_name_problem(user)
    if problem is not None:
        raise EvaluationError(f"{path}: line {line}, column user: {problem}")
    context = {name: row[name].strip() for name in needed}
    point = space.point(context)
    truth_set, ambiguous = _wanted(path, line, row, point, home, truth)  # type: ignore[arg-type]
    scenario = Scenario(
        context=context, point=point, truth=truth_set, choices=ambiguous, user=user, timestamp=timestamp
    )
    return scenario, zoned


def _check_header(
    path: Path, header: Sequence[str], needed: list[str], *, events: bool, corrections: bool
) -> None:
    """The columns: every feature and device, a first ``timestamp`` for events, nothing unknown."""
    if not header:
        raise EvaluationError(f"{path}: empty file; expected a header with {', '.join(needed)}")
    check_header_unique(header, path, EvaluationError)
    required = [*needed, "timestamp"] if events or corrections else needed
    missing = [c for c in [*required, *(["services"] if corrections else [])] if c not in header]
    if missing:
        raise EvaluationError(f"{path}: line 1: missing column(s) {', '.join(missing)}")
    if (events or corrections) and header[0] != "timestamp":
        raise EvaluationError(f"{path}: line 1: the first column must be timestamp")
    extra = ("services", "timestamp", *(["user"] if corrections else []))
    unknown = [c for c in header if c not in needed and c not in extra]
    if unknown:
        raise EvaluationError(f"{path}: line 1: unknown column(s) {', '.join(unknown)}")


def _check_readings(path: Path, line: int, row: dict[str, str], space: Space, home: Home) -> None:
    """Every feature's reading (or a missing one) and every device's state of a row."""
    for j, name in enumerate(space.names):
        value = row[name].strip()
        try:
            if j >= space.n_features:
                parse_state(value, name)
            elif not is_missing(home.features[j], value):
                home.features[j].discretize(value)
        except ContextError as e:
            raise EvaluationError(f"{path}: line {line}, column {name}: {e}") from None


def _wanted(
    path: Path, line: int, row: dict[str, str], point: Point, home: Home, truth: Home
) -> tuple[frozenset[str], TruthChoices | tuple[()]]:
    """The services a row wants: its ``services`` column, else what the truth home says."""
    if row.get("services") is not None:
        try:
            wanted = parse_services(row["services"].replace(";", ","), truth)
        except ContextError as e:
            raise EvaluationError(f"{path}: line {line}, column services: {e}") from None
        return frozenset(wanted), ()
    if point.missing:
        name = home.features[min(point.missing)].name
        raise EvaluationError(
            f"{path}: line {line}, column {name}: a missing reading needs a services column "
            "(the truth home cannot say what is wanted where a reading is unknown)"
        )
    return truth_of(truth, point)


#: rows the first pass checks at once, and distinct cells it remembers per column as good
_BATCH = 8192
_REMEMBERED = 50_000


class _Check:
    """The first pass over a file of rows: every row checked as :func:`_row` checks it, without
    making a scenario. Rows are read in batches of :data:`_BATCH`, each column of a batch as one
    set of distinct cells, and only a cell not met before is checked (each column remembers up
    to :data:`_REMEMBERED`); a batch in which anything is amiss (a row of another length, a
    blank line, a cell that does not pass) is checked again row by row by :func:`_row`, which
    raises the error the file has always had. Memory is a batch's, whatever the file's size."""

    def __init__(
        self, path: Path, header: list[str], space: Space, home: Home, truth: Home, *, stamped: bool
    ):
        self.path, self.header, self.space, self.home, self.truth = path, header, space, home, truth
        self.stamped = stamped
        self.zoned: Zoned = None
        self.has_services = "services" in header
        # per column of the home: its position in the row, and its cells known good
        self.columns: list[tuple[int, int, set[str]]] = [
            (header.index(name), j, set()) for j, name in enumerate(space.names)
        ]
        self.services: set[str] = set()
        self.users: set[str] = set()

    def rows(self, lines: Iterator[str], read: int) -> None:
        """Check every row of the lines after the header (``read``: the lines the header took).

        Lines without a quote or a carriage return, the common case, are split at commas as
        :mod:`csv` would split them, a batch at once; from a batch with either on, :mod:`csv`
        reads the rest."""
        line = 2  # the next row's number, as csv.DictReader counts rows
        plain = csv.field_size_limit() >= LINE_LIMIT  # no unquoted cell can be over the limit
        while True:
            batch: list[str] = []
            failure: EvaluationError | None = None
            try:
                batch.extend(itertools.islice(lines, _BATCH))  # keeps the lines before a failure
            except EvaluationError as e:  # a line too long, not UTF-8, a NUL byte
                failure = e
            text = "".join(batch)
            if not plain or '"' in text or "\r" in text:
                rest = itertools.chain(batch, _raise(failure) if failure else lines)
                self._csv_rows(csv.reader(rest), line, read)
                return
            if set(map(str.count, batch, itertools.repeat(","))) == {len(self.header) - 1}:
                cells = text.replace("\n", ",").split(",")
                width = len(self.header)
                del cells[len(batch) * width :]  # the empty cell after the last line ending
                good = self._batch_good([cells[at::width] for at in range(width)], line)
            else:  # a blank line (no row) or a row of another length
                good = False
            if not good:
                self._one_by_one(list(csv.reader(batch)), line)
            line += len(batch) - batch.count("\n")
            read += len(batch)
            if failure is not None:
                raise failure from None
            if len(batch) < _BATCH:
                return

    def _csv_rows(self, reader: Iterator[list[str]], line: int, read: int) -> None:
        """Check the rows :mod:`csv` reads (``line``: the first's number; ``read``: the lines
        read before)."""
        while True:
            batch: list[list[str]] = []
            failure: Exception | None = None
            try:
                batch.extend(itertools.islice(reader, _BATCH))  # keeps the rows before a failure
            except csv.Error as e:  # after the rows before it are checked, as a row at a time did
                at = read + reader.line_num  # type: ignore[attr-defined]
                failure = EvaluationError(f"{self.path}: line {at}: not CSV: {e}")
            except EvaluationError as e:
                failure = e
            width = len(self.header)
            good = bool(batch) and set(map(len, batch)) == {width}
            if good:
                good = self._batch_good(list(zip(*batch, strict=False)), line)
            if batch and not good:
                self._one_by_one(batch, line)
            line += len(batch) - batch.count([])
            if failure is not None:
                raise failure from None
            if len(batch) < _BATCH:
                return

    def _batch_good(self, columns: list[Sequence[str]], line: int) -> bool:
        """Whether every row of a batch passes, checked column by column (``line``: the
        number of its first row)."""
        for at, j, known in self.columns:
            cells = set(columns[at])
            for cell in cells.difference(known):
                missing = self._reading(j, cell)
                if missing is None or (missing and not self.has_services):
                    return False
                if len(known) < _REMEMBERED:
                    known.add(cell)
        if self.has_services and not _known(
            set(columns[self.header.index("services")]), self.services, self._services
        ):
            return False
        if "user" in self.header and not _known(set(columns[self.header.index("user")]), self.users, _user):
            return False
        return not self.stamped or self._timestamps(columns[self.header.index("timestamp")], line)

    def _reading(self, j: int, cell: str) -> bool | None:
        """Whether a good cell of column ``j`` is a missing reading; None for a bad one."""
        value = cell.strip()
        try:
            if j >= self.space.n_features:
                parse_state(value, self.space.names[j])
                return False
            feature = self.home.features[j]
            if is_missing(feature, value):
                return True
            feature.discretize(value)
        except Exception:  # the row is checked again, and says what
            return None
        return False

    def _services(self, cell: str) -> bool:
        try:
            parse_services(cell.replace(";", ","), self.truth)
        except Exception:  # the row is checked again, and says what
            return False
        return True

    def _timestamps(self, cells: Sequence[str], line: int) -> bool:
        """Whether every timestamp of a batch is an ISO 8601 time, all with a zone or all without
        as the file's first (``line``: the batch's first row's)."""
        try:
            times = list(map(datetime.fromisoformat, map(str.strip, cells)))
        except Exception:  # the row is checked again, and says what
            return False
        zoned = self.zoned or (times[0].tzinfo is not None, line)
        if {zone is not None for zone in set(map(attrgetter("tzinfo"), times))} != {zoned[0]}:
            return False
        self.zoned = zoned
        return True

    def _one_by_one(self, batch: list[list[str]], line: int) -> None:
        """A batch checked row by row as the second pass reads it: the first bad row raises."""
        names = self.header
        width = len(names)
        for row in batch:
            if not row:  # a blank line is no row
                continue
            cells: dict[str | None, Any] = dict(zip(names, row, strict=False))
            if len(row) > width:
                cells[None] = row[width:]
            for name in names[len(row) :]:
                cells[name] = None
            _, self.zoned = _row(
                self.path, line, cells, width, self.space, self.home, self.truth, self.stamped, self.zoned
            )
            line += 1


def _known(cells: set[str], known: set[str], good: Callable[[str], bool]) -> bool:
    """Whether every cell is good, those not ``known`` checked (and then remembered)."""
    for cell in cells.difference(known):
        if not good(cell):
            return False
        if len(known) < _REMEMBERED:
            known.add(cell)
    return True


def _user(cell: str) -> bool:
    name = cell.strip()
    return not name or user_name_problem(name) is None


def _raise(failure: Exception) -> Iterator[str]:
    """Lines that end where reading them failed, as they did the first time."""
    raise failure
    yield  # a generator
