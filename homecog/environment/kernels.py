"""The environment's step as kernels compiled by numba: the distance to the optimum, a service's
effect, whether it is prohibited, the reward of Eq. 1, and steps one at a time or in arrays.

A state is ``(c, h, n)``: the context index ``c``, the device states ``h`` as bits (bit ``i``
set = device ``i`` on) and the pending needs ``n`` as bits over the needs of ``c``. The kernels
are plain Python over the arrays of :class:`~homecog.environment.tables.Tables`; run with
``NUMBA_DISABLE_JIT=1`` they are the same algorithm as a plain-Python loop (the benchmark and
the equivalence test do that). Learning's kernels inline the helpers here.

>>> popcount(0b1011)
3
"""

from __future__ import annotations

import numba
import numpy as np

from homecog.environment.tables import Tables

_jit = numba.njit(cache=True, nogil=True)
# Small helpers are inlined into the kernels at numba's IR level: a call that is not
# inlined increments and decrements the reference count of every array of the tables,
# which costs more than the helper itself.
_inline = numba.njit(cache=True, nogil=True, inline="always")

# -- kernels ------------------------------------------------------------------------------
# The kernels read the arrays they need out of the tables by name, into locals, and pass
# arrays, not the tuple, to the small helpers below.


@_inline
def popcount(x: int) -> int:
    """Number of set bits of a value below 2**32 (SWAR; the same in plain Python)."""
    x = x - ((x >> 1) & 0x55555555)
    x = (x & 0x33333333) + ((x >> 2) & 0x33333333)
    x = (x + (x >> 4)) & 0x0F0F0F0F
    return ((x * 0x01010101) & 0xFFFFFFFF) >> 24


@_inline
def distance(care_c: int, want_c: int, h: int, n: int) -> int:
    """Devices not in their wanted state plus pending needs (care_c, want_c: the context's bits)."""
    return popcount((h ^ want_c) & care_c) + popcount(n)


@_inline
def apply(
    set_mask: np.ndarray, set_val: np.ndarray, need_pos: np.ndarray, c: int, h: int, n: int, a: int
) -> tuple[int, int]:
    """Device states and pending needs after service a."""
    # One return statement each: numba inlines early returns poorly in hot loops.
    p = need_pos[c, a]
    h2 = (h & ~set_mask[a]) | set_val[a]
    n2 = n & ~(1 << p) if p >= 0 else n
    return h2, n2


@_inline
def is_prohibited(
    prohibited_ctx: np.ndarray,
    rule_start: np.ndarray,
    rule_ctx: np.ndarray,
    rule_mask: np.ndarray,
    rule_val: np.ndarray,
    c: int,
    h: int,
    a: int,
) -> bool:
    """Whether service a is prohibited in context c with device states h."""
    forbidden = prohibited_ctx[c, a]
    r = rule_start[a]
    while not forbidden and r < rule_start[a + 1]:
        forbidden = rule_ctx[r, c] and (h & rule_mask[r]) == rule_val[r]
        r += 1
    return forbidden


@_inline
def progressed(care_c: int, want_c: int, h: int, h2: int, before: int, after: int) -> bool:
    """Whether a step from device states ``h`` to ``h2`` is progress: the distance fell, and every
    device it switched was not as wanted (and now is). A service that sets several devices may
    put more right than it puts wrong, or switch a device nobody cares about; neither is
    progress: the plan would have to put a broken device back, with a service that changes
    nothing where the plan starts, and the optimum leaves a device nobody cares about as it was."""
    return after < before and ((h ^ h2) & ~(care_c & (h ^ want_c))) == 0


@_inline
def reward(
    w_terminal: float,
    w_progress: float,
    w_prohibited: float,
    m: float,
    progress: bool,
    before: int,
    after: int,
    forbidden: bool,
) -> float:
    """Eq. 1: w_p·(±m by progress) + w_t·(m at the optimum) − w_x·(m when prohibited).

    A step that brings the distance to 0 without being progress — it also switched a device
    nobody cares about, or put one wrong — earns no terminal reward: the optimum keeps such a
    device as it was. (With services of one device each every such step is progress, and a
    useless service at the optimum still earns −2 + 5 = +3: Eq. 1 as before.)"""
    r = w_progress * (m if progress else -m)
    if after == 0 and (progress or before == 0):
        r += w_terminal * m
    if forbidden:
        r -= w_prohibited * m
    return r


@_inline
def argmax_row(q: np.ndarray, s: int) -> int:
    """Best service in state s (the first on ties)."""
    best = 0
    for a in range(1, q.shape[1]):
        if q[s, a] > q[s, best]:
            best = a
    return best


