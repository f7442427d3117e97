"""The adapter of the MIT home-activity data: a home file and an event file that homecog reads."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from homecog.cli.main import main
from homecog.errors import RealDataError
from homecog.evaluation.evaluate import load_scenarios
from homecog.evaluation.mit import read_activities
from homecog.home import load_home

DATA = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "mit-home-activity"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason=f"no real data at {DATA}")


@pytest.mark.parametrize(("subject", "events", "devices"), [("subject1", 994, 10), ("subject2", 1096, 11)])
def test_subject_becomes_a_home_and_events(tmp_path, capsys, subject, events, devices):
    assert main(["adapt-mit", str(DATA / subject), "--out", str(tmp_path), "--json"]) == 0
    capsys.readouterr()
    home = load_home(tmp_path / f"mit_{subject}.yaml")
    assert len(home.devices) == devices
    assert len(home.services) == 2 * devices
    rows = load_scenarios(tmp_path / f"mit_{subject}-events.csv", home, home, events=True)
    assert len(rows) == events
    with (tmp_path / f"mit_{subject}-events.csv").open() as f:
        table = list(csv.DictReader(f))
    stamps = [r["timestamp"] for r in table]
    assert stamps == sorted(stamps)  # replayed in the order it happened
    assert any(r["services"] for r in table)
    # a wanted switch always changes its device: TurnOn only for a device that is off
    for r in table:
        for service in filter(None, r["services"].split(";")):
            device = next(
                d.name
                for d in home.devices
                if service.endswith("".join(p.capitalize() for p in d.name.split("_")))
            )
            assert r[device] == ("off" if service.startswith("TurnOn") else "on")
    # the clear-sky illumination is dark at night and bright at midday
    night = [float(r["illumination"]) for r in table if r["time"] < "04:00"]
    noon = [float(r["illumination"]) for r in table if "11:30" <= r["time"] <= "13:30"]
    assert night and max(night) == 0.0
    assert noon and min(noon) > 10_000


def test_the_first_activity_of_subject1():
    first = sorted(read_activities(DATA / "subject1" / "activities_data.csv"), key=lambda a: a.start)[0]
    assert first.start.isoformat().startswith("2003-03-27")


def test_broken_data_names_file_and_line(tmp_path, capsys):
    (tmp_path / "sensors.csv").write_text("101,Bathroom,Light switch\n")
    (tmp_path / "activities_data.csv").write_text(
        "Toileting,4/1/2003,17:30:36,17:46:41\n101\nLight switch\n17:39:37\n"
    )
    with pytest.raises(RealDataError, match="4 lines; expected blocks of 5 lines"):
        read_activities(tmp_path / "activities_data.csv")
    (tmp_path / "activities_data.csv").write_text(
        "Toileting,4/x/2003,17:30:36,17:46:41\n101\nLight switch\n17:39:37\n17:40:00\n"
    )
    code = main(["adapt-mit", str(tmp_path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert "activities_data.csv: line 1: '4/x/2003' is not a date M/D/YYYY" in err and err.count("\n") == 1


def test_location_comes_from_the_other_sensors_never_the_devices(tmp_path):
    """The light switched during an activity is what the robot predicts: it must not say where
    the user is. Location is the room of the last other sensor activated, held 30 minutes."""
    from homecog.evaluation.mit import convert

    folder = tmp_path / "subject9"
    folder.mkdir()
    (folder / "sensors.csv").write_text(
        "101,Bathroom,Light switch\n102,Bathroom,Exhaust fan\n103,Kitchen,Cabinet\n104,Kitchen,Light switch\n"
    )
    blocks = [
        # the bathroom's devices fire three times, then the kitchen's cabinet once (17:34)
        ("Toileting,4/1/2003,17:30:00,17:50:00", ["101", "102", "101", "103"]),
        # only devices fire: where the user is is not known
        ("Toileting,4/2/2003,17:30:00,17:50:00", ["101", "102"]),
        # no device at all; the cabinet fires after the activity, past the log's end
        ("Preparing lunch,4/3/2003,12:00:00,12:20:00", ["103"]),
    ]
    lines = []
    for head, ids in blocks:
        on = [f"{head.split(',')[2][:3]}{31 + k}:00" for k in range(len(ids))]
        off = [f"{head.split(',')[2][:3]}{31 + k}:30" for k in range(len(ids))]
        lines += [head, ",".join(ids), ",".join("x" for _ in ids), ",".join(on), ",".join(off)]
    (folder / "activities_data.csv").write_text("\n".join(lines) + "\n")
    _, events, n = convert(folder, tmp_path / "out")
    with events.open() as f:
        table = list(csv.DictReader(f))
    assert n == len(table) == 21
    switches = [(r["timestamp"][5:16], r["location"], r["services"]) for r in table if r["services"]]
    on, off = "TurnOnLightBathroom", "TurnOffLightBathroom"
    fan_on, fan_off = "TurnOnFanBathroom", "TurnOffFanBathroom"
    first = [("31", on), ("31", off), ("32", fan_on), ("32", fan_off), ("33", on), ("33", off)]
    assert switches == [
        *[(f"04-01T17:{m}", "unknown", s) for m, s in first],
        *[(f"04-02T17:{m}", "unknown", s) for m, s in first[:4]],
    ]
    # the cabinet (17:34) came within 10 minutes of a switch: no quiet row then; at the
    # activity's end the user is still in the kitchen, until the cabinet's 30 minutes are over
    quiet = [(r["timestamp"][5:16], r["location"], r["behavior"]) for r in table if not r["services"]]
    assert quiet[:2] == [("04-01T17:50", "kitchen", "idle"), ("04-01T18:04", "unknown", "idle")]
    assert ("04-03T12:00", "unknown", "cooking") in quiet


@pytest.mark.parametrize("name", ["../../escaped", "/tmp/x", "<b>x</b>", ""])
def test_a_name_is_never_a_path(tmp_path, capsys, name):
    """``--name ../../escaped`` wrote the home file and the log two folders above ``--out``;
    ``<b>x</b>`` (a slash) was a traceback."""
    out = tmp_path / "a" / "b"
    assert main(["adapt-mit", str(DATA / "subject1"), "--out", str(out), "--name", name]) == 2
    rule = "1 to 64 letters, digits, _ or -, beginning with a letter or digit"
    assert capsys.readouterr() == ("", f"homecog: error: --name: {name!r} is not a home name: {rule}\n")
    assert list(tmp_path.rglob("*.*")) == [] and not Path("/tmp/x.yaml").exists()
