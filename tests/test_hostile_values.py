"""Values a hostile file carries: numbers past any sane size, dates that are none, time zones
mixed in one file. Each is one line naming the file and where in it, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import HomeFileError
from homecog.home import load_home_text
from homecog.home.clock import clock_hours

HOMES = Path(__file__).parent / "homes"
STUDIO = (HOMES / "studio.yaml").read_text()
BIG = "9" * 5000  # past Python's 4,300 digits of text to integer, and a float's range
RANGE = "is out of range; a home file's numbers lie within ±1e15"


def run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def one_line(capsys, args: list[str], expected: str) -> None:
    """The command fails with exactly ``expected`` as its one line."""
    assert run(capsys, *args) == (2, "", f"homecog: error: {expected}\n")


# -- 1. numbers in a home file -------------------------------------------------------------------
FIVE_THOUSAND = "99999999999999999999… (5,000 characters)"
HOUSEHOLD = "household: {{{}}}\nprohibited:"


@pytest.mark.parametrize(
    ("old", "new", "path", "shown"),
    [
        ("[200, .inf]", f"[200, {BIG}]", "context.light.bins.bright[1]", FIVE_THOUSAND),
        (
            "[200, .inf]",
            f"[200, -{BIG}]",
            "context.light.bins.bright[1]",
            "-9999999999999999999… (5,001 characters)",
        ),
        (
            "[0, 200]",
            f"[0, 0x{'f' * 3000}]",
            "context.light.bins.dim[1]",
            "0xffffffffffffffffff… (3,002 characters)",
        ),
        (
            "[0, 200]",
            f"[0, {BIG[:400]}]",
            "context.light.bins.dim[1]",
            "99999999999999999999… (400 characters)",
        ),
        ("[0, 200]", "[0, 10000000000000000]", "context.light.bins.dim[1]", "10000000000000000"),
        ("[0, 200]", "[0, 1.0e+400]", "context.light.bins.dim[1]", "1.0e+400"),
        ("[0, 200]", "[0, !!float 1e400]", "context.light.bins.dim[1]", "1e400"),
        ("[0, 200]", '[0, "1e400"]', "context.light.bins.dim[1]", "1e400"),
        ("[0, 200]", f'[0, "{BIG}"]', "context.light.bins.dim[1]", FIVE_THOUSAND),
        ("unit: lx", f"unit: lx\n    deadband: {BIG}", "context.light.deadband", FIVE_THOUSAND),
        (
            "radio: {room: studio}",
            f"radio: {{room: studio, min_on: {BIG}}}",
            "devices.radio.min_on",
            FIVE_THOUSAND,
        ),
        ("prohibited:", f"rewards: {{magnitude: {BIG}}}\nprohibited:", "rewards.magnitude", FIVE_THOUSAND),
        ("prohibited:", "rewards: {magnitude: 1e999}\nprohibited:", "rewards.magnitude", "1e999"),
        ("prohibited:", HOUSEHOLD.format(f"users: [ann], hold: {BIG}"), "household.hold", FIVE_THOUSAND),
        (
            "prohibited:",
            HOUSEHOLD.format(f"{BIG[:900]}: 1"),
            f"household.{'9' * 40}",
            "99999999999999999999… (900 characters)",
        ),
    ],
)
def test_a_number_past_any_sane_size_is_refused_naming_its_key_path(old, new, path, shown):
    """A 5,000-digit integer anywhere in a home file was a traceback: Python's limit on text to
    integer (4,300 digits) in the YAML reader, or ``OverflowError`` making it a float."""
    assert old in STUDIO
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO.replace(old, new, 1), "evil.yaml")
    assert str(e.value) == f"evil.yaml: {path}: number {shown} {RANGE}"


@pytest.mark.parametrize(
    ("new", "why"),
    [
        (HOUSEHOLD.format("since: 2024-13-01"), "household.since: '2024-13-01' is not a date"),
        (HOUSEHOLD.format("since: 0000-01-01"), "household.since: '0000-01-01' is not a date"),
        (
            HOUSEHOLD.format("since: 2024-01-01 99:00:00"),
            "household.since: '2024-01-01 99:00:00' is not a date",
        ),
    ],
)
def test_a_date_that_is_none_is_refused_naming_its_key_path(new, why):
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO.replace("prohibited:", new, 1), "evil.yaml")
    assert str(e.value) == f"evil.yaml: {why}"


def test_a_huge_clock_time_is_not_a_time_and_not_echoed_whole():
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO.replace('["06:30", "19:00"]', f'["06:30", "{BIG}:00"]', 1), "evil.yaml")
    quoted = repr(BIG[:40] + "…")
    assert (
        str(e.value) == f'evil.yaml: context.time.bins.day[1]: expected hours (7.5 or "07:30"), got {quoted}'
    )
    with pytest.raises(ValueError, match="not a time"):
        clock_hours(BIG[:400] + ":00")


def test_sane_numbers_and_infinities_still_load():
    home = load_home_text(
        STUDIO.replace("[0, 200]", "[-1_000, 999_999_999_999_999.0]").replace(
            "bright: [200, .inf]", "bright: [999_999_999_999_999.0, .inf]"
        ),
        "fine.yaml",
    )
    assert home.name == "studio"


def test_the_command_line_names_the_field(capsys, tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text(STUDIO.replace("[200, .inf]", f"[200, {BIG}]"))
    one_line(
        capsys,
        ["home", "check", str(path)],
        f"{path}: context.light.bins.bright[1]: number 99999999999999999999… (5,000 characters) {RANGE}",
    )


# -- 2. time zones mixed in an event file ---------------------------------------------------------
HEADER = "timestamp,time,light,activity,blind,desk_lamp,radio,services"


def mixed_events(path: Path, first: str, second: str) -> Path:
    path.write_text(
        f"{HEADER}\n{first},07:02,50,work,off,off,off,LampOn\n"
        "2024-03-01T07:20:00,07:20,50,work,off,on,off,\n"
        f"{second},07:30,50,relax,off,on,off,RadioOn\n"
    )
    return path


@pytest.mark.parametrize(
    ("first", "second", "why"),
    [
        (
            "2024-03-01T07:02:00",
            "2024-03-01T07:30:00+01:00",
            "line 4, column timestamp: has a time zone, unlike line 2's",
        ),
        (
            "2024-03-01T07:02:00Z",
            "2024-03-01T07:30:00+01:00",
            "line 3, column timestamp: has no time zone, unlike line 2's",
        ),
    ],
)
def test_an_event_file_mixing_time_zones_is_refused_naming_the_line(capsys, tmp_path, first, second, why):
    """Timestamps with and without a time zone cannot be compared: ``TypeError`` from the
    stream's ordering, a traceback, in ``replay`` and ``correct --events``."""
    path = mixed_events(tmp_path / "events.csv", first, second)
    db = tmp_path / "k.sqlite"
    for command in (
        ["replay", "--events", str(path)],
        ["correct", "--events", str(path), "--db", f"sqlite:///{db}"],
    ):
        one_line(capsys, [*command, "--home", str(HOMES / "studio.yaml")], f"{path}: {why}")
    assert not db.exists()  # refused before the store was opened


