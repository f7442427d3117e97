"""Sarsa, as the paper's Algorithm 1 with its action-selection policy.

In a state where every service has been tried, take the best; otherwise take the best
with probability ε and an untried service (uniformly) with probability 1 − ε, where
ε = min(1, √(c/t)) and t counts episodes (the paper's c = 2). Episodes start in a
uniformly random context and device state with every need pending, and end at the
optimum or after ``max_steps``.

Randomness comes from a small xorshift generator inside the kernel, seeded from
``seed``, so a run is reproducible and the compiled kernel and the same code run as
plain Python (``NUMBA_DISABLE_JIT=1``) give identical Q tables.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> result = train(home, SarsaConfig(episodes=2_000, seed=1))
>>> result.episodes, result.steps > 2_000
(2000, True)
>>> again = train(home, SarsaConfig(episodes=2_000, seed=1))
>>> bool((again.q_table.q == result.q_table.q).all())
True
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numba
import numpy as np

from homecog.environment.core import Core
from homecog.environment.kernels import (
    apply,
    argmax_allowed,
    distance,
    is_prohibited,
    popcount,
    progressed,
    reward,
)
from homecog.environment.reachability import greedy_outcomes
from homecog.environment.tables import Tables
from homecog.home.model import Home
from homecog.learning.qtable import QTable

_jit = numba.njit(cache=True, nogil=True)
_inline = numba.njit(cache=True, nogil=True, inline="always")
#: the most a count the kernel takes may be (an int64)
INT64_MAX = 2**63 - 1


@dataclass(frozen=True)
class SarsaConfig:
    """Hyperparameters of a Sarsa run; stored unchanged in the Q table."""

    episodes: int = 3_000_000
    """Episodes to run."""
    alpha: float = 1.0
    """Learning rate α (the environment is deterministic)."""
    gamma: float = 0.2
    """Discount γ; below 1/3 one try of each service separates right from wrong (docs/design.md)."""
    epsilon_c: float = 2.0
    """ε_t = min(1, √(epsilon_c / t)); the paper's schedule is c = 2."""
    epsilon_min: float = 0.0
    """Lower bound of ε."""
    max_steps: int = 30
    """Step limit of an episode (it is truncated there)."""
    seed: int = 0
    """Seed of the kernel's random generator."""

    def validate(self) -> None:
        """Raise ValueError naming the first invalid parameter."""
        if self.episodes < 0:
            raise ValueError(f"episodes must be 0 or more, got {self.episodes}")
        if not 0 < self.alpha <= 1:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")
        if not 0 <= self.gamma <= 1:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")
        if not 0 <= self.epsilon_c < math.inf or not 0 <= self.epsilon_min <= 1:  # NaN is neither
            raise ValueError("epsilon_c must be ≥ 0 and finite and epsilon_min in [0, 1]")
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be at least 1, got {self.max_steps}")
        if self.max_steps > INT64_MAX:
            raise ValueError(f"max_steps must be at most {INT64_MAX}, got {self.max_steps}")
        if self.episodes > INT64_MAX:
            raise ValueError(f"episodes must be at most {INT64_MAX}, got {self.episodes}")
        if self.seed < 0:
            raise ValueError(f"seed must be 0 or more, got {self.seed}")


# -- the kernel ----------------------------------------------------------------------------
@_inline
def _next(rng: np.ndarray) -> int:
    """xorshift32 on an int64 cell; the same in compiled and plain-Python runs."""
    x = rng[0]
    x ^= (x << 13) & 0xFFFFFFFF
    x ^= x >> 17
    x ^= (x << 5) & 0xFFFFFFFF
    rng[0] = x
    return x


@_inline
def _uniform(rng: np.ndarray) -> float:
    return _next(rng) / 4294967296.0


@_inline
def _lowest_bit(x: int) -> int:
    return popcount((x & -x) - 1)


