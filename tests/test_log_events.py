"""``homecog log events``: a home's log of state changes as an event file — the ``log:`` section,
switch and quiet rows, presence, noisy and broken logs — and what rests on the same core: the
Home Assistant recorder's reader and van Kasteren's three houses."""

from __future__ import annotations

import csv
import json
import sqlite3
from datetime import datetime
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import HomeFileError, LogFileError
from homecog.evaluation.log_events import convert_log, read_log
from homecog.home import load_home, load_home_text
from homecog.home.scenario_file import load_scenarios

HOMES = Path(__file__).parent / "homes"
STUDIO_LOG = HOMES / "studio_log.yaml"
KASTEREN = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "kasteren"

# A morning in the studio: the user gets up (the bed mat), goes to the desk and works, the sun
# comes up; a log with every kind of noise a log has.
LOG = """timestamp,entity,state
2024-03-01T06:00:00,x10.blind,closed
2024-03-01T06:00:00,x10.lamp,off
2024-03-01T06:00:00,x10.radio,off
2024-03-01T06:00:00,sensor.lux,20
2024-03-01T06:00:00,activity,Sleeping
2024-03-01T06:00:00,mat_bed,on
2024-03-01T06:40:00,mat_bed,off
2024-03-01T06:41:00,pir_desk,on
2024-03-01T06:42:00,pir_desk,off
2024-03-01T06:42:00,activity,Working
2024-03-01T06:45:00,x10.lamp,on
2024-03-01T07:00:00,sensor.lux,250
2024-03-01T07:05:00,sensor.lux,300
2024-03-01T07:30:00,x10.blind,open
2024-03-01T07:31:00,x10.radio,on
2024-03-01T07:32:00,x10.radio,off
2024-03-01T07:33:00,x10.radio,maybe
2024-03-01T07:34:00,activity,Dancing
2024-03-01T07:35:00,sensor.lux,-5
2024-03-01T07:36:00,sensor.lux,bright
2024-03-01T07:37:00,sensor.co2,400
2024-03-01T07:37:00,sensor.co2,400
2024-03-01T08:00:00,activity,Relaxing
2024-03-01T07:45:00,x10.lamp,off
"""
HEADER = "timestamp,time,light,activity,location,blind,desk_lamp,radio,services"
EVENTS = [
    # the bed mat: the user is in bed (from unknown), with no switch within 10 minutes: quiet
    "2024-03-01T06:00:00,06:00,20,sleep,bed,off,off,off,",
    # a mat pressed longer than its hold says no more (until it is let go, 06:40)
    "2024-03-01T06:30:00,06:30,20,sleep,unknown,off,off,off,",
    # in bed again, at the desk and working (06:40, 06:41, 06:42): within 10 minutes of the
    # lamp, no quiet row
    "2024-03-01T06:45:00,06:45,20,work,desk,off,off,off,LampOn",  # the context before the switch
    "2024-03-01T07:00:00,07:00,250,work,desk,off,on,off,",  # bright now; 07:05 is the same bin
    # the desk's sensor went off at 06:42, its hold ends 30 minutes later; the bed's ended before
    "2024-03-01T07:12:00,07:12,300,work,unknown,off,on,off,",
    "2024-03-01T07:30:00,07:30,300,work,unknown,off,on,off,RaiseBlind",
    "2024-03-01T07:31:00,07:31,300,work,unknown,on,on,off,RadioOn",
    # 07:32 the radio off: no service does that; 07:45 came last in the log, sorted into place
    "2024-03-01T07:45:00,07:45,300,work,unknown,on,on,off,LampOff",
    "2024-03-01T08:00:00,08:00,300,relax,unknown,on,off,off,",
]


def _convert(tmp_path: Path, text: str, **options: object):
    log = tmp_path / "log.csv"
    log.write_text(text)
    return convert_log(load_home(STUDIO_LOG), log, tmp_path / "events.csv", **options)


