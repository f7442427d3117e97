"""The robot never flaps a device: at most two of its own switches of one device within an
hour (a third is left to the household), and no switch back of its own switch while the user's
situation is the one it switched in."""

from __future__ import annotations

from pathlib import Path

import pytest

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.robot.pacing import HOUR, MOST_AN_HOUR, Pacing
from homecog.robot.runtime import Runtime
from homecog.robot.settling import SAME_SITUATION, Settling

STUDIO = (Path(__file__).parent / "homes" / "studio.yaml").read_text()
WORK = {"time": "10:00", "light": "300", "activity": "work"}


class Clocked(ManualSource):
    """A context set by hand on a clock the test moves."""

    now = 0.0

    def clock(self) -> float:
        return self.now


@pytest.fixture
def studio():
    return load_home_text(STUDIO, "studio.yaml")


def make_runtime(home, wants):
    """A runtime on an empty knowledge tree whose proposal is ``wants(context)``."""
    source = Clocked(home)
    source.set_context(WORK)
    tree = IHDRTree(home)
    tree.predict_one = lambda point, user=None: wants(source.snapshot())  # type: ignore[method-assign]
    return Runtime(home=home, store=Store.open("sqlite://", home), tree=tree, source=source)


def radio_by_activity(context):
    """The radio on while the user relaxes, off while they work."""
    return ["RadioOn"] if context["activity"] == "relax" else ["RadioOff"]


def live(runtime, at, **context):
    runtime.source.now = at
    runtime.source.set_context(context)
    runtime.act_now("default")
    return runtime.source.snapshot()["radio"]


def test_a_device_is_switched_at_most_twice_an_hour_by_the_robot(studio):
    assert (MOST_AN_HOUR, HOUR) == (2, 3600.0)
    runtime = make_runtime(studio, radio_by_activity)
    assert live(runtime, 0.0, activity="relax") == "on"  # the first switch
    assert live(runtime, 600.0, activity="work") == "off"  # the second, 10 minutes later
    assert live(runtime, 1200.0, activity="relax") == "off"  # a third within the hour: left
    assert runtime.actor.skipped_hourly == 1
    assert live(runtime, 3540.0, activity="relax") == "off"  # the first is 59 minutes old
    assert runtime.actor.skipped_hourly == 2
    assert live(runtime, 3600.0, time="11:00") == "on"  # an hour since the first: one more
    assert [a.switches for a in runtime.journal.recent()][::-1] == [
        [("radio", True)],
        [("radio", False)],
        [("radio", True)],
    ]


def test_a_device_the_robot_leaves_is_the_households_and_the_robot_waits_out_the_hour(studio):
    runtime = make_runtime(studio, radio_by_activity)
    live(runtime, 0.0, activity="relax")
    live(runtime, 600.0, activity="work")
    runtime.source.now = 1200.0
    runtime.source.set_context({"activity": "relax"})
    runtime.source.switch("radio", True)  # the person switches the radio the robot left
    assert runtime.status()["household_switches"] == 1
    assert live(runtime, 1800.0, activity="work") == "on"  # the person's hold (30 minutes)
    assert (runtime.actor.skipped_held, runtime.actor.skipped_hourly) == (1, 0)
    assert live(runtime, 3100.0, time="10:50") == "on"  # the hold is over, the hour is not
    assert (runtime.actor.skipped_held, runtime.actor.skipped_hourly) == (1, 1)
    assert live(runtime, 3700.0, time="11:00") == "off"  # an hour since its first switch
    assert runtime.status()["fights"] == 0


def test_the_robot_does_not_switch_back_its_own_switch_in_the_same_situation(studio):
    # the radio wanted while the room is bright; the robot's own switch does not move the light
    # here, but a reading crossing a bin while the user does the same is no reason to switch back
    runtime = make_runtime(studio, lambda c: ["RadioOn"] if float(c["light"]) >= 200 else ["RadioOff"])
    assert live(runtime, 0.0, light="300") == "on"
    assert live(runtime, 600.0, light="50") == "on"  # dim now, the same situation: left as it is
    assert runtime.actor.skipped_settling == 1
    assert live(runtime, SAME_SITUATION - 1.0, light="50") == "on"
    assert live(runtime, SAME_SITUATION, light="50") == "off"  # an hour in it: readings count again
    assert live(runtime, SAME_SITUATION + 60.0, light="300", activity="relax") == "on"  # moved on


def test_settling_gives_a_device_back_when_the_situation_moves(studio):
    settling = Settling(studio)
    after = {**WORK, "radio": "on", "blind": "off", "desk_lamp": "off"}
    settling.switched("radio", True, at=0.0, context=after)
    assert settling.settled("radio", after, at=30.0)  # the home as the switch left it
    assert settling.settled("radio", {**after, "light": "50", "time": "20:00"}, at=60.0)  # readings, clock
    assert not settling.settled("radio", {**after, "light": "50", "activity": "relax"}, at=90.0)


def test_in_the_moment_of_its_switch_the_robot_may_still_answer_it(studio):
    # what the robot's other switches of the same moment do to the readings (a curtain it opens
    # after switching a light on) is judged as before: the light may go off again then
    settling = Settling(studio)
    after = {**WORK, "radio": "on", "blind": "off", "desk_lamp": "off"}
    settling.switched("radio", True, at=0.0, context=after)
    assert settling.settled("radio", after, at=0.0)
    assert not settling.settled("radio", {**after, "light": "50"}, at=59.0)
    settling.switched("radio", True, at=0.0, context=after)
    assert settling.settled("radio", after, at=0.0)
    assert settling.settled("radio", {**after, "light": "50"}, at=60.0)  # a later moment: held


def test_pacing_counts_the_robots_switches_in_a_rolling_hour(studio):
    pacing = Pacing(studio)
    pacing.switched("radio", True, at=0.0)  # anyone's switch: not the robot's count
    pacing.switched("radio", False, at=10.0)
    assert not pacing.spent("radio", at=20.0)
    pacing.robot_switched("radio", at=100.0)
    assert not pacing.spent("radio", at=200.0)
    pacing.robot_switched("radio", at=1900.0)
    assert [pacing.spent("radio", at=t) for t in (1900.0, 3699.0, 3700.0, 5499.0, 5500.0)] == [
        True,
        True,
        False,
        False,
        False,
    ]
    assert not pacing.spent("blind", at=0.0)
