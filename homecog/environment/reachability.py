"""Which start states reach their optimum, over the whole table of a home at once: by the greedy
roll-out of a Q table (:func:`greedy_outcomes`), by some path the rules leave
(:func:`fewest_steps`, :func:`solvable_states`), or already there (:func:`optimal_start_states`).

A path is a sequence of services, none prohibited, each of them progress (the distance falls
and no device that was as wanted is switched away from it: :func:`~homecog.environment.kernels.progressed`).
A roll-out is optimal when it is such a path to the optimum in the fewest services: with
services that each set one device, in exactly ``distance`` steps.

>>> from homecog.home import load_home
>>> from homecog.environment.tables import build_tables
>>> t = build_tables(load_home("paper"))
>>> optimal = optimal_start_states(t)  # [c, h]: every need pending
>>> optimal.shape, int(optimal.sum())
((2592, 256), 540)
"""

from __future__ import annotations

import numba
import numpy as np

from homecog.environment.kernels import apply, distance, greedy_walk, is_prohibited, progressed
from homecog.environment.tables import Tables

_jit = numba.njit(cache=True, nogil=True)
_inline = numba.njit(cache=True, nogil=True, inline="always")


@_jit
def _greedy(t: Tables, q: np.ndarray, fewest: np.ndarray) -> np.ndarray:
    n_contexts = len(t.need_count)
    n_h = 1 << t.n_devices
    services = np.empty(t.n_devices + t.need_count.max(), dtype=np.int64)  # at most the distance
    out = np.zeros((n_contexts, n_h), dtype=np.bool_)
    for c in range(n_contexts):
        k = t.need_count[c]
        for h0 in range(n_h):
            steps, ok = greedy_walk(t, q, c, h0, (1 << k) - 1, True, services)
            if ok and fewest.size:
                ok = steps == fewest[t.offsets[c] + (h0 << k) + (1 << k) - 1]
            out[c, h0] = ok
    return out


def greedy_outcomes(t: Tables, q: np.ndarray) -> np.ndarray:
    """Per start state (c, h, n = needs(c)), whether the greedy roll-out (the best service not
    prohibited, :func:`~homecog.environment.kernels.argmax_allowed`) is optimal: a path to the
    optimum (see the module) in the fewest services the table can choose (a column that is −inf
    everywhere, a scene in the joint table, is none of them). Indexed ``[c, h]``."""
    usable = ~np.isneginf(q).all(axis=0) if q.shape[0] else np.ones(q.shape[1], dtype=bool)
    several = bool((np.bitwise_count(t.set_mask[usable]) > 1).any())
    return _greedy(t, q, fewest_steps(t, usable) if several else np.zeros(0, dtype=np.int16))


def fewest_steps(t: Tables, usable: np.ndarray | None = None) -> np.ndarray:
    """Per state, the fewest services (of those ``usable``, default all) of a path to the
    optimum (see the module), −1 where the rules leave none. Indexed by state number."""
    return _fewest(t, np.ones(len(t.set_mask), dtype=np.bool_) if usable is None else usable)


@_inline
def _fewest_from(t: Tables, usable: np.ndarray, steps: np.ndarray, c: int, h: int, n: int, d: int) -> int:
    """The fewest services of a path from (c, h, n), at distance ``d`` > 0, given ``steps`` of
    every state nearer; −1 where there is none."""
    k = t.need_count[c]
    care_c, want_c = t.care[c], t.want[c]
    best = -1
    for a in range(len(t.set_mask)):
        if not usable[a]:
            continue
        if is_prohibited(t.prohibited_ctx, t.rule_start, t.rule_ctx, t.rule_mask, t.rule_val, c, h, a):
            continue
        h2, n2 = apply(t.set_mask, t.set_val, t.need_pos, c, h, n, a)
        if not progressed(care_c, want_c, h, h2, d, distance(care_c, want_c, h2, n2)):
            continue
        rest = steps[t.offsets[c] + (h2 << k) + n2]
        if rest >= 0 and (best < 0 or rest + 1 < best):
            best = rest + 1
    return best


@_jit
def _fewest(t: Tables, usable: np.ndarray) -> np.ndarray:
    steps = np.full(t.offsets[-1], -1, dtype=np.int16)
    for level in range(t.n_devices + t.need_count.max() + 1):  # a state's successors on a path are nearer
        for c in range(len(t.need_count)):
            k = t.need_count[c]
            for h in range(1 << t.n_devices):
                for n in range(1 << k):
                    d = distance(t.care[c], t.want[c], h, n)
                    if d == level:
                        s = t.offsets[c] + (h << k) + n
                        steps[s] = 0 if d == 0 else _fewest_from(t, usable, steps, c, h, n, d)
    return steps


def solvable_states(t: Tables) -> np.ndarray:
    """Per state, whether some path (see the module) reaches the optimum. Indexed by state number."""
    return fewest_steps(t) >= 0


def optimal_start_states(t: Tables) -> np.ndarray:
    """Per start state ``[c, h]`` (every need pending), whether it is already the optimum."""
    h = np.arange(1 << t.n_devices, dtype=np.int64)[None, :]
    return (((h ^ t.want[:, None]) & t.care[:, None]) == 0) & (t.need_count[:, None] == 0)


def solvable_start_states(t: Tables) -> np.ndarray:
    """:func:`solvable_states` of the start states, indexed ``[c, h]``."""
    ok = solvable_states(t)
    n_h = 1 << t.n_devices
    rows = (
        t.offsets[:-1, None]
        + (np.arange(n_h)[None, :] << t.need_count[:, None])
        + ((1 << t.need_count) - 1)[:, None]
    )
    return ok[rows]