def test_a_log_becomes_switch_and_quiet_rows(tmp_path: Path) -> None:
    result = _convert(tmp_path, LOG)
    assert (tmp_path / "events.csv").read_text().splitlines() == [HEADER, *EVENTS]
    assert (result.rows, result.switches, result.quiet, result.near_switch) == (9, 4, 5, 3)
    assert result.devices == {"blind": 1, "desk_lamp": 2, "radio": 1}
    assert result.skipped == {
        "unknown_entity": 1,
        "duplicate": 1,
        "unmapped_state": 2,  # the radio 'maybe', the activity 'Dancing'
        "out_of_range": 2,  # -5 lx, 'bright'
        "no_service": 1,
        "incomplete": 0,
        "excluded_user": 0,
    }
    assert (result.reordered, result.log_rows, result.unknown_entities) == (1, 24, {"sensor.co2": 1})
    home = load_home(STUDIO_LOG)
    rows = load_scenarios(tmp_path / "events.csv", home, home, events=True)
    assert [sorted(r.truth) for r in rows][:3] == [[], [], ["LampOn"]]


def test_quiet_minutes_decide_which_changes_are_rows(tmp_path: Path) -> None:
    """With no quiet minutes every change is a row; with an hour, none of these."""
    assert (_convert(tmp_path, LOG, quiet=0).quiet, _convert(tmp_path, LOG, quiet=60).quiet) == (8, 0)


def test_more_quiet_minutes_than_a_time_span_holds_are_no_quiet_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--quiet 1e308`` was an OverflowError's traceback."""
    log = tmp_path / "log.csv"
    log.write_text(LOG)
    for quiet in ("1e308", "inf"):
        argv = [
            "log",
            "events",
            "--home",
            str(STUDIO_LOG),
            "--log",
            str(log),
            "--out",
            str(tmp_path / "e.csv"),
        ]
        assert main([*argv, "--quiet", quiet, "--json"]) == 0
        out, err = capsys.readouterr()
        assert (json.loads(out)["quiet"], json.loads(out)["near_switch"], err) == (0, 8, "")


def test_a_reading_not_yet_known_is_unknown_a_device_not_yet_known_incomplete(tmp_path: Path) -> None:
    log = (
        "timestamp,entity,state,user\n"
        "2024-03-01T06:00:00,x10.blind,closed,\n2024-03-01T06:00:00,x10.lamp,off,\n"
        "2024-03-01T06:00:00,activity,Working,\n"
        "2024-03-01T06:00:10,x10.lamp,on,kim\n"  # the radio's state not known yet: incomplete
        "2024-03-01T06:00:20,x10.radio,off,\n"
        "2024-03-01T06:00:30,x10.lamp,off,kim\n"  # no light reading yet: unknown
        "2024-03-01T06:02:00,sensor.lux,50,\n"
        "2024-03-01T06:03:00,x10.lamp,on,robot\n"
        "2024-03-01T06:04:00,x10.blind,1,kim\n"
    )
    result = _convert(tmp_path, log, exclude_users=["robot"])
    assert (result.skipped["incomplete"], result.skipped["excluded_user"], result.switches) == (1, 1, 2)
    # the location never fired: unknown, which the feature has as a value; the light had no
    # reading at 06:00:30: unknown, a missing reading
    rows = (tmp_path / "events.csv").read_text().splitlines()[1:]
    assert rows == [
        "2024-03-01T06:00:30,06:00,unknown,work,unknown,off,on,off,LampOff",
        "2024-03-01T06:04:00,06:04,50,work,unknown,off,on,off,RaiseBlind",
    ]
    home = load_home(STUDIO_LOG)
    first, second = load_scenarios(tmp_path / "events.csv", home, home, events=True)
    light = home.feature_names.index("light")
    assert (first.point.missing, second.point.missing) == (frozenset({light}), frozenset())


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("timestamp,entity,state\n2024-03-01T06:00,x10.lamp,on\nyesterday,x10.lamp,off\n",
         "line 3, column timestamp: 'yesterday' is not an ISO 8601 time"),
        ("timestamp,entity\n2024-03-01T06:00,x10.lamp\n", "line 1: missing column(s) state"),
        ("timestamp,entity,state,room\n", "line 1: unknown column(s) room"),
        ("timestamp,entity,state,state\n2024-03-01T06:00,x10.lamp,on,off\n",
         "line 1: column(s) named twice: state"),
        ("timestamp,entity,state\n2024-03-01T06:00,x10.lamp\n", "line 2: expected 3 fields, got 2"),
        ("timestamp,entity,state\n2024-03-01T06:00,x10.lamp,on\n2024-03-01T06:01+01:00,x10.lamp,off\n",
         "line 3, column timestamp: has a time zone, unlike line 2's"),
        ("", "empty file; expected the header timestamp,entity,state[,user]"),
        ("timestamp,entity,state\n\n", "no rows after the header"),
        ("timestamp,entity,state\n2024-03-01T06:00,x10.lamp," + "x" * 200_000 + "\n",
         "line 2: not CSV: field larger than field limit (131072)"),
    ],
)  # fmt: skip
def test_a_broken_log_is_one_line_naming_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    log = tmp_path / "log.csv"
    log.write_text(text)
    code = main(
        ["log", "events", "--home", str(STUDIO_LOG), "--log", str(log), "--out", str(tmp_path / "e.csv")]
    )
    err = capsys.readouterr().err
    assert (code, err) == (2, f"homecog: error: {log}: {message}\n")
    assert not (tmp_path / "e.csv").exists()


