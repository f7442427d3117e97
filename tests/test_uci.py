"""The UCI occupancy office as a home and events: the light's switches found in its illuminance."""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import pytest

from homecog.errors import RealDataError
from homecog.evaluation import uci
from homecog.home import load_home
from homecog.home.scenario_file import load_scenarios

DATA = Path(__file__).resolve().parents[2] / "shared" / "realdata" / "uci-occupancy"
HEADER = '"date","Temperature","Humidity","Light","CO2","HumidityRatio","Occupancy"'


def minutes(values: list[float], start: int = 0) -> list[tuple[object, float]]:
    return [(start + k, v) for k, v in enumerate(values)]


def test_a_step_is_a_switch_and_daylight_is_not():
    daylight = [100.0 + 10 * k for k in range(40)]  # 100 → 490 lx over 40 minutes: no switch
    assert uci.step_switches(minutes(daylight)) == []
    office = [0.0, 0.0, 260.0, 430.0, 440.0, 420.0, 200.0, 20.0]  # on over two minutes, off likewise
    assert uci.step_switches(minutes(office)) == [(3, True), (7, False)]
    # a gap in the data: the reading before it is not within the window
    gap = [(0, 0.0), (60, 450.0), (61, 460.0)]
    assert uci.step_switches(gap) == []
    assert uci.step_switches(minutes([500.0, 510.0, 30.0])) == [(2, False)]  # on from the start


def write_files(folder: Path, rows: list[tuple[datetime, float, int]]) -> None:
    folder.mkdir()
    lines = [HEADER] + [
        f'"{k}","{at:%Y-%m-%d %H:%M:%S}",21,27,{lux},700,0.004,{o}' for k, (at, lux, o) in enumerate(rows)
    ]
    third = len(lines) // 3
    parts = [lines[1 : 1 + third], lines[1 + third : 1 + 2 * third], lines[1 + 2 * third :]]
    for name, part in zip(uci.FILES, parts, strict=True):
        (folder / name).write_text("\n".join([HEADER, *part]) + "\n")


def test_a_small_office_becomes_a_home_and_events(tmp_path):
    start = datetime(2015, 2, 2, 7, 0)
    rows = []
    for k in range(300):  # 07:00 to 12:00: in at 08:00 with the light, out at 11:00 without it
        at = start + timedelta(minutes=k)
        occupied = int(60 <= k < 240)
        rows.append((at, 430.0 if 61 <= k < 270 else 5.0, occupied))
    write_files(tmp_path / "uci", rows)
    office = uci.convert(tmp_path / "uci", tmp_path / "out")
    assert (office.minutes, office.switches) == (300, 2)
    home = load_home(office.home)
    events = load_scenarios(office.events, home, home, events=True)
    # came in at 08:00 and switched the light on a minute later: a switch, and no quiet row
    # (within 10 minutes of it); left at 11:00 with the light on: a quiet moment
    assert [(f"{e.timestamp:%H:%M}", e.context["occupancy"], sorted(e.truth)) for e in events] == [
        ("08:01", "present", ["TurnOnCeilingLight"]),
        ("11:00", "absent", []),
        ("11:30", "absent", ["TurnOffCeilingLight"]),
    ]


def test_a_bad_row_names_the_file_and_line(tmp_path):
    write_files(tmp_path / "uci", [(datetime(2015, 2, 2, 7, k), 5.0, 0) for k in range(9)])
    path = tmp_path / "uci" / uci.FILES[1]
    lines = path.read_text().splitlines()
    lines[2] = lines[2].replace("2015-02-02", "yesterday")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RealDataError, match=rf"^{path}: line 3: expected a time, an illuminance"):
        uci.convert(tmp_path / "uci", tmp_path / "out")


@pytest.mark.skipif(not DATA.is_dir(), reason=f"no real data at {DATA}")
def test_the_real_office(tmp_path):
    office = uci.convert(DATA, tmp_path)
    assert (office.minutes, office.switches) == (20_560, 34)
    assert (office.result.switches, office.result.quiet) == (34, 60)
    home = load_home(office.home)
    assert home.service_names == ("TurnOnCeilingLight", "TurnOffCeilingLight")
