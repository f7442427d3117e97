"""The recent past: features of what came just before a moment, derived from the stream, that
the correction learner keys on — and that a stored correction keeps."""

from __future__ import annotations

import pickle
from dataclasses import replace
from datetime import datetime, timedelta

from knowledge_fixtures import tree
from processes import outputs_by_hash_seed

from homecog.home import load_home
from homecog.home.recent import Recent, RecentPast, recent_names, span

T0 = datetime(2026, 11, 30, 18, 0)  # a Monday
READ = {"location": "sofa", "posture": "sit", "behavior": "read"}


def test_the_features_of_a_stream_moment_by_moment():
    home = load_home("paper")
    past = RecentPast(home)
    assert recent_names(home) == (
        "weekday",
        "minutes since previous",
        "previous location",
        "previous posture",
        "previous behavior",
        "minutes in location",
        "minutes in posture",
        "minutes in behavior",
    )
    first = past.at(T0, READ)
    assert dict(first.values) == {"weekday": "mon", **dict.fromkeys(recent_names(home)[1:], "unknown")}
    assert first.previous is None
    past.learn(T0, READ, ["TurnOnLamp"])
    later = past.at(T0 + timedelta(minutes=70), {**READ, "location": "bed"})
    assert dict(later.values) == {
        "weekday": "mon",
        "minutes since previous": "1-4h",
        "previous location": "sofa",  # it has just changed
        "previous posture": "unknown",
        "previous behavior": "unknown",
        "minutes in location": "<5",
        "minutes in posture": "1-4h",
        "minutes in behavior": "1-4h",
    }
    assert later.previous == frozenset({"TurnOnLamp"})
    past.learn(T0 + timedelta(minutes=70), {**READ, "location": "bed"}, [])
    # a day later, the value before the current one is remembered, the previous services are none
    tuesday = past.at(T0 + timedelta(days=1), {**READ, "location": "bed"})
    assert tuesday.value("weekday") == "tue"
    assert tuesday.value("previous location") == "sofa"
    assert tuesday.value("minutes in location") == ">4h"
    assert tuesday.previous == frozenset()


def test_a_stream_without_times_says_unknown_and_times_going_back_are_not_spans():
    past = RecentPast(load_home("paper"))
    past.learn(None, READ, [])
    r = past.at(None, READ)
    assert (
        r.value("weekday") == r.value("minutes since previous") == r.value("minutes in behavior") == "unknown"
    )
    past.learn(T0, READ, [])
    assert past.at(T0 - timedelta(minutes=1), READ).value("minutes since previous") == "unknown"
    assert [span(m) for m in (0, 4.99, 5, 15, 60, 240)] == ["<5", "<5", "5-15", "15-60", "1-4h", ">4h"]


def test_recent_round_trips_as_plain_data():
    r = Recent(
        at=T0, values=(("weekday", "mon"), ("previous location", "sofa")), previous=frozenset({"A", "B"})
    )
    assert Recent.from_dict(r.as_dict()) == r
    none = Recent(at=None, values=(("weekday", "unknown"),), previous=None)
    assert Recent.from_dict(none.as_dict()) == none


def test_a_wish_that_follows_the_previous_moment_is_learned_from_the_recent_past():
    """Ann wants the ceiling light at every other moment — the snapshot is the same each time,
    so only the recent past (was it wanted just before?) can tell the two apart."""
    t = pickle.loads(pickle.dumps(tree("paper")))
    home = t.home
    x = {
        "time": "20:00", "temperature": 24, "illumination": 100, **READ, "window": "off", "curtain": "off",
        "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off", "lamp": "off",
        "ceiling_light": "off",
    }  # fmt: skip
    base = t.point(x)
    light = "TurnOnLight"
    past = RecentPast(home)
    when = T0
    pattern = [True, False] * 24
    for wanted in pattern:
        p = replace(base, recent=past.at(when, x))
        others = [s for s in t.predict_one(base, "ann") if s != light]
        want = sorted({*others, light} if wanted else others)
        t.correct_one(p, want, user="ann")
        past.learn(when, x, want)
        when += timedelta(minutes=7)
    after = Recent(at=when, values=past.at(when, x).values, previous=frozenset({light}))
    quiet = replace(after, previous=frozenset())
    assert light not in t.predict_one(replace(base, recent=after), "ann")
    assert light in t.predict_one(replace(base, recent=quiet), "ann")
    learner = t.layers.learners("ann")[home.service_index(light)]
    assert len(home.features) + len(recent_names(home)) in learner.best_key()  # "wanted just before"
    why = next(
        e for e in t.explain_one(replace(base, recent=quiet), "ann").explanations if e.service == light
    )
    assert why.conditions["wanted just before"] == "False"
    # the first moment had no moment before it: its "wanted just before" is unknown
    assert why.evidence["agreed"] == 23 and why.evidence["disagreed"] == 0


def test_how_long_ago_a_device_switched_by_the_services_or_by_its_state():
    home = load_home("paper")
    past = RecentPast(home)
    x = {**READ, "lamp": "off", "tv_living": "off"}
    past.learn(T0, x, ["TurnOnLamp"])  # the lamp is switched on at this moment
    r = past.at(T0 + timedelta(minutes=3), {**x, "lamp": "on"})
    assert r.since_switched("lamp") == "<5"
    assert r.since_switched("tv_living") == ">4h"  # never seen switching
    past.learn(T0 + timedelta(minutes=3), {**x, "lamp": "on", "tv_living": "on"}, [])  # by hand
    r = past.at(T0 + timedelta(minutes=20), {**x, "lamp": "on", "tv_living": "on"})
    assert r.switched == (("lamp", "15-60"), ("tv_living", "15-60"))
    past.learn(T0 + timedelta(hours=5), {**x, "lamp": "on", "tv_living": "on"}, [])
    assert past.at(T0 + timedelta(hours=5), x).switched == ()  # forgotten after four hours
    assert Recent(at=None, values=()).since_switched("lamp") == "unknown"


def test_a_moment_wanting_a_device_both_ways_is_the_same_past_in_every_process():
    """Two wanted services that set one device each way (an inconsistent wish): the device's
    state and switch are taken in one order, whatever the process's hash seed."""
    code = (
        "from datetime import datetime, timedelta; from homecog.home import load_home; "
        "from homecog.home.recent import RecentPast; home = load_home('paper'); past = RecentPast(home); "
        "t = datetime(2026, 1, 1, 20); "
        "past.learn(t, {'lamp': 'off'}, ['TurnOffLamp', 'TurnOnLamp', 'TurnOffLight', 'TurnOnLight']); "
        "past.learn(t + timedelta(minutes=20), {'lamp': 'on', 'ceiling_light': 'off'}, []); "
        "at = past.at(t + timedelta(minutes=21), {}); "
        "print(at.since_switched('lamp'), at.since_switched('ceiling_light'))"
    )
    answers = outputs_by_hash_seed(code, range(6))
    assert len(answers) == 1 and answers != {""}
