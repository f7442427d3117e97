"""The environment: Gymnasium API, Eq. 1 rewards, and the core checked against a reference."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from reference import reference_distance, reference_step

from homecog.environment import ENV_ID, SmartHomeEnv


def test_registered_and_passes_check_env():
    env = gym.make(ENV_ID, home="paper")
    assert env.spec.max_episode_steps == 30
    check_env(env.unwrapped)
    env.close()


@pytest.mark.filterwarnings("ignore:.*alternative render modes")  # made without gymnasium.make
def test_check_env_on_another_home(studio):
    check_env(SmartHomeEnv(studio))


def test_time_limit_truncates_at_30():
    env = gym.make(ENV_ID, home="paper")
    env.reset(seed=0, options={"context": (5, 1, 0, 2, 1, 2), "devices": [True] * 8})
    useless = env.unwrapped.home.service_index("ChargeItSelf")  # never needed in paper: never progress
    for i in range(30):
        _, reward, terminated, truncated, _ = env.step(useless)
        assert reward == -2.0 and not terminated
        assert truncated == (i == 29)


def test_reset_is_reproducible():
    env = SmartHomeEnv("paper")
    a, _ = env.reset(seed=42)
    b, _ = env.reset(seed=42)
    assert (a == b).all()


def _start(env, values, on):
    codes = tuple(env.home.feature(k).index(v) for k, v in values.items())
    states = [d in on for d in env.home.device_names]
    return env.reset(options={"context": codes, "devices": states})


EVENING_TV = {
    "time": "evening",
    "temperature": "hot",
    "illumination": "suitable",
    "location": "sofa",
    "posture": "sit",
    "behavior": "watch_tv",
}


def test_fig8_rewards():
    """−2 for a wrong or useless service, +2 for progress, +7 for the last step."""
    env = SmartHomeEnv("paper", render_mode="ansi")
    _, info = _start(env, EVENING_TV, {"window", "curtain"})
    assert info["distance"] == 5
    assert env.render() == "532-212-11222222"
    sid = env.home.service_index
    steps = [
        ("TurnOnLamp", -2.0),
        ("TurnOffLamp", 2.0),
        ("OpenWindow", -2.0),
        ("TurnOnLight", 2.0),
        ("TurnOnTVL", 2.0),
        ("SendDrinks", 2.0),
        ("SendDrinks", -2.0),
        ("CloseWindow", 2.0),
    ]
    for name, expected in steps:
        _, reward, terminated, _, _ = env.step(sid(name))
        assert reward == expected, name
        assert not terminated
    _, reward, terminated, _, info = env.step(sid("TurnOnACL"))
    assert (reward, terminated, info["distance"]) == (7.0, True, 0)


def test_prohibited_penalty():
    env = SmartHomeEnv("paper")
    sid = env.home.service_index
    # OpenCurtain at night when the curtain is wanted closed: wrong (−2) and prohibited (−3)
    _start(env, {**EVENING_TV, "time": "night"}, set())
    _, reward, _, _, info = env.step(sid("OpenCurtain"))
    assert (reward, info["prohibited"]) == (-5.0, True)
    # TurnOnACL through an open window is progress (+2) yet prohibited (−3)
    _start(env, EVENING_TV, {"window"})
    _, reward, _, _, info = env.step(sid("TurnOnACL"))
    assert (reward, info["prohibited"]) == (-1.0, True)


def _check_against_reference(home, core, states):
    for s in states:
        c, h, n = core.decode(int(s))
        codes = core.codes(c)
        needed = core.need_services(c)
        pending = frozenset(home.services[a].name for j, a in enumerate(needed) if n >> j & 1)
        dev = core.states(h)
        assert core.distance(c, h, n) == reference_distance(home, codes, dev, pending)
        for a, svc in enumerate(home.services):
            h2, n2, reward, done, _ = core.step(c, h, n, a)
            ref_states, ref_pending, ref_reward, ref_done = reference_step(
                home, codes, dev, pending, svc.name
            )
            assert core.states(h2) == ref_states
            assert (
                frozenset(home.services[b].name for j, b in enumerate(needed) if n2 >> j & 1) == ref_pending
            )
            assert (reward, done) == (pytest.approx(ref_reward), ref_done)


def test_core_matches_reference_over_whole_studio(studio, studio_core):
    _check_against_reference(studio, studio_core, range(studio_core.n_states))


def test_core_matches_reference_on_paper_sample(paper, paper_core):
    rng = np.random.default_rng(7)
    _check_against_reference(paper, paper_core, rng.choice(paper_core.n_states, 1500, replace=False))


def test_invariants_over_whole_paper_transition_table(paper, paper_core):
    """Every state × every service: one device or need changes, the distance moves by at most one,
    the reward follows from the distance change and prohibition."""
    core = paper_core
    t = core.tables
    s = np.arange(core.n_states)
    c = np.searchsorted(t.offsets, s, side="right") - 1
    k = t.need_count[c]
    rest = s - t.offsets[c]
    h, n = rest >> k, rest & ((1 << k) - 1)
    care, want = t.care[c], t.want[c]

    def dist(hh, nn):
        return _popcount((hh ^ want) & care) + _popcount(nn)

    d0 = dist(h, n)
    allowed = {-2.0, 2.0, 7.0, -5.0, -1.0, 4.0}
    at_optimum = {3.0, 0.0, -2.0, -5.0}  # useless yet still optimal (−2 + 5), or breaking it
    for a in range(core.n_services):
        h2, n2, reward, done, forbidden = core.step_many(c, h, n, np.full_like(c, a))
        d1 = dist(h2, n2)
        assert (np.abs(d1 - d0) <= 1).all()
        assert (_popcount(h2 ^ h) + _popcount(n2 ^ n) <= 1).all()
        assert (done == (d1 == 0)).all()
        expected = np.where(d1 < d0, 2.0, -2.0) + np.where(d1 == 0, 5.0, 0.0) - np.where(forbidden, 3.0, 0.0)
        assert np.allclose(reward, expected)
        assert set(np.unique(reward[d0 > 0])) <= allowed
        assert set(np.unique(reward[d0 == 0])) <= at_optimum
        if paper.services[a].is_interaction:
            assert (h2 == h).all()
        else:
            assert (n2 == n).all()


def _popcount(x: np.ndarray) -> np.ndarray:
    return np.bitwise_count(x.astype(np.uint64)).astype(np.int64)
