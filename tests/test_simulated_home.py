"""The simulated home: a user routine, typical-year weather, devices switched by the
robot and by the user, every snapshot a valid context of the home."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

import pytest
from pvlib.iotools import read_tmy3

from homecog.context import ContextSource
from homecog.context.simulated import SimulatedHome
from homecog.context.weather import tmy_path
from homecog.errors import ContextError, HomeFileError
from homecog.home import Home, load_home_text
from homecog.home.codec import Space
from homecog.home.routine import Routine

HOMES = Path(__file__).parent / "homes"
STUDIO_TEXT = (HOMES / "studio.yaml").read_text(encoding="utf-8")


def _day(sim: SimulatedHome, step_minutes: int = 10) -> list[dict[str, str]]:
    out = []
    for _ in range(24 * 60 // step_minutes):
        out.append(sim.snapshot())
        sim.advance(step_minutes * 60)
    return out


@pytest.mark.parametrize("name", ["paper", "studio"])
def test_every_snapshot_of_a_day_is_a_valid_context(name: str, paper: Home, studio: Home) -> None:
    home = paper if name == "paper" else studio
    sim = SimulatedHome(home, start="2021-01-15 00:00")  # winter: cold, short days
    space = Space(home)
    names = set(home.feature_names) | set(home.device_names)
    for snapshot in _day(sim):
        assert set(snapshot) == names
        assert all(isinstance(v, str) for v in snapshot.values())
        space.point(snapshot)  # raises on anything out of place
        home.discretize(snapshot)
    assert sim.now == datetime(2021, 1, 16, 0, 0)


def test_snapshot_text_is_as_a_scenario_file(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-17 07:00")
    source: ContextSource = sim  # the protocol the running system takes
    s = source.snapshot()
    assert s["time"] == "07:00"
    float(s["temperature"]), float(s["illumination"])
    assert all(s[d] in ("on", "off") for d in paper.device_names)


def test_paper_routine_parsed_and_content_hash_unchanged(paper: Home) -> None:
    assert isinstance(paper.routine, Routine)
    assert len(paper.routine.steps) >= 10
    # the routine is no part of what the knowledge was learned from
    assert paper.content_hash == "eb7f010f19e72c72442cb71558a96083550536602d4246ba029698f1850eaefd"


def test_paper_user_is_asleep_in_bed_at_seven(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-03-02 06:00")
    sim.advance(3600)
    s = sim.snapshot()
    assert (s["time"], s["location"], s["posture"], s["behavior"]) == ("07:00", "bed", "lie", "sleep")


def test_paper_day_visits_every_behavior(paper: Home) -> None:
    behaviors = {s["behavior"] for s in _day(SimulatedHome(paper))}
    assert behaviors == {"read", "watch_tv", "sleep", "eat"}


def test_routine_wraps_midnight(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-01 23:50")
    before = sim.snapshot()
    sim.advance(20 * 60)
    after = sim.snapshot()
    assert sim.now == datetime(2021, 6, 2, 0, 10)
    assert after["time"] == "00:10"
    for f in ("location", "posture", "behavior"):
        assert before[f] == after[f]
    assert after["behavior"] == "sleep"
    # and the first step of the day takes over the last one's values it leaves out
    home = load_home_text(
        STUDIO_TEXT + 'routine:\n  - {at: "08:00", activity: work}\n  - {at: "23:00"}\n', "studio.yaml"
    )
    assert home.routine.values_at(23.5) == {"activity": "work"}


def test_temperature_follows_the_tmy_file(paper: Home) -> None:
    data, _ = read_tmy3(tmy_path(), coerce_year=2001, map_variables=True)
    for when in (datetime(2001, 1, 10, 6), datetime(2001, 7, 20, 15), datetime(2001, 10, 3, 11)):
        expected = float(data.loc[data.index.tz_localize(None) == when, "temp_air"].iloc[0])
        sim = SimulatedHome(paper, start=when)
        assert float(sim.snapshot()["temperature"]) == pytest.approx(expected, abs=1.0)
    # between two hours it is interpolated
    sim = SimulatedHome(paper, start="2001-07-20 15:30")
    at = [
        float(data.loc[data.index.tz_localize(None) == datetime(2001, 7, 20, h), "temp_air"].iloc[0])
        for h in (15, 16)
    ]
    assert float(sim.snapshot()["temperature"]) == pytest.approx(sum(at) / 2, abs=1.0)


def test_illumination_daylight_with_the_curtain_open(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-17 00:00")
    for d in paper.device_names:
        sim.switch(d, False)
    sim.switch("curtain", True)
    midnight = float(sim.snapshot()["illumination"])
    sim.advance(12 * 3600)
    for d in paper.device_names:  # undo whatever the user switched on the way
        sim.switch(d, d == "curtain")
    noon = float(sim.snapshot()["illumination"])
    assert midnight < 100 < 550 < noon
    sim.switch("curtain", False)
    assert float(sim.snapshot()["illumination"]) < noon / 4
    sim.switch("ceiling_light", True)
    assert float(sim.snapshot()["illumination"]) > 300


def test_robot_switch_changes_the_device(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-17 10:00")
    sim.switch("window", True)
    assert sim.snapshot()["window"] == "on"
    sim.advance(600)
    assert sim.snapshot()["window"] == "on"  # devices keep their state
    sim.switch("window", False)
    assert sim.snapshot()["window"] == "off"
    with pytest.raises(ContextError, match="unknown device 'toaster'"):
        sim.switch("toaster", True)


def test_user_routine_switches_a_device_at_its_step(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-17 15:00")
    sim.switch("lamp", False)
    sim.advance(29 * 60)
    assert sim.snapshot()["lamp"] == "off"
    sim.advance(60)  # 15:30: reading at the table, the lamp on
    s = sim.snapshot()
    assert (s["time"], s["behavior"], s["lamp"]) == ("15:30", "read", "on")
    sim.advance(3 * 3600)  # 18:30: the user switched it off at 18:00
    assert sim.snapshot()["lamp"] == "off"


def test_manual_mode_overrides_until_resume(paper: Home) -> None:
    sim = SimulatedHome(paper, start="2021-06-17 07:00")
    sim.set_context({"temperature": 31, "behavior": "watch_tv", "tv_living": "on"})
    assert sim.manual
    sim.advance(300)
    s = sim.snapshot()
    assert (s["temperature"], s["behavior"], s["tv_living"]) == ("31", "watch_tv", "on")
    sim.resume()
    s = sim.snapshot()
    assert not sim.manual and s["behavior"] == "sleep" and s["temperature"] != "31"
    assert s["tv_living"] == "on"
    with pytest.raises(ContextError, match="unknown feature or device 'mood'"):
        sim.set_context({"mood": "happy"})
    with pytest.raises(ContextError, match="behavior: unknown value 'nap'"):
        sim.set_context({"behavior": "nap"})
    with pytest.raises(ContextError, match="illumination: -5 lx is outside every bin"):
        sim.set_context({"illumination": -5})


def test_home_without_routine_stays_at_first_values(studio: Home) -> None:
    assert studio.routine.values_at(12) == {"activity": "work"}
    assert {s["activity"] for s in _day(SimulatedHome(studio), 60)} == {"work"}


def test_same_seed_same_snapshots(paper: Home) -> None:
    a = _day(SimulatedHome(paper, seed=3), 30)
    b = _day(SimulatedHome(paper, seed=3), 30)
    c = _day(SimulatedHome(paper, seed=4), 30)
    assert a == b
    assert a != c


def test_advance_backwards_is_refused(paper: Home) -> None:
    with pytest.raises(ValueError, match="time only moves forward"):
        SimulatedHome(paper).advance(-1)


@pytest.mark.parametrize(
    ("routine", "message"),
    [
        (
            '  - {at: "08:00", activity: nap}\n',
            "studio.yaml: routine[0].activity: unknown value 'nap'; expected one of work, relax, sleep",
        ),
        (
            '  - {at: "08:00", mood: happy}\n',
            "studio.yaml: routine[0].mood: unknown feature; expected at, set or one of activity",
        ),
        (
            '  - {at: "08:00", light: 300}\n',
            "studio.yaml: routine[0].light: a numeric feature comes from the clock or the weather",
        ),
        (
            '  - {at: "09:00", activity: work}\n  - {at: "08:00", activity: relax}\n',
            "studio.yaml: routine[1].at: steps must be in time order; this one is not after the one before",
        ),
        (
            '  - {at: "breakfast", activity: work}\n',
            "studio.yaml: routine[0].at: expected a time \"HH:MM\", got 'breakfast'",
        ),
        (
            "  - {activity: work}\n",
            "studio.yaml: routine[0]: missing key 'at'",
        ),
        (
            '  - {at: "08:00", set: {toaster: on}}\n',
            "studio.yaml: routine[0].set.toaster: unknown device; expected one of blind, desk_lamp, radio",
        ),
        (
            '  - {at: "08:00", set: {radio: loud}}\n',
            "studio.yaml: routine[0].set.radio: unknown state 'loud'; expected on or off",
        ),
    ],
)
def test_bad_routine_names_the_key_path(routine: str, message: str) -> None:
    with pytest.raises(HomeFileError) as e:
        load_home_text(STUDIO_TEXT + "routine:\n" + routine, "studio.yaml")
    assert str(e.value) == message


def test_routine_not_a_list() -> None:
    with pytest.raises(HomeFileError, match=r"studio.yaml: routine: expected a non-empty list"):
        load_home_text(STUDIO_TEXT + "routine: {at: 8}\n", "studio.yaml")
