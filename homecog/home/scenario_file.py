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
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from homecog.errors import ContextError, EvaluationError
from homecog.home.codec import Point, Space, is_missing, parse_services
from homecog.home.model import Home
from homecog.home.states import parse_state
from homecog.home.truth import TruthChoices, truth_with_choices
from homecog.names import user_name_problem
from homecog.text_files import check_header_unique, check_zone, text_lines, timestamp_cell


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
    """
    space = Space(home)
    what = "an event file" if events or corrections else "a scenario file"
    with text_lines(path, what=what, error=EvaluationError) as lines:
        reader = csv.DictReader(lines)
        try:
            out = _rows(path, reader, space, home, truth, events=events, corrections=corrections)
        except csv.Error as e:  # a quoted cell that never ends, or over the field limit
            raise EvaluationError(f"{path}: line {reader.line_num}: not CSV: {e}") from None
    if not out:
        raise EvaluationError(f"{path}: no rows after the header")
    return out


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
    needed = list(space.names)
    header = reader.fieldnames or []
    _check_header(path, header, needed, events=events, corrections=corrections)
    out = []
    zoned: tuple[bool, int] | None = None  # whether the first timestamp had a zone, its line
    for line, row in enumerate(reader, start=2):
        if None in row or any(row.get(c) is None for c in needed):
            raise EvaluationError(f"{path}: line {line}: expected {len(header)} fields")
        _check_readings(path, line, row, space, home)
        timestamp = None
        if events or corrections:  # all with a time zone or all without: others cannot be compared
            timestamp = timestamp_cell(row["timestamp"], path, line, EvaluationError)
            zoned = zoned or (timestamp.tzinfo is not None, line)
            check_zone(path, line, timestamp, zoned, EvaluationError)
        user = (row.get("user") or "").strip() or None  # a blank cell: the user the caller gives
        problem = None if user is None else user_name_problem(user)
        if problem is not None:
            raise EvaluationError(f"{path}: line {line}, column user: {problem}")
        context = {name: row[name].strip() for name in needed}
        point = space.point(context)
        truth_set, ambiguous = _wanted(path, line, row, point, home, truth)
        out.append(
            Scenario(
                context=context,
                point=point,
                truth=truth_set,
                choices=ambiguous,
                user=user,
                timestamp=timestamp,
            )
        )
    return out


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