def test_a_log_that_is_no_text_or_no_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "log.csv"
    log.write_bytes(b"timestamp,entity,state\n2024-03-01T06:00,x10.lamp,on\n2024-03-01T06:01,\xff,on\n")
    with pytest.raises(LogFileError, match=r"log.csv: line 3: not UTF-8 text$"):
        read_log(log)
    out = ["--out", str(tmp_path / "e.csv")]
    none = tmp_path / "none.csv"
    for args, message in [
        (["--home", str(STUDIO_LOG), "--log", str(none)], f"--log {none}: no such file"),
        (
            ["--home", "paper", "--log", str(log)],
            "paper.yaml: no log section; it maps a log's entities to the home's features and devices",
        ),
    ]:
        assert main(["log", "events", *args, *out]) == 2
        assert capsys.readouterr().err == f"homecog: error: {message}\n"


def test_the_summary_says_what_was_written_and_left_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "log.csv"
    log.write_text(LOG)
    args = ["log", "events", "--home", str(STUDIO_LOG), "--log", str(log), "--out", str(tmp_path / "e.csv")]
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert (data["rows"], data["switches"], data["quiet"], data["skipped"]["duplicate"]) == (9, 4, 5, 1)
    assert main(args) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == (
        f"wrote {tmp_path / 'e.csv'}: 9 rows, 4 switches (blind 1, desk_lamp 2, radio 1) and 5 quiet rows, "
        "from 24 log rows"
    )
    assert (
        lines[1] == "left out: unknown entity 1, duplicate 1, unmapped state 2, out of range 2, no service 1"
    )
    assert lines[2:5] == [
        "unknown entities: sensor.co2",
        "sorted: 1 rows came after a later one",
        "no quiet row: 3 changes within the quiet minutes of a switch",
    ]