def test_an_event_file_all_with_time_zones_is_read(tmp_path, studio):
    from homecog.home.scenario_file import load_scenarios

    path = mixed_events(tmp_path / "events.csv", "2024-03-01T07:02:00+01:00", "2024-03-01T07:30:00Z")
    path.write_text(path.read_text().replace("07:20:00,", "07:20:00+01:00,"))
    rows = load_scenarios(path, studio, studio, events=True)
    assert [r.timestamp.utcoffset().total_seconds() for r in rows] == [3600, 3600, 0]


# -- 3. absurd dates in the real data sets -----------------------------------------------------------
OF_YEARS = "of the years 1900 to 2100"


def mit_folder(folder: Path, head: str, on: str = "17:39:37") -> Path:
    """A subject's folder of one activity (``head``: NAME,DATE,START,END) and one firing."""
    folder.mkdir()
    (folder / "sensors.csv").write_text("101,Bathroom,Light switch\n103,Kitchen,Cabinet\n")
    (folder / "activities_data.csv").write_text(f"{head}\n101\nLight switch\n{on}\n17:40:00\n")
    return folder


@pytest.mark.parametrize(
    ("head", "on", "why"),
    [
        (
            "Toileting,4/1/0,17:30:36,17:46:41",
            "17:39:37",
            f"line 1: '4/1/0' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            "Toileting,4/1/99999,17:30:36,17:46:41",
            "17:39:37",
            f"line 1: '4/1/99999' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            "Toileting,12/31/9999,23:30:36,00:46:41",
            "17:39:37",
            f"line 1: '12/31/9999' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            "Toileting,13/1/2003,17:30:36,17:46:41",
            "17:39:37",
            f"line 1: '13/1/2003' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            "Toileting,4/99999999999/2003,17:30:36,17:46:41",
            "17:39:37",
            f"line 1: '4/99999999999/2003' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            f"Toileting,4/1/{BIG},17:30:36,17:46:41",
            "17:39:37",
            f"line 1: '4/1/{'9' * 36}…' is not a date M/D/YYYY {OF_YEARS}",
        ),
        (
            "Toileting,4/1/2003,99999999999:30:36,17:46:41",
            "17:39:37",
            "line 1: '99999999999:30:36' is not a time H:M:S",
        ),
        ("Toileting,4/1/2003,17:30:36,17:46:41", "17:99:37", "line 4: '17:99:37' is not a time H:M:S"),
    ],
)
def test_an_absurd_date_of_the_mit_data_names_file_and_line(capsys, tmp_path, head, on, why):
    """Year 9999 with a time past midnight, a 12-digit day or a 12-digit hour overflowed
    ``datetime`` (``OverflowError``, a traceback)."""
    folder = mit_folder(tmp_path / "subject9", head, on)
    one_line(
        capsys,
        ["adapt-mit", str(folder), "--out", str(tmp_path / "out")],
        f"{folder / 'activities_data.csv'}: {why}",
    )
    assert not list(tmp_path.glob("out/*"))  # nothing written


