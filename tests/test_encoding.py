"""Context encoding: Table 1 coding, discretization, and collision-free numbering."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from reference import parse_hardware_code

from homecog.errors import ContextError
from homecog.home.clock import parse_clock
from homecog.home.encoding import coded, context_codes, context_index, hardware_code


def paper_index(codes: tuple[int, ...]) -> int:
    """The paper's Eq. 2 (with 1-based ``num``): collides; kept to show why we do not use it."""
    return sum(k * 2**i for i, k in enumerate(codes))


def test_table1_coding(paper):
    expected = {
        "time": [(1, 0.0), (2, 0.2), (3, 0.4), (4, 0.6), (5, 0.8), (6, 1.0)],
        "temperature": [(1, 0.0), (2, 0.5), (3, 1.0)],
        "illumination": [(1, 0.0), (2, 0.5), (3, 1.0)],
        "location": [(1, 0.0), (2, 1 / 3), (3, 2 / 3), (4, 1.0)],
        "posture": [(1, 0.0), (2, 0.5), (3, 1.0)],
        "behavior": [(1, 0.0), (2, 1 / 3), (3, 2 / 3), (4, 1.0)],
    }
    for name, codes in expected.items():
        f = paper.feature(name)
        got = [coded(f, k) for k in range(f.radix)]
        assert [c for c, _ in got] == [c for c, _ in codes]
        assert [n for _, n in got] == pytest.approx([n for _, n in codes])


@pytest.mark.parametrize(
    ("feature", "reading", "value"),
    [
        ("time", "07:00", "early_morning"),
        ("time", "06:59", "night"),
        ("time", "21:00", "night"),
        ("time", "0:00", "night"),
        ("time", "24:00", "night"),
        ("time", 11.5, "noon"),
        ("time", "11:29", "morning"),
        ("temperature", 25, "suitable"),
        ("temperature", 24.999, "cold"),
        ("temperature", 30, "hot"),
        ("temperature", -40, "cold"),
        ("illumination", 100, "suitable"),
        ("illumination", 99.9, "dark"),
        ("illumination", 550, "light"),
        ("illumination", 0, "dark"),
        ("location", "dining_table", "dining_table"),
    ],
)
def test_discretize_half_open_bins(paper, feature, reading, value):
    f = paper.feature(feature)
    assert f.values[f.discretize(reading)] == value


@pytest.mark.parametrize(
    ("feature", "reading", "message"),
    [
        ("illumination", -5, "illumination: -5 lx is outside every bin; valid range [0, inf)"),
        ("time", "25:00", "time: time '25:00' out of range; expected 00:00 to 24:00"),
        ("time", "7h", "time: not a time: '7h'; expected HH:MM or decimal hours"),
        ("temperature", "warm", "temperature: not a number: 'warm'"),
        (
            "location",
            "garden",
            "location: unknown value 'garden'; expected one of table, sofa, bed, dining_table",
        ),
    ],
)
def test_discretize_errors(paper, feature, reading, message):
    with pytest.raises(ContextError) as e:
        paper.feature(feature).discretize(reading)
    assert str(e.value) == message


def test_parse_clock():
    assert parse_clock("7:30") == 7.5
    assert parse_clock("07:30:36") == pytest.approx(7.51)
    assert parse_clock(22) == 22.0
    assert parse_clock("24:00") == 0.0


def test_context_index_is_a_bijection(paper):
    radices = [f.radix for f in paper.features]
    seen = set()
    for codes in itertools.product(*(range(r) for r in radices)):
        i = context_index(paper, codes)
        assert context_codes(paper, i) == codes
        seen.add(i)
    assert seen == set(range(paper.context_count))


def test_paper_eq2_collides(paper):
    """The paper's Eq. 2 maps distinct contexts to one index; ours does not."""
    radices = [f.radix for f in paper.features]
    by_index: dict[int, tuple[int, ...]] = {}
    collision = None
    for codes in itertools.product(*(range(r) for r in radices)):
        other = by_index.setdefault(paper_index(codes), codes)
        if other != codes:
            collision = (other, codes)
            break
    assert collision is not None
    a, b = collision
    assert context_index(paper, a) != context_index(paper, b)


def _all_states(core):
    """Every (c, h, n) of a home, vectorized, in index order."""
    t = core.tables
    s = np.arange(core.n_states)
    c = np.searchsorted(t.offsets, s, side="right") - 1
    rest = s - t.offsets[c]
    k = t.need_count[c]
    return s, c, rest >> k, rest & ((1 << k) - 1), k


@pytest.mark.parametrize("home", ["paper_core", "studio_core"])
def test_state_index_round_trip_over_whole_space(home, request):
    core = request.getfixturevalue(home)
    t = core.tables
    s, c, h, n, k = _all_states(core)
    assert (h < (1 << core.n_devices)).all() and (n < (1 << k)).all()
    assert (t.offsets[c] + (h << k) + n == s).all()
    # and every valid state is counted once: the sizes add up
    assert core.n_states == int(sum((1 << core.n_devices) << int(x) for x in t.need_count))
    # spot-check the scalar API on a spread of states
    for i in np.linspace(0, core.n_states - 1, 257).astype(int):
        ci, hi, ni = core.decode(int(i))
        assert core.index(ci, hi, ni) == i


def test_hardware_code_round_trip():
    for bits in itertools.product([False, True], repeat=8):
        assert parse_hardware_code(hardware_code(bits)) == bits
    assert hardware_code([False, True, False, False, True, False, False, False]) == "21221222"