# -- the section -----------------------------------------------------------------------------------
def _studio_with(log_section: str) -> str:
    text = STUDIO_LOG.read_text()
    return text[: text.index("log:")] + log_section


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ("log:\n  devices: {radio: x10.radio}\n  features: {light: a, activity: b, location: c}\n",
         "log.devices: no entity for blind, desk_lamp; every device needs one"),
        ("log:\n  features: {light: sensor.lux}\n",
         "log.features: no entity for activity, location; every feature but the clock needs one"),
        ("log:\n  features: {mood: sensor.mood}\n",
         "log.features.mood: unknown feature 'mood'; expected one of time, light, activity, location"),
        ("log:\n  quiet: -1\n", "log.quiet: expected minutes, a number from 0, got -1"),
        ("log:\n  colour: red\n", "log.colour: unknown key; expected one of features, devices, quiet"),
    ],
)  # fmt: skip
def test_the_section_is_checked_with_key_paths(section: str, message: str) -> None:
    with pytest.raises(HomeFileError) as e:
        load_home_text(_studio_with(section), "studio_log.yaml")
    assert str(e.value) == f"studio_log.yaml: {message}"


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("pir_desk: desk", "x10.lamp: desk"),
         "log.features.location.presence.x10.lamp: is the entity of device desk_lamp; "
         "a device the robot predicts may not say where the user is"),
        (("mat_bed: bed", "mat_bed: kitchen"),
         "log.features.location.presence.mat_bed: unknown value 'kitchen'; "
         "expected one of desk, bed, unknown"),
        (("hold: 30", "hold: 0"), "log.features.location.hold: expected minutes, a number above 0, got 0"),
        (("light: {entity: sensor.lux}", "light: {entity: sensor.lux, values: {x: dim}}"),
         "log.features.light.values: only categorical features map values; light is numeric"),
        (("Working: work", "Working: play"),
         "log.features.activity.values.Working: unknown value 'play'; expected one of work, relax, sleep"),
        (('on: [open, "1"]', 'on: [open, "0"]'), "log.devices.blind: state '0' is both on and off"),
        (("radio: {entity: x10.radio}", "radio: {on: [on]}"), "log.devices.radio: missing key 'entity'"),
    ],
)  # fmt: skip
def test_presence_values_and_words_are_checked(change: tuple[str, str], message: str) -> None:
    text = STUDIO_LOG.read_text().replace(*change)
    with pytest.raises(HomeFileError) as e:
        load_home_text(text, "studio_log.yaml")
    assert str(e.value) == f"studio_log.yaml: {message}"


def test_the_section_is_not_part_of_what_the_robot_learns() -> None:
    home = load_home(STUDIO_LOG)
    other = load_home_text(_studio_with("log:\n  quiet: 5\n  devices: {blind: b, desk_lamp: l, radio: r}\n"
                                        "  features: {light: x, activity: y, location: z}\n"))  # fmt: skip
    assert home.content_hash == other.content_hash and other.log.quiet == 5


# -- the Home Assistant recorder, through the same core -----------------------------------------------
def _recorder(path: Path) -> None:
    """The tables ``ha history`` reads, with a morning of the studio."""
    robot, kim, parent = bytes.fromhex("aa" * 16), bytes.fromhex("bb" * 16), bytes.fromhex("cc" * 16)
    t = 1_709_280_000.0
    entities = ["input_datetime.clock", "input_number.light", "input_select.activity", "cover.blind",
                "light.desk_lamp", "input_boolean.radio"]  # fmt: skip
    first = ["08:00", "100", "working", "closed", "off", "off"]
    rows = [(i, i, s, t, None, None, None) for i, s in enumerate(first, start=1)]
    rows += [
        (7, 6, "on", t + 60, 6, kim, None),  # Kim: RadioOn
        (8, 4, "open", t + 120, 4, robot, None),  # homecog
        (9, 6, "off", t + 180, 7, None, parent),  # an automation
        (10, 3, "relaxing", t + 240, 3, None, None),  # a change a minute after a switch
        (11, 2, "300", t + 4000, 2, None, None),  # bright, an hour from every switch
        (12, 5, "on", t + 8000, 5, None, None),  # a wall switch: LampOn
    ]
    with sqlite3.connect(path) as db:
        db.executescript(
            "CREATE TABLE schema_changes (change_id INTEGER PRIMARY KEY, schema_version INTEGER);"
            "CREATE TABLE states_meta (metadata_id INTEGER PRIMARY KEY, entity_id TEXT);"
            "CREATE TABLE state_attributes (attributes_id INTEGER PRIMARY KEY, shared_attrs TEXT);"
            "CREATE TABLE states (state_id INTEGER PRIMARY KEY, metadata_id INTEGER, state TEXT, "
            "last_updated_ts REAL, old_state_id INTEGER, attributes_id INTEGER, "
            "context_user_id_bin BLOB, context_parent_id_bin BLOB);"
            "INSERT INTO schema_changes VALUES (1, 42);"
        )
        db.executemany("INSERT INTO states_meta VALUES (?, ?)", list(enumerate(entities, start=1)))
        db.executemany(
            "INSERT INTO states VALUES (?, ?, ?, ?, ?, NULL, ?, ?)",
            [(sid, meta, state, ts, old, user, par) for sid, meta, state, ts, old, user, par in rows],
        )


