"""How far one method is ahead of another on the same events, with a paired bootstrap interval."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from homecog.evaluation.leads import MIN_EVENTS, f1_difference, leads, pooled_difference, pooled_leads
from homecog.evaluation.metrics import prf

event = st.tuples(st.integers(0, 3), st.integers(0, 3), st.integers(0, 3)).map(
    lambda t: (min(t[0], t[1], t[2]), t[1], t[2])  # hits never exceed what was said or wanted
)


def micro_f1(events):
    return prf(*(sum(e[k] for e in events) for k in range(3)))[2]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(event, event), min_size=MIN_EVENTS, max_size=80))
def test_the_difference_is_the_two_micro_f1s_and_antisymmetric(rows):
    a, b = [r[0] for r in rows], [r[1] for r in rows]
    d = f1_difference(a, b, resamples=200)
    assert d.difference == pytest.approx(micro_f1(a) - micro_f1(b), abs=1e-12)
    assert -1 <= d.low <= d.high <= 1
    # the same draws for both orders: the interval turns over exactly
    e = f1_difference(b, a, resamples=200)
    assert (e.difference, e.low, e.high) == pytest.approx((-d.difference, -d.high, -d.low), abs=1e-12)


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(event, event), min_size=0, max_size=MIN_EVENTS - 1))
def test_too_few_events_give_the_difference_and_no_interval(rows):
    a, b = [r[0] for r in rows], [r[1] for r in rows]
    d = f1_difference(a, b)
    assert d.difference == pytest.approx(micro_f1(a) - micro_f1(b), abs=1e-12)
    assert (d.low, d.high) == (None, None)
    assert d.as_dict() == {"difference": round(d.difference, 6), "low": None, "high": None}
    assert str(d).endswith("[too few events]")


def test_a_clear_lead_and_chance():
    good = [(1, 1, 1)] * 80 + [(0, 1, 1)] * 20  # F1 0.8
    poor = [(1, 1, 1)] * 40 + [(0, 1, 1)] * 60  # F1 0.4
    d = f1_difference(good, poor)
    assert d.difference == pytest.approx(0.4)
    assert 0.25 < d.low < 0.4 < d.high < 0.55
    # two methods that differ on 2 of 100 events in opposite ways cannot be told apart
    one = [(1, 1, 1), (0, 1, 1)] + [(1, 1, 1)] * 98
    two = [(0, 1, 1), (1, 1, 1)] + [(1, 1, 1)] * 98
    same = f1_difference(one, two)
    assert same.difference == 0 and same.low < 0 < same.high
    assert str(d).startswith("+0.400 [+0.")


def test_the_draws_are_paired():
    """a is right on one event more than b and the same elsewhere: drawn in pairs, a is never
    behind in any draw, so the interval never goes below 0 — drawn apart, it would."""
    rng = np.random.default_rng(1)
    common = [(int(h), 1, 1) for h in rng.integers(0, 2, 99)]
    a, b = [(1, 1, 1), *common], [(0, 1, 1), *common]
    d = f1_difference(a, b)
    assert d.difference == pytest.approx(0.01) and d.low >= 0 and d.high > 0


def test_arrays_and_lists_agree_and_lengths_must_agree():
    a = [(1, 1, 1)] * 15 + [(0, 2, 1)] * 15
    b = [(1, 2, 1)] * 20 + [(0, 0, 1)] * 10
    assert f1_difference(a, b) == f1_difference(np.array(a, dtype=np.int32), np.array(b))
    with pytest.raises(ValueError, match="3 events for one method, 2 for the other"):
        f1_difference([(0, 0, 0)] * 3, [(0, 0, 0)] * 2)


def test_leads_need_the_base_method():
    counts = {"frequency": [(1, 1, 1)] * 30, "naive_bayes": [(0, 1, 1)] * 30}
    assert leads(counts) == {}
    versus = leads(counts, base="frequency")
    assert list(versus) == ["naive_bayes"] and versus["naive_bayes"].difference == pytest.approx(1.0)


def test_pooled_homes_weigh_the_same_and_draw_each_home_alone():
    """A long home does not outweigh a short one; the interval of one home is its own bootstrap's
    width; a home where the two agree on every event narrows nothing but halves the mean."""
    ahead = [(1, 1, 1)] * 60 + [(0, 1, 1)] * 40
    behind = [(1, 1, 1)] * 40 + [(0, 1, 1)] * 60
    short, long = (ahead, behind), (behind * 10, ahead * 10)
    d = pooled_difference([short, long])
    assert d.difference == pytest.approx(0.0, abs=1e-12)  # +0.2 and −0.2, each home once
    assert d.low < 0 < d.high
    one = pooled_difference([short])
    assert one.difference == pytest.approx(0.2)
    assert 0 < one.low < 0.2 < one.high
    same = pooled_difference([short, (ahead, ahead)])
    assert same.difference == pytest.approx(0.1)
    assert same.high - same.low == pytest.approx((one.high - one.low) / 2, abs=0.02)
    few = pooled_difference([short, (ahead[:5], behind[:5])])
    assert (few.low, few.high) == (None, None)
    with pytest.raises(ValueError, match="no home"):
        pooled_difference([])


def test_pooled_leads_count_the_homes_where_both_ran():
    a = [(1, 1, 1)] * 30
    b = [(0, 1, 1)] * 30
    out = pooled_leads({"h1": {"multi": a, "x": b, "y": b}, "h2": {"multi": a, "x": a}})
    assert {m: n for m, (_, n) in out.items()} == {"x": 2, "y": 1}
    assert out["x"][0].difference == pytest.approx(0.5) and out["y"][0].difference == pytest.approx(1.0)
