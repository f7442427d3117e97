"""Which start states reach their optimum, over the whole table of a home at once: by the greedy
roll-out of a Q table (:func:`greedy_outcomes`), by some path the rules leave
(:func:`solvable_states`), or already there (:func:`optimal_start_states`).

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

from homecog.environment.kernels import apply, argmax_row, distance, is_prohibited
from homecog.environment.tables import Tables

_jit = numba.njit(cache=True, nogil=True)


@_jit
def greedy_outcomes(t: Tables, q: np.ndarray) -> np.ndarray:
    """Per start state (c, h, n = needs(c)), whether the greedy roll-out is optimal.

    Optimal: every step lowers the distance, no step is prohibited, and the optimum
    is reached — with one device or need per service, exactly ``distance`` steps.
    The result is indexed ``[c, h]``.
    """
    (
        n_devices,
        need_count,
        offsets,
        care,
        want,
        need_pos,
        set_mask,
        set_val,
        prohibited_ctx,
        rule_start,
        rule_ctx,
        rule_mask,
        rule_val,
        _,
    ) = t
    n_contexts = len(need_count)
    n_h = 1 << n_devices
    out = np.zeros((n_contexts, n_h), dtype=np.bool_)
    for c in range(n_contexts):
        k = need_count[c]
        for h0 in range(n_h):
            h, n = h0, (1 << k) - 1
            d = distance(care[c], want[c], h, n)
            ok = True
            while d > 0:
                a = argmax_row(q, offsets[c] + (h << k) + n)
                if is_prohibited(prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h, a):
                    ok = False
                    break
                h, n = apply(set_mask, set_val, need_pos, c, h, n, a)
                d2 = distance(care[c], want[c], h, n)
                if d2 >= d:
                    ok = False
                    break
                d = d2
            out[c, h0] = ok
    return out


@_jit
def solvable_states(t: Tables) -> np.ndarray:
    """Per state, whether some sequence of non-prohibited services, each lowering the
    distance, reaches the optimum (the rules leave a way). Indexed by state number."""
    (
        n_devices,
        need_count,
        offsets,
        care,
        want,
        need_pos,
        set_mask,
        set_val,
        prohibited_ctx,
        rule_start,
        rule_ctx,
        rule_mask,
        rule_val,
        _,
    ) = t
    n_services = len(set_mask)
    ok = np.zeros(offsets[-1], dtype=np.bool_)
    max_d = n_devices + need_count.max()
    for level in range(max_d + 1):  # a state's successors on a good path are nearer
        for c in range(len(need_count)):
            k = need_count[c]
            for h in range(1 << n_devices):
                for n in range(1 << k):
                    d = distance(care[c], want[c], h, n)
                    if d != level:
                        continue
                    s = offsets[c] + (h << k) + n
                    if d == 0:
                        ok[s] = True
                        continue
                    for a in range(n_services):
                        if is_prohibited(prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h, a):
                            continue
                        h2, n2 = apply(set_mask, set_val, need_pos, c, h, n, a)
                        if distance(care[c], want[c], h2, n2) < d and ok[offsets[c] + (h2 << k) + n2]:
                            ok[s] = True
                            break
    return ok


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