@_inline
def choose(q: np.ndarray, tried: np.ndarray, s: int, eps: float, rng: np.ndarray, best: int) -> int:
    """The paper's policy: the best (``best``, the caller's greedy choice) when all are tried;
    else the best w.p. ε, a random untried one.

    ``tried[s, w]`` holds the tried marks of services ``32w .. 32w+31`` as bits.
    """
    n_services = q.shape[1]
    untried = 0
    for w in range(tried.shape[1]):
        untried += popcount(~tried[s, w] & word_mask(n_services, w))
    if untried == 0 or _uniform(rng) < eps:
        return best
    pick = _next(rng) % untried
    for w in range(tried.shape[1]):
        bits = ~tried[s, w] & word_mask(n_services, w)
        count = popcount(bits)
        if pick < count:
            for _ in range(pick):
                bits &= bits - 1
            return 32 * w + _lowest_bit(bits)
        pick -= count
    return -1  # unreachable


@_inline
def word_mask(n_services: int, w: int) -> int:
    """Bits of word w that stand for a service."""
    rest = n_services - 32 * w
    return 0xFFFFFFFF if rest >= 32 else (1 << rest) - 1


@_inline
def epsilon(t: int, eps_c: float, eps_min: float) -> float:
    """ε of episode t (1-based): min(1, max(ε_min, √(c/t))); the paper's c = 2."""
    return min(1.0, max(eps_min, math.sqrt(eps_c / t)))


@_inline
def sarsa_update(q: np.ndarray, s: int, a: int, r: float, target: float, alpha: float) -> None:
    """Q(s,a) ← Q(s,a) + α[r + target − Q(s,a)], target = γQ(s',a') (0 at the end)."""
    q[s, a] += alpha * (r + target - q[s, a])


@_jit
def run_episodes(
    t: Tables,
    q: np.ndarray,
    tried: np.ndarray,
    episodes: int,
    t0: int,
    alpha: float,
    gamma: float,
    eps_c: float,
    eps_min: float,
    max_steps: int,
    rng: np.ndarray,
    starts: np.ndarray,
    firsts: np.ndarray,
) -> int:
    """Algorithm 1 for ``episodes`` episodes numbered from ``t0 + 1``; returns the steps taken.

    Episodes start in a uniformly random context and device state, or, when ``starts`` is not
    empty, in ``starts[e]`` (``c · 2^devices + h``): a sweep over every start state; where
    ``firsts`` is not empty, episode ``e`` begins with service ``firsts[e]``, the policy choosing
    from the second step on (exploring starts over states and services).
    """
    n_devices, need_count, offsets, care, want = t.n_devices, t.need_count, t.offsets, t.care, t.want
    need_pos, set_mask, set_val, w = t.need_pos, t.set_mask, t.set_val, t.weights
    prohibited_ctx, rule_start, rule_ctx = t.prohibited_ctx, t.rule_start, t.rule_ctx
    rule_mask, rule_val = t.rule_mask, t.rule_val
    w_terminal, w_progress, w_prohibited, m = w[0], w[1], w[2], w[3]
    n_contexts = len(need_count)
    n_h = 1 << n_devices
    steps = 0
    for e in range(episodes):
        eps = epsilon(t0 + e + 1, eps_c, eps_min)
        if starts.size:
            c = starts[e] // n_h
            h = starts[e] % n_h
        else:
            c = _next(rng) % n_contexts
            h = _next(rng) % n_h
        k = need_count[c]
        n = (1 << k) - 1
        care_c, want_c = care[c], want[c]
        d = distance(care_c, want_c, h, n)
        if d == 0:
            continue
        s = offsets[c] + (h << k) + n
        if firsts.size:
            a = firsts[e]
        else:
            best = argmax_allowed(q, s, prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h)
            a = choose(q, tried, s, eps, rng, best)
        for _ in range(max_steps):
            h2, n2 = apply(set_mask, set_val, need_pos, c, h, n, a)
            d2 = distance(care_c, want_c, h2, n2)
            forbidden = is_prohibited(prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h, a)
            good = progressed(care_c, want_c, h, h2, d, d2)
            r = reward(w_terminal, w_progress, w_prohibited, m, good, d, d2, forbidden)
            tried[s, a >> 5] |= 1 << (a & 31)
            steps += 1
            if d2 == 0:
                sarsa_update(q, s, a, r, 0.0, alpha)
                break
            s2 = offsets[c] + (h2 << k) + n2
            best = argmax_allowed(q, s2, prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h2)
            a2 = choose(q, tried, s2, eps, rng, best)
            sarsa_update(q, s, a, r, gamma * q[s2, a2], alpha)
            s, h, n, a, d = s2, h2, n2, a2, d2
    return steps


