"""Corrections a household can trust, on a flat written by a newcomer from the docs alone
(tests/homes/family.yaml): a confirmation changes nothing, an addition stays near where it was
made, a scene is corrected as what it is, the home as its own truth is never made worse; and
devices that must not flap do not."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest

from homecog.errors import ContextError, HomeFileError
from homecog.evaluation.evaluate import run
from homecog.evaluation.learn import learn_methods
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home, load_home_text
from homecog.home.codec import Space
from homecog.knowledge.pipeline import ensure_policy
from homecog.robot.pacing import Pacing

FAMILY = Path(__file__).parent / "homes" / "family.yaml"


@pytest.fixture(scope="module")
def family():
    home = load_home(FAMILY)
    tree = learn_methods(home, ensure_policy(home), ("multi",), seed=0, kmeans_k=8).tree
    return home, tree


def fresh(family):
    return pickle.loads(pickle.dumps(family[1]))


def test_confirming_what_the_robot_proposed_changes_nothing_anywhere(family):
    home, _ = family
    t = fresh(family)
    tests = random_scenarios(home, 300, seed=3)
    before = [t.predict_one(s.point, user="uma") for s in tests]
    for s in tests[:5]:
        t.correct_one(s.point, t.predict_one(s.point, user="uma"), user="uma")
    assert [t.predict_one(s.point, user="uma") for s in tests] == before


def test_six_additions_on_the_sofa_in_the_evening_are_no_wish_for_the_night_in_bed(family):
    home, _ = family
    t = fresh(family)
    space = Space(home)
    sofa = {"location": "sofa", "behavior": "relax"}
    made = 0
    for i, s in enumerate(random_scenarios(home, 200, seed=4)):
        x = {**space.context(s.point), **sofa, "time": f"{19 + i % 3}:{(7 * i) % 60:02d}"}
        if "BringWater" not in t.predict_one(x, user="uma"):
            t.correct_one(x, ["BringWater"], user="uma", concerns=["BringWater"])
            made += 1
        if made == 6:
            break
    assert "BringWater" in t.predict_one({**x, "time": "20:10"}, user="uma")
    outside = [
        s for s in random_scenarios(home, 1000, seed=5) if space.context(s.point)["location"] != "sofa"
    ]
    newly = [s for s in outside if "BringWater" in t.predict_one(s.point, user="uma")]
    assert len(newly) <= sum("BringWater" in t.predict_one(s.point) for s in outside)
    night = {**x, "time": "03:00", "location": "parents_bed", "behavior": "sleep", "posture": "lie"}
    assert "BringWater" not in t.predict_one(night, user="uma")


def test_a_scene_and_its_own_devices_service_in_one_correction_is_refused(family):
    home, _ = family
    t = fresh(family)
    scene = home.services[home.service_index("MovieNight")]
    device, state = scene.sets[0]
    own = next(s.name for s in home.services if s.sets == ((device, state),))
    x = random_scenarios(home, 1, seed=6)[0].point
    with pytest.raises(ContextError, match="MovieNight does the work of"):
        t.correct_one(x, ["MovieNight", own], user="uma")
    assert t.n_clusters("uma") == 0  # nothing kept


def test_the_home_as_its_own_truth_is_never_made_worse_by_corrections():
    home = load_home(FAMILY)
    curve = run(home, home, scenarios=300, methods=("multi",), corrections=60).curve
    assert curve is not None and min(c["f1"] for c in curve) >= curve[0]["f1"] - 0.005


PACED = """
name: paced
context:
  time: {kind: clock, bins: {day: [7, 21], night: [21, 7]}}
  temperature: {kind: numeric, unit: "°C", deadband: 1, bins: {cold: [-.inf, 19], warm: [19, .inf]}}
devices:
  radiator: {min_on: 20, min_off: 5}
  lamp: {}
services:
  HeatOn: {category: c, set: {radiator: on}}
  HeatOff: {category: c, set: {radiator: off}}
  LampOn: {category: c, set: {lamp: on}}
  LampOff: {category: c, set: {lamp: off}}
comfort:
  radiator: [{when: {temperature: [cold]}, want: on}, {want: off}]
  lamp: [{when: {time: [night]}, want: on}, {want: off}]
"""


def test_minimum_times_and_deadbands_are_read_and_kept():
    home = load_home_text(PACED)
    radiator, lamp = home.devices
    assert (radiator.min_on, radiator.min_off, lamp.min_on) == (1200.0, 300.0, 0.0)
    assert home.features[1].deadband == 1.0
    pacing = Pacing(home)
    pacing.switched("radiator", True, at=0.0)
    assert pacing.resting("radiator", at=1199.0) and not pacing.resting("radiator", at=1200.0)
    pacing.switched("lamp", True, at=0.0)
    assert not pacing.resting("lamp", at=1.0)
    # hysteresis: 18.5 is cold; 19.5 is not past the edge by the deadband: still cold for the robot
    readings = ["18.5", "19.5", "19.9", "20.1", "18.4", "17.9"]
    seen = [
        Space(home)
        .point(
            {
                "time": "12:00",
                "temperature": pacing.steady({"temperature": r})["temperature"],
                "radiator": "off",
                "lamp": "off",
            }
        )
        .codes[1]
        for r in readings
    ]
    assert seen == [0, 0, 0, 1, 1, 0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("radiator: {min_on: 20, min_off: 5}", None),
        ("radiator: {min_on: -1}", "devices.radiator.min_on: -1 minutes; expected 0 to 1440"),
        ("radiator: {min_off: lots}", "devices.radiator.min_off: expected a number"),
    ],
)
def test_bad_minimum_times_are_one_line(text, message):
    source = PACED.replace("radiator: {min_on: 20, min_off: 5}", text)
    if message is None:
        load_home_text(source)
        return
    with pytest.raises(HomeFileError, match=message):
        load_home_text(source)


def test_a_negative_deadband_or_one_on_the_clock_is_refused():
    with pytest.raises(HomeFileError, match=r"temperature.deadband: -1; expected 0 or more"):
        load_home_text(PACED.replace("deadband: 1", "deadband: -1"))
    with pytest.raises(HomeFileError, match="a deadband is for numeric features, not clock ones"):
        load_home_text(PACED.replace("{kind: clock,", "{kind: clock, deadband: 1,"))
