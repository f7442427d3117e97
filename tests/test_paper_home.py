"""The built-in paper home: its contract (names, order) and the paper's worked cases."""

from __future__ import annotations

import itertools

import pytest
from reference import parse_hardware_code

from homecog.environment.reachability import solvable_start_states

DEVICES = ["window", "curtain", "tv_living", "tv_bedroom", "ac_living", "ac_bedroom", "lamp", "ceiling_light"]
TABLE2 = [
    "TurnOnLight",
    "TurnOnLamp",
    "TurnOnTVL",
    "TurnOnTVB",
    "OpenCurtain",
    "OpenWindow",
    "TurnOnACL",
    "TurnOnACB",
    "SendDrinks",
    "CallToWakeup",
    "TurnOffLamp",
    "TurnOffTVL",
    "TurnOffTVB",
    "CloseWindow",
    "CloseCurtain",
    "TurnOffLight",
    "TurnOffACL",
    "TurnOffACB",
]


def test_paper_contract(paper):
    assert paper.feature_names == ("time", "temperature", "illumination", "location", "posture", "behavior")
    assert [f.radix for f in paper.features] == [6, 3, 3, 4, 3, 4]
    assert list(paper.device_names) == DEVICES
    assert list(paper.service_names) == [*TABLE2, "RemindToSleep", "ChargeItSelf"]
    sets = {s.name: dict(s.sets) for s in paper.services}
    assert sets["TurnOnLight"] == {"ceiling_light": True}
    assert sets["TurnOffLight"] == {"ceiling_light": False}
    assert sets["TurnOnTVB"] == {"tv_bedroom": True}
    assert sets["TurnOffACL"] == {"ac_living": False}
    assert sets["SendDrinks"] == {} and sets["ChargeItSelf"] == {}


def _context(paper, time, temp, lux, location, posture, behavior, on):
    readings = {
        "time": time,
        "temperature": temp,
        "illumination": lux,
        "location": location,
        "posture": posture,
        "behavior": behavior,
    }
    readings |= {d: ("on" if d in on else "off") for d in DEVICES}
    return paper.discretize(readings)


FIG9 = [
    pytest.param(
        ("22:00", 19, 200, "table", "sit", "read", {"window", "curtain", "lamp", "ceiling_light"}),
        {"SendDrinks", "RemindToSleep", "CloseWindow", "CloseCurtain"},
        id="1-night-reading",
    ),
    pytest.param(
        ("19:00", 30, 200, "sofa", "sit", "watch_tv", {"window", "curtain"}),
        {"TurnOnLight", "TurnOnTVL", "TurnOnACL", "SendDrinks", "CloseWindow"},
        id="2-evening-tv",
    ),
    pytest.param(
        ("07:00", 25, 100, "bed", "lie", "sleep", set()),
        {"CallToWakeup", "OpenCurtain", "OpenWindow", "SendDrinks"},
        id="3-wake-up",
    ),
    pytest.param(
        ("11:00", 22, 300, "dining_table", "sit", "eat", {"window", "curtain", "tv_living"}),
        {"SendDrinks", "TurnOffTVL"},
        id="4-lunch",
    ),
]


@pytest.mark.parametrize(("case", "expected"), FIG9)
def test_fig9_cases(paper, paper_core, case, expected):
    codes, states = _context(paper, *case)
    assert set(paper.services_to_optimum(codes, states)) == expected
    # the environment agrees: its distance is the number of those services
    c = paper_core.context_of({f.name: f.values[k] for f, k in zip(paper.features, codes, strict=True)})
    assert paper_core.distance(c, paper_core.bits(states)) == len(expected)


@pytest.mark.parametrize("lux", ["light", "suitable", "dark"])
@pytest.mark.parametrize("posture", ["lie"])
def test_section_213_example(paper, paper_core, lux, posture):
    """Night, suitable temperature, in bed lying asleep, hardware 21221222: distance 2, optimum all off."""
    values = {
        "time": "night",
        "temperature": "suitable",
        "illumination": lux,
        "location": "bed",
        "posture": posture,
        "behavior": "sleep",
    }
    c = paper_core.context_of(values)
    h = paper_core.bits(parse_hardware_code("21221222"))
    assert paper_core.distance(c, h) == 2
    assert paper_core.wanted(c) == (False,) * 8
    codes = paper_core.codes(c)
    assert paper.optimum(codes, paper_core.states(h)) == (False,) * 8
    assert paper.needs_of(codes) == ()


def test_every_paper_start_state_can_reach_its_optimum(paper_core):
    assert solvable_start_states(paper_core.tables).all()


def test_device_prohibitions_make_order_matter(paper, paper_core):
    """Hot evening on the sofa with the window open: close the window before cooling."""
    c = paper_core.context_of(
        {
            "time": "evening",
            "temperature": "hot",
            "illumination": "suitable",
            "location": "sofa",
            "posture": "sit",
            "behavior": "read",
        }
    )
    h = paper_core.bits([d in {"window", "curtain", "ceiling_light"} for d in DEVICES])
    codes = paper_core.codes(c)
    acl, close = paper.service_index("TurnOnACL"), paper.service_index("CloseWindow")
    assert paper.is_prohibited(acl, codes, paper_core.states(h))
    h_closed = paper_core.step(c, h, paper_core.full_needs(c), close)[0]
    assert not paper.is_prohibited(acl, codes, paper_core.states(h_closed))


def test_all_contexts_have_a_wanted_state_for_every_device(paper, paper_core):
    for c in range(paper.context_count):
        assert None not in paper_core.wanted(c)
    assert all(
        len(set(itertools.chain(paper.needs_of(paper_core.codes(c))))) <= 2
        for c in range(paper.context_count)
    )