NO_STARTS = np.zeros(0, dtype=np.int64)


def run_table(
    core: Core,
    table: QTable,
    config: SarsaConfig,
    episodes: int,
    t0: int,
    rng: np.ndarray,
    starts: np.ndarray = NO_STARTS,
    firsts: np.ndarray = NO_STARTS,
) -> int:
    """:func:`run_episodes` on a Q table with the hyperparameters of ``config``; the steps taken."""
    c = config
    return int(
        run_episodes(
            core.tables,
            table.q,
            table.tried,
            episodes,
            t0,
            c.alpha,
            c.gamma,
            c.epsilon_c,
            c.epsilon_min,
            c.max_steps,
            rng,
            starts,
            firsts,
        )
    )


def seed_rng(seed: int) -> np.ndarray:
    """Generator state for a seed (never zero, which xorshift cannot leave)."""
    x = (seed * 2654435761 + 0x9E3779B9) & 0xFFFFFFFF
    return np.array([x or 1], dtype=np.int64)


# -- the trainer ---------------------------------------------------------------------------
@dataclass
class RunFigures:
    """What a training run reports (the keys of ``homecog train --json``)."""

    episodes: int
    steps: int
    seconds: float
    greedy_optimal_rate: float

    @property
    def steps_per_second(self) -> float:
        return self.steps / self.seconds if self.seconds > 0 else 0.0


@dataclass
class TrainResult(RunFigures):
    """A joint run's figures and the Q table it made."""

    q_table: QTable = field(kw_only=True)


def leave_out_scenes(table: QTable, home: Home) -> None:
    """Scenes are never chosen by a table (the roll-out composes them, :mod:`homecog.home.scenes`):
    their columns are −inf and marked tried, so neither the greedy choice nor exploration takes
    them, and Sarsa never updates them."""
    from homecog.home.scenes import scene_services

    if table.q.shape[0] == 0:
        return
    for a in scene_services(home):
        table.q[:, a] = -np.inf
        table.tried[:, a >> 5] |= 1 << (a & 31)


def greedy_optimal_rate(core: Core, q: np.ndarray) -> float:
    """Share of start states whose greedy roll-out is optimal (exact, over all of them)."""
    return float(greedy_outcomes(core.tables, q).mean())


def train(
    home: Home,
    config: SarsaConfig = SarsaConfig(),
    *,
    core: Core | None = None,
    q_table: QTable | None = None,
    chunk: int = 100_000,
    progress: Callable[[int, int], None] | None = None,
) -> TrainResult:
    """Run Sarsa on a home, continuing ``q_table`` if given.

    ``progress(done, total)`` is called after every ``chunk`` episodes.
    """
    config.validate()
    core = core or Core(home)
    if q_table is None:
        q_table = QTable.empty(core, config=asdict(config))
        leave_out_scenes(q_table, core.home)
    else:
        q_table.check_home(home)
    rng = seed_rng(config.seed) if q_table.episodes == 0 else q_table.rng.copy()
    start = time.perf_counter()
    steps = done = 0
    while done < config.episodes:
        n = min(chunk, config.episodes - done)
        steps += run_table(core, q_table, config, n, q_table.episodes + done, rng)
        done += n
        if progress is not None:
            progress(done, config.episodes)
    seconds = time.perf_counter() - start
    q_table.episodes += done
    q_table.steps += steps
    q_table.rng = rng
    q_table.config = asdict(config)
    rate = greedy_optimal_rate(core, q_table.q)
    q_table.greedy_optimal_rate = rate
    return TrainResult(q_table=q_table, episodes=done, steps=steps, seconds=seconds, greedy_optimal_rate=rate)
