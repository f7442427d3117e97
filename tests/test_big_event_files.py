"""Large event and scenario files: a bad row anywhere is refused in bounded memory, before any
scenario is made, with the message a row at a time always gave (docs/design.md, "Hostile
input"); a good file reads as before."""

from __future__ import annotations

import csv
import random
import time
import tracemalloc
from pathlib import Path

import pytest

from homecog.errors import EvaluationError
from homecog.home import load_home
from homecog.home.codec import Space, parse_services
from homecog.home.scenario_file import _BATCH, _rows, load_scenarios, truth_of
from homecog.text_files import text_lines

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
HEADER = "timestamp,time,light,activity,blind,desk_lamp,radio,services,user\n"
DANCE = "activity: unknown value 'dance'; expected one of work, relax, sleep"
BAD = "2024-03-01T08:00:00,10:00,50,dance,off,off,off,,\n"


def _good_rows(n: int, seed: int = 1) -> list[str]:
    rng = random.Random(seed)
    rows = []
    for i in range(n):
        cells = [
            f"2024-03-01T{i // 60 % 24:02d}:{i % 60:02d}:00",
            f"{rng.randrange(24):02d}:{rng.choice(['00', '30'])}",
            rng.choice(["5", "50", " 300", "812.5", "unknown", ""]),
            rng.choice(["work", "relax", "sleep"]),
            rng.choice(["on", "off", "yes", "0"]),
            rng.choice(["on", "off"]),
            rng.choice(["on", "OFF"]),
            rng.choice(["LampOn", "", "RadioOn;BringTea", "LowerBlind"]),
            rng.choice(["", "ann", "bo"]),
        ]
        rows.append(",".join(cells) + "\n")
    return rows