@_inline
def argmax_allowed(
    q: np.ndarray,
    s: int,
    prohibited_ctx: np.ndarray,
    rule_start: np.ndarray,
    rule_ctx: np.ndarray,
    rule_mask: np.ndarray,
    rule_val: np.ndarray,
    c: int,
    h: int,
) -> int:
    """Best service in state s (context c, devices h) among those not prohibited there (the
    first on ties): the robot never does what it must not, even where the table rates it
    highest — Eq. 1's penalty can be outweighed by a terminal reward a prohibited service would
    reach at once. Where every service is prohibited, the best of all."""
    best = -1
    for a in range(q.shape[1]):
        if best >= 0 and q[s, a] <= q[s, best]:
            continue
        if not is_prohibited(prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h, a):
            best = a
    return argmax_row(q, s) if best < 0 else best


@_jit
def best_allowed(t: Tables, q: np.ndarray, c: int, h: int, n: int) -> int:
    """:func:`argmax_allowed` in state (c, h, n) of a table over ``t`` (for callers in Python)."""
    k = t.need_count[c]
    s = t.offsets[c] + (h << k) + n
    return argmax_allowed(q, s, t.prohibited_ctx, t.rule_start, t.rule_ctx, t.rule_mask, t.rule_val, c, h)


@_inline
def greedy_walk(
    t: Tables, q: np.ndarray, c: int, h: int, n: int, strict: bool, services: np.ndarray
) -> tuple[int, bool]:
    """The greedy roll-out of ``q`` from (c, h, n): the best service not prohibited
    (:func:`argmax_allowed`), step after step, until the optimum or ``len(services)`` services.

    Writes the services to ``services`` in order and returns how many, and whether the roll-out
    was optimal so far: no step prohibited, every step progress, the optimum reached. ``strict``
    stops it at the first step that is not allowed progress."""
    care_c, want_c, k, first = t.care[c], t.want[c], t.need_count[c], t.offsets[c]
    need_pos, set_mask, set_val = t.need_pos, t.set_mask, t.set_val
    p_ctx, r_start, r_ctx, r_mask, r_val = t.prohibited_ctx, t.rule_start, t.rule_ctx, t.rule_mask, t.rule_val
    d = distance(care_c, want_c, h, n)
    ok = True
    count = 0
    while d > 0 and count < len(services) and (ok or not strict):
        a = argmax_allowed(q, first + (h << k) + n, p_ctx, r_start, r_ctx, r_mask, r_val, c, h)
        services[count] = a
        h2, n2 = apply(set_mask, set_val, need_pos, c, h, n, a)
        d2 = distance(care_c, want_c, h2, n2)
        ok = ok and not is_prohibited(p_ctx, r_start, r_ctx, r_mask, r_val, c, h, a)
        ok = ok and progressed(care_c, want_c, h, h2, d, d2)
        h, n, d = h2, n2, d2
        count += 1
    return count, ok and d == 0


@_jit
def greedy_path(t: Tables, q: np.ndarray, c: int, h: int, n: int, limit: int) -> np.ndarray:
    """The services of :func:`greedy_walk` from (c, h, n), at most ``limit`` (for callers in Python)."""
    services = np.empty(limit, dtype=np.int64)
    count, _ = greedy_walk(t, q, c, h, n, False, services)
    return services[:count]


@_inline
def step(t: Tables, c: int, h: int, n: int, a: int) -> tuple[int, int, float, bool, bool]:
    """One environment step: (h', n', reward, terminated, prohibited), rewards as Eq. 1."""
    care_c, want_c, w = t.care[c], t.want[c], t.weights
    before = distance(care_c, want_c, h, n)
    h2, n2 = apply(t.set_mask, t.set_val, t.need_pos, c, h, n, a)
    after = distance(care_c, want_c, h2, n2)
    forbidden = is_prohibited(t.prohibited_ctx, t.rule_start, t.rule_ctx, t.rule_mask, t.rule_val, c, h, a)
    good = progressed(care_c, want_c, h, h2, before, after)
    return h2, n2, reward(w[0], w[1], w[2], w[3], good, before, after, forbidden), after == 0, forbidden


@_jit
def step_many(
    t: Tables, c: np.ndarray, h: np.ndarray, n: np.ndarray, a: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`step` over arrays of states and services at once."""
    size = len(c)
    h2 = np.empty(size, dtype=np.int64)
    n2 = np.empty(size, dtype=np.int64)
    rewards = np.empty(size, dtype=np.float64)
    done = np.empty(size, dtype=np.bool_)
    forbidden = np.empty(size, dtype=np.bool_)
    for i in range(size):
        h2[i], n2[i], rewards[i], done[i], forbidden[i] = step(t, c[i], h[i], n[i], a[i])
    return h2, n2, rewards, done, forbidden