def test_mit_activities_over_centuries_are_refused_before_any_reading(capsys, tmp_path):
    """Readings every 10 minutes of two centuries: ten million of them."""
    folder = mit_folder(tmp_path / "subject9", "Toileting,4/1/1900,17:30:36,17:46:41")
    with (folder / "activities_data.csv").open("a") as f:
        f.write("Toileting,4/1/2100,17:30:36,17:46:41\n101\nLight switch\n17:39:37\n17:40:00\n")
    one_line(
        capsys,
        ["adapt-mit", str(folder), "--out", str(tmp_path / "out")],
        f"{folder / 'activities_data.csv'}: the activities span 73,049 days, 1900-04-01 to 2100-04-01; "
        "a data set may span at most 366",
    )


def kasteren_folder(folder: Path, start: str, end: str) -> Path:
    folder.mkdir()
    (folder / "sensorMapA-ids.txt").write_text("1,Microwave,KitchHeat\n7,Cups cupboard,Kitchen\n")
    (folder / "actionMapA.txt").write_text("15,use-toilet\n")
    (folder / "houseA-as.txt").write_text(
        f"25-Feb-2008 09:37:17\t25-Feb-2008 09:38:02\t15\n{start}\t{end}\t15\n"
    )
    (folder / "houseA-ss.txt").write_text("25-Feb-2008 09:37:20\t25-Feb-2008 09:37:23\t1\n")
    return folder


@pytest.mark.parametrize(
    ("start", "end", "why"),
    [
        (
            "25-Feb-0 09:37:17",
            "25-Feb-2008 09:38:02",
            f"line 2: '25-Feb-0 09:37:17' is not a time DD-Mon-YYYY HH:MM:SS {OF_YEARS}",
        ),
        (
            "31-Dec-9999 23:50:00",
            "31-Dec-9999 23:59:59",
            f"line 2: '31-Dec-9999 23:50:00' is not a time DD-Mon-YYYY HH:MM:SS {OF_YEARS}",
        ),
        (
            "25-Feb-99999999999999999999 09:37:17",
            "25-Feb-2008 09:38:02",
            f"line 2: '25-Feb-99999999999999999999 09:37:17' is not a time DD-Mon-YYYY HH:MM:SS {OF_YEARS}",
        ),
        (
            "25-Feb-2008 99999999999999999999:37:17",
            "25-Feb-2008 09:38:02",
            f"line 2: '25-Feb-2008 99999999999999999999:37:17' is not a time DD-Mon-YYYY HH:MM:SS {OF_YEARS}",
        ),
        (
            "25-Mon-2008 09:37:17",
            "25-Feb-2008 09:38:02",
            f"line 2: '25-Mon-2008 09:37:17' is not a time DD-Mon-YYYY HH:MM:SS {OF_YEARS}",
        ),
        (
            "25-Feb-1900 09:37:17",
            "25-Feb-2100 09:38:02",
            "the activities span 73,049 days, 1900-02-25 to 2100-02-25; a data set may span at most 366",
        ),
    ],
)
def test_an_absurd_date_of_a_kasteren_house_names_file_and_line(capsys, tmp_path, start, end, why):
    """A 20-digit year or hour overflowed ``datetime`` (``OverflowError``, a traceback)."""
    folder = kasteren_folder(tmp_path / "house", start, end)
    args = ["adapt-kasteren", str(folder), "--house", "A", "--out", str(tmp_path / "out")]
    one_line(capsys, args, f"{folder / 'houseA-as.txt'}: {why}")
    assert not list(tmp_path.glob("out/*"))  # nothing written