def _write(path: Path, size: int, last: str = BAD) -> Path:
    block = "".join(_good_rows(2000))
    with path.open("w") as f:
        f.write(HEADER)
        for _ in range(size // len(block)):
            f.write(block)
        f.write(last)
    return path


def _refusal(path: Path, **kinds: bool) -> tuple[str, float, float]:
    """What reading a file says, its seconds and its peak of memory (MB) as tracemalloc sees it."""
    studio = load_home(STUDIO)
    tracemalloc.start()
    start = time.perf_counter()
    try:
        with pytest.raises(EvaluationError) as e:
            load_scenarios(path, studio, studio, **kinds)
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()
    return str(e.value), seconds, peak


def test_a_bad_last_line_is_refused_in_memory_that_does_not_grow_with_the_file(tmp_path):
    small = _write(tmp_path / "small.csv", 1_000_000)
    big = _write(tmp_path / "big.csv", 12_000_000)
    lines = sum(1 for _ in big.open())
    said, _, small_peak = _refusal(small, corrections=True)
    assert said.endswith(
        "column activity: activity: unknown value 'dance'; expected one of work, relax, sleep"
    )
    said, seconds, big_peak = _refusal(big, corrections=True)
    assert said == f"{big}: line {lines}, column activity: " + DANCE
    # a row at a time kept every row made before the bad one: 12 MB of rows took over 250 MB
    assert big_peak < 40, big_peak
    assert big_peak < small_peak * 1.5 + 5, (small_peak, big_peak)
    assert seconds < 30, seconds


def _one_at_a_time(path: Path, **kinds: bool) -> str:
    """What reading a file a row at a time, as homecog always did, says."""
    studio = load_home(STUDIO)
    with text_lines(path, what="an event file", error=EvaluationError) as lines:
        reader = csv.DictReader(lines)
        try:
            _rows(
                path,
                reader,
                Space(studio),
                studio,
                studio,
                **{"events": False, "corrections": False, **kinds},
            )
        except csv.Error as e:
            return f"{path}: line {reader.line_num}: not CSV: {e}"
        except EvaluationError as e:
            return str(e)
    return "no error"


def _without_services(row: str) -> str:
    cells = row.rstrip("\n").split(",")[:7]
    cells[2] = cells[2] if cells[2].strip() not in ("", "unknown") else "5"
    return ",".join(cells) + "\n"


BROKEN = {
    "a value": ("2024-03-01T08:00:00,10:00,50,dance,off,off,off,,\n", {}),
    "a reading out of range": ("2024-03-01T08:00:00,10:00,-5,work,off,off,off,,\n", {}),
    "a device state": ("2024-03-01T08:00:00,10:00,50,work,half,off,off,,\n", {}),
    "a short row": ("2024-03-01T08:00:00,10:00,50,work,off,off\n", {}),
    "a long row": ("2024-03-01T08:00:00,10:00,50,work,off,off,off,,,x\n", {}),
    "a service": ("2024-03-01T08:00:00,10:00,50,work,off,off,off,Dance,\n", {}),
    "a user": ("2024-03-01T08:00:00,10:00,50,work,off,off,off,, \u200bkim\n", {}),
    "a timestamp": ("yesterday,10:00,50,work,off,off,off,,\n", {}),
    "a zone": ("2024-03-01T08:00:00+01:00,10:00,50,work,off,off,off,,\n", {}),
    "a quote never closed": ('2024-03-01T08:00:00,10:00,50,work,off,off,off,"LampOn,\n', {}),
    "a NUL byte": ("2024-03-01T08:00:00,10:00,50,work,off,off,off,,a\0b\n", {}),
    "a blank line, then a value": ("\n2024-03-01T08:00:00,10:00,50,dance,off,off,off,,\n", {}),
    "a quoted cell over two lines": ('2024-03-01T08:00:00,10:00,50,work,off,off,off,"Lamp\nOn",\n', {}),
    "a Windows line ending, then a value": ("2024-03-01T08:00:00,10:00,50,dance,off,off,off,,\r\n", {}),
    "a reading missing, no services": (
        "2024-03-01T08:00:00,10:00,unknown,work,off,off,off\n",
        {"header": "timestamp,time,light,activity,blind,desk_lamp,radio\n"},
    ),
}


@pytest.mark.parametrize("at", [5, _BATCH - 1, _BATCH + 3])
@pytest.mark.parametrize("case", sorted(BROKEN))
def test_a_bad_row_anywhere_says_what_a_row_at_a_time_said(tmp_path, case, at):
    bad, options = BROKEN[case]
    header = options.get("header", HEADER)
    rows = _good_rows(_BATCH + 40)
    if header != HEADER:
        rows = [_without_services(r) for r in rows]
    later = "2024-03-01T08:00:00,10:00,50,relax,off,off,off,,\n" if header == HEADER else rows[0]
    text = header + "".join(rows[:at]) + bad + "".join(rows[at : at + 30]) + later.replace("relax", "dance")
    path = tmp_path / "events.csv"
    path.write_text(text)
    kinds = {"events": True} if header != HEADER else {"corrections": True}
    expected = _one_at_a_time(path, **kinds)
    assert expected != "no error"
    with pytest.raises(EvaluationError) as e:
        load_scenarios(path, load_home(STUDIO), load_home(STUDIO), **kinds)
    assert str(e.value) == expected


def test_a_good_file_gives_the_scenarios_it_always_gave(tmp_path):
    """Every row as its own scenario: the context as written (stripped), its point, the truth
    (the services column, or the truth home's), its user and time."""
    studio = load_home(STUDIO)
    space = Space(studio)
    rows = _good_rows(3 * _BATCH + 17, seed=7)
    rows.insert(100, "\n")  # a blank line is no row
    rows.insert(5000, '2024-03-01T08:00:00,10:00,50,work,off,off,off,"LampOn;\nRadioOff",ann\n')
    path = tmp_path / "events.csv"
    path.write_text(HEADER + "".join(rows))
    got = load_scenarios(path, studio, studio, corrections=True)
    with path.open(newline="") as f:
        expected = list(csv.DictReader(f))
    assert len(got) == len(expected) == 3 * _BATCH + 18
    for scenario, row in zip(got, expected, strict=True):
        context = {name: row[name].strip() for name in space.names}
        assert scenario.context == context
        assert scenario.point == space.point(context)
        assert scenario.truth == frozenset(parse_services(row["services"].replace(";", ","), studio))
        assert scenario.user == (row["user"].strip() or None)
        assert scenario.timestamp is not None and scenario.timestamp.isoformat() == row["timestamp"]
    # without a services column the truth home decides, as ever
    plain = tmp_path / "scenarios.csv"
    plain.write_text(
        "time,light,activity,blind,desk_lamp,radio\n"
        + "".join(_without_services(r).split(",", 1)[1] for r in rows if r.strip())
    )
    for scenario in load_scenarios(plain, studio, studio)[:500]:
        assert (scenario.truth, scenario.choices) == truth_of(studio, scenario.point)