def test_the_recorder_reader_makes_its_rows_through_the_core(tmp_path: Path) -> None:
    from homecog.evaluation.ha_history import read_history

    _recorder(tmp_path / "rec.db")
    home = load_home(HOMES / "studio_ha.yaml")

    def stamp(seconds: float) -> str:
        return (
            datetime.fromtimestamp(1_709_280_000.0 + seconds).astimezone().isoformat(timespec="milliseconds")
        )

    switches = [
        f"{stamp(60)},08:00,100,work,off,off,off,RadioOn",
        f"{stamp(8000)},08:00,300,relax,on,off,off,LampOn",
    ]
    plain = read_history(home, str(tmp_path / "rec.db"), tmp_path / "a.csv", exclude_users=("aa" * 16,))
    assert (tmp_path / "a.csv").read_text().splitlines()[1:] == switches
    assert (plain.events, plain.skipped["by_homecog"], plain.skipped["by_automation"], plain.quiet) == (
        2,
        1,
        1,
        None,
    )
    assert "quiet" not in plain.as_dict()
    quiet = read_history(
        home, str(tmp_path / "rec.db"), tmp_path / "q.csv", exclude_users=("aa" * 16,), quiet=10
    )
    assert (tmp_path / "q.csv").read_text().splitlines()[1:] == [
        switches[0], f"{stamp(4000)},08:00,300,relax,on,off,off,", switches[1]
    ]  # fmt: skip
    assert (quiet.events, quiet.quiet) == (2, 1)


# -- van Kasteren's houses -------------------------------------------------------------------------------
needs_kasteren = pytest.mark.skipif(not KASTEREN.is_dir(), reason=f"no real data at {KASTEREN}")


