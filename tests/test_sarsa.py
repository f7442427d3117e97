"""Sarsa: the update rule, the paper's policy, learning, reproducibility and the Q table file."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from homecog.environment.reachability import greedy_outcomes
from homecog.errors import QTableError
from homecog.home import load_home
from homecog.learning.policy import Policy
from homecog.learning.qtable import QTable
from homecog.learning.rollout import greedy_services
from homecog.learning.sarsa import (
    SarsaConfig,
    choose,
    epsilon,
    greedy_optimal_rate,
    sarsa_update,
    seed_rng,
    train,
)

ROOT = Path(__file__).parent.parent


def test_sarsa_update_rule():
    q = np.zeros((2, 3), dtype=np.float32)
    q[1, 2] = 4.0
    sarsa_update(q, 0, 1, 2.0, 0.5 * q[1, 2], 0.25)  # 0 + 0.25·(2 + 0.5·4 − 0)
    assert q[0, 1] == pytest.approx(1.0)
    sarsa_update(q, 0, 1, -2.0, 0.0, 1.0)  # α = 1 at the end of an episode: Q = r
    assert q[0, 1] == -2.0


def test_policy_takes_the_best_when_all_tried():
    q = np.array([[0.1, 0.9, -1.0]], dtype=np.float32)
    tried = np.array([[0b111]], dtype=np.int64)
    rng = seed_rng(3)
    assert {int(choose(q, tried, 0, 0.0, rng, 1)) for _ in range(50)} == {1}  # the caller's best


def test_policy_explores_untried_services_uniformly():
    q = np.array([[5.0, 0.0, 0.0, 0.0]], dtype=np.float32)
    tried = np.array([[0b0001]], dtype=np.int64)  # service 0 tried and best
    rng = seed_rng(5)
    picks = Counter(int(choose(q, tried, 0, 0.0, rng, 0)) for _ in range(3000))  # ε = 0: always untried
    assert set(picks) == {1, 2, 3}
    assert all(800 < v < 1200 for v in picks.values())
    greedy = Counter(int(choose(q, tried, 0, 1.0, rng, 0)) for _ in range(100))  # ε = 1: always best
    assert greedy == Counter({0: 100})


def test_policy_handles_more_than_32_services():
    q = np.zeros((1, 40), dtype=np.float32)
    tried = np.array([[0xFFFFFFFF, 0b11111101]], dtype=np.int64)  # only service 33 untried
    assert int(choose(q, tried, 0, 0.0, seed_rng(1), 0)) == 33


def test_epsilon_schedule_is_the_papers():
    assert epsilon(1, 2.0, 0.0) == 1.0  # √2 capped at 1
    assert epsilon(2, 2.0, 0.0) == 1.0
    assert epsilon(8, 2.0, 0.0) == 0.5
    assert epsilon(200, 2.0, 0.0) == pytest.approx(0.1)
    assert epsilon(2_000_000, 2.0, 0.0) == pytest.approx(0.001)
    assert epsilon(2_000_000, 2.0, 0.05) == 0.05


def test_learning_happens_on_a_small_home(studio, studio_core):
    empty = QTable.empty(studio_core)
    before = greedy_optimal_rate(studio_core, empty.q)
    result = train(studio, SarsaConfig(episodes=20_000, seed=0), core=studio_core)
    assert before < 0.2
    assert result.greedy_optimal_rate >= 0.99
    assert result.steps > result.episodes / 2


def test_learning_happens_on_paper(paper, paper_core):
    """The default schedule passes 0.999 on paper within 2.5 million episodes."""
    result = train(paper, SarsaConfig(episodes=2_500_000, seed=0), core=paper_core)
    assert result.greedy_optimal_rate >= 0.999


def test_reproducible_from_seed(studio, studio_core):
    a = train(studio, SarsaConfig(episodes=3000, seed=11), core=studio_core).q_table
    b = train(studio, SarsaConfig(episodes=3000, seed=11), core=studio_core).q_table
    c = train(studio, SarsaConfig(episodes=3000, seed=12), core=studio_core).q_table
    assert np.array_equal(a.q, b.q) and np.array_equal(a.tried, b.tried)
    assert not np.array_equal(a.q, c.q)


def test_training_in_chunks_equals_one_run(studio, studio_core):
    one = train(studio, SarsaConfig(episodes=4000, seed=2), core=studio_core).q_table
    table = QTable.empty(studio_core)
    train(studio, SarsaConfig(episodes=1500, seed=2), core=studio_core, q_table=table)
    train(studio, SarsaConfig(episodes=2500, seed=2), core=studio_core, q_table=table)
    assert table.episodes == 4000
    assert np.array_equal(one.q, table.q)


def test_compiled_kernel_equals_plain_python(tmp_path, studio, studio_core):
    """The same code run by the interpreter (NUMBA_DISABLE_JIT=1) makes the identical Q table."""
    out = tmp_path / "plain.npz"
    script = (
        "from homecog.home import load_home\n"
        "from homecog.learning.sarsa import SarsaConfig, train\n"
        f"home = load_home({str(ROOT / 'tests/homes/studio.yaml')!r})\n"
        "r = train(home, SarsaConfig(episodes=1500, seed=4))\n"
        f"r.q_table.save({str(out)!r})\n"
    )
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    subprocess.run([sys.executable, "-c", script], check=True, env=env, timeout=300)
    plain = QTable.load(out, home=studio)
    compiled = train(studio, SarsaConfig(episodes=1500, seed=4), core=studio_core).q_table
    assert np.array_equal(plain.q, compiled.q)
    assert np.array_equal(plain.tried, compiled.tried)
    assert plain.steps == compiled.steps


def _reference_greedy_optimal(home, core, q):
    """Per start state, by the Home's own rules: the best service not prohibited at each step,
    all of them progress."""
    out = np.zeros((core.n_contexts, 1 << core.n_devices), dtype=bool)
    for c in range(core.n_contexts):
        codes = core.codes(c)
        for h0 in range(1 << core.n_devices):
            h, n = h0, core.full_needs(c)
            ok = True
            while core.distance(c, h, n) > 0:
                row = q[core.index(c, h, n)]
                allowed = [a for a in range(len(row)) if not home.is_prohibited(a, codes, core.states(h))]
                a = max(allowed, key=lambda a: (row[a], -a)) if allowed else int(np.argmax(row))
                if home.is_prohibited(a, codes, core.states(h)):
                    ok = False
                    break
                h2, n2, *_ = core.step(c, h, n, a)
                if core.distance(c, h2, n2) >= core.distance(c, h, n):
                    ok = False
                    break
                h, n = h2, n2
            out[c, h0] = ok
    return out


@pytest.mark.parametrize("episodes", [0, 40, 300, 5000])
def test_greedy_optimal_rate_is_exact(studio, studio_core, episodes):
    table = train(studio, SarsaConfig(episodes=episodes, seed=9), core=studio_core).q_table
    expected = _reference_greedy_optimal(studio, studio_core, table.q)
    assert np.array_equal(greedy_outcomes(studio_core.tables, table.q), expected)
    assert greedy_optimal_rate(studio_core, table.q) == expected.mean()


def test_greedy_services_reach_the_optimum(studio, studio_core):
    table = train(studio, SarsaConfig(episodes=20_000, seed=0), core=studio_core).q_table
    c = studio_core.context_of({"time": "day", "light": "dim", "activity": "work"})
    services = [studio.services[a].name for a in greedy_services(studio_core, table.q, c, 0)]
    assert sorted(services) == ["BringTea", "LampOn", "RaiseBlind"]


def test_q_table_round_trip_and_refusal(tmp_path, studio, studio_core, paper):
    result = train(studio, SarsaConfig(episodes=2000, seed=1), core=studio_core)
    path = result.q_table.save(tmp_path / "sub" / "q.npz")
    loaded = QTable.load(path, home=studio)
    assert np.array_equal(loaded.q, result.q_table.q) and np.array_equal(loaded.tried, result.q_table.tried)
    assert (loaded.episodes, loaded.steps) == (2000, result.steps)
    assert loaded.greedy_optimal_rate == result.greedy_optimal_rate
    assert loaded.config["seed"] == 1
    with pytest.raises(QTableError, match=r"made for home 'studio'.*not for home 'paper'"):
        QTable.load(path, home=paper)
    # continuing a loaded table goes on from where it stopped
    more = train(studio, SarsaConfig(episodes=500, seed=1), core=studio_core, q_table=loaded)
    assert loaded.episodes == 2500 and more.episodes == 500


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (SarsaConfig(episodes=-1), "episodes must be 0 or more, got -1"),
        (SarsaConfig(alpha=0), r"alpha must be in \(0, 1\], got 0"),
        (SarsaConfig(gamma=1.5), r"gamma must be in \[0, 1\], got 1.5"),
        (SarsaConfig(max_steps=0), "max_steps must be at least 1, got 0"),
        (SarsaConfig(seed=-3), "seed must be 0 or more, got -3"),
    ],
)
def test_config_validation(config, message):
    with pytest.raises(ValueError, match=message):
        config.validate()


def test_train_command_json(tmp_path):
    out = tmp_path / "q.npz"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "homecog.cli.main",
            "train",
            "--home",
            str(ROOT / "tests/homes/studio.yaml"),
            "--episodes",
            "20000",
            "--seed",
            "3",
            "--out",
            str(out),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    data = json.loads(proc.stdout)
    assert set(data) >= {"episodes", "steps", "seconds", "steps_per_second", "greedy_optimal_rate", "q_path"}
    assert data["episodes"] == 20000 and data["q_path"] == str(out)
    assert data["greedy_optimal_rate"] >= 0.99
    policy = Policy.load(out, load_home(ROOT / "tests/homes/studio.yaml"))
    assert policy.episodes == 20000 and not policy.joint