@needs_kasteren
@pytest.mark.parametrize(
    ("house", "devices", "log_rows", "switches", "quiet", "unknown"),
    [
        ("A", {"microwave": 60, "dishwasher": 38, "washing_machine": 24}, 2949, 122, 1109, 0),
        ("B", {"toaster": 59, "microwave": 49}, 26059, 108, 876, 947),
        ("C", {"microwave": 52}, 44304, 52, 1309, 0),
    ],
)
def test_each_house_becomes_a_home_a_log_and_events(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], house: str, devices: dict[str, int],
    log_rows: int, switches: int, quiet: int, unknown: int,
) -> None:  # fmt: skip
    assert main(["adapt-kasteren", str(KASTEREN), "--house", house, "--out", str(tmp_path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    done = data["conversion"]
    assert (data["log_rows"], done["switches"], done["quiet"], done["devices"]) == (
        log_rows,
        switches,
        quiet,
        devices,
    )
    assert {k: v for k, v in done["skipped"].items() if v} == ({"unknown_entity": unknown} if unknown else {})
    home = load_home(data["home"])
    assert len(home.services) == 2 * len(devices)
    rows = load_scenarios(Path(data["events"]), home, home, events=True)
    assert len(rows) == switches + quiet
    with Path(data["events"]).open() as f:
        table = list(csv.DictReader(f))
    assert [r["timestamp"] for r in table] == sorted(r["timestamp"] for r in table)
    for r in table:  # a switch always changes its device: TurnOn for one that is off
        for service in filter(None, r["services"].split(";")):
            device = next(
                d for d in devices if service.endswith("".join(p.capitalize() for p in d.split("_")))
            )
            assert r[device] == ("off" if service.startswith("TurnOn") else "on")
    assert {r["location"] for r in table} <= set(home.feature("location").values)


@needs_kasteren
def test_house_a_replays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["adapt-kasteren", str(KASTEREN), "--house", "A", "--out", str(tmp_path), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    args = ["replay", "--home", data["home"], "--events", data["events"], "--methods", "multi,frequency"]
    assert main([*args, "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["events"] == 1231 and set(result["multi_minus"]) == {"frequency"}
    assert all(0 < m["f1"] < 1 for m in result["methods"].values())


def test_a_broken_house_file_names_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "sensorMapA-ids.txt").write_text("1,Microwave,KitchHeat\r\n5,Hall-Toilet door,Toilet\r\n")
    (tmp_path / "actionMapA.txt").write_text("15,use-toilet\n")
    (tmp_path / "houseA-as.txt").write_text("25-Feb-2008 09:37:17\t25-Feb-2008 09:38:02\t15\n")
    (tmp_path / "houseA-ss.txt").write_text(
        "25-Feb-2008 09:36:43\t25-Feb-2008 09:37:04\t5\t\n25-Fbr-2008 09:37:20\t25-Feb-2008 09:37:23\t1\n"
    )
    assert main(["adapt-kasteren", str(tmp_path), "--house", "A", "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == (
        f"homecog: error: {tmp_path / 'houseA-ss.txt'}: line 2: '25-Fbr-2008 09:37:20' is not a time "
        "DD-Mon-YYYY HH:MM:SS of the years 1900 to 2100\n"
    )


def test_several_rooms_live_at_once_are_the_value_the_home_names_for_it(tmp_path: Path) -> None:
    text = STUDIO_LOG.read_text().replace(
        "values: [desk, bed, unknown]", "values: [desk, bed, both, unknown]"
    )
    text = text.replace("hold: 30}", "hold: 30, several: both}")
    home = load_home_text(text, "studio_several.yaml")
    log = tmp_path / "log.csv"
    log.write_text(
        "timestamp,entity,state\n"
        "2024-03-01T06:00:00,x10.blind,closed\n2024-03-01T06:00:00,x10.lamp,off\n"
        "2024-03-01T06:00:00,x10.radio,off\n2024-03-01T06:00:00,sensor.lux,20\n"
        "2024-03-01T06:00:00,activity,Sleeping\n2024-03-01T06:00:00,mat_bed,on\n"
        "2024-03-01T06:20:00,pir_desk,on\n"  # someone at the desk while someone is in bed
        "2024-03-01T06:30:00,mat_bed,off\n"  # the bed's hold runs on 30 minutes: still both
        "2024-03-01T06:45:00,pir_desk,on\n"  # motion again: the desk holds until 07:15
        "2024-03-01T07:05:00,x10.radio,on\n"  # the bed's hold ended at 07:00: the desk alone
    )
    convert_log(home, log, tmp_path / "events.csv", quiet=0)
    locations = [line.split(",")[4] for line in (tmp_path / "events.csv").read_text().splitlines()[1:]]
    assert locations == ["bed", "both", "desk", "desk"]  # 06:00, 06:20, 07:00, the radio at 07:05
    wrong = text.replace("several: both", "several: hall")
    with pytest.raises(HomeFileError, match=r"log\.features\.location\.several: unknown value 'hall'"):
        load_home_text(wrong, "studio_several.yaml")


def test_a_long_bad_cell_is_not_echoed_back_whole(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "log.csv"
    log.write_text("timestamp,entity,state\n" + "9" * 100_000 + ",x10.lamp,on\n")
    out = tmp_path / "e.csv"
    assert main(["log", "events", "--home", str(STUDIO_LOG), "--log", str(log), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"homecog: error: {log}: line 2, column timestamp: '999")
    assert err.endswith("…\n") and len(err) == len("homecog: error: ") + 1000 + 1


@needs_kasteren
@pytest.mark.parametrize("name", ["../../escaped", "a/b", ""])
def test_a_house_name_is_never_a_path(tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str) -> None:
    """``--name ../../escaped`` wrote the home file and the log two folders above ``--out``."""
    out = tmp_path / "a" / "b"
    assert main(["adapt-kasteren", str(KASTEREN), "--out", str(out), "--name", name]) == 2
    rule = "1 to 64 letters, digits, _ or -, beginning with a letter or digit"
    assert capsys.readouterr() == ("", f"homecog: error: --name: {name!r} is not a home name: {rule}\n")
    assert list(tmp_path.rglob("*.*")) == []
