"""The vectorized core of the smart-home environment (SPEC §3).

A state is ``(c, h, n)``: the context index ``c`` (fixed within an episode), the device
states ``h`` as bits (bit ``i`` set = device ``i`` on) and the pending needs ``n`` as
bits over the needs of ``c`` (bit ``j`` = the ``j``-th interaction service ``c`` needs).
:class:`Tables` holds the rules of a home as arrays; the kernels below read them.

States are numbered without collisions by a mixed-radix code: the context digits
(radix = number of values of each feature), then one binary digit per device, then one
binary digit per need *of that context*. Contexts with fewer needs take fewer rows, so
the numbering is dense: every index in ``range(n_states)`` is a state.

The kernels are plain Python over NumPy arrays, compiled by numba. Run with
``NUMBA_DISABLE_JIT=1`` they are the same algorithm as a plain-Python loop (the
benchmark and the equivalence test do that).

>>> from homecog.home import load_home
>>> core = Core(load_home("paper"))
>>> core.n_contexts, core.n_devices, core.n_services, core.n_states
(2592, 8, 20, 1410048)
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from homecog.errors import HomeTooLargeError
from homecog.home.encoding import context_codes, context_index
from homecog.home.model import Condition, Home

#: Largest Q table (states × services) the core builds: 2**31 entries (8 GiB of float32).
MAX_TABLE_ENTRIES = 2**31

_jit = numba.njit(cache=True, nogil=True)
# Small helpers are inlined into the kernels at numba's IR level: a call that is not
# inlined increments and decrements the reference count of every array of the tables,
# which costs more than the helper itself.
_inline = numba.njit(cache=True, nogil=True, inline="always")


class Tables(NamedTuple):
    """The rules of a home as arrays, for the kernels."""

    n_devices: int
    need_count: np.ndarray  # int64[C]: number of needs of each context
    offsets: np.ndarray  # int64[C + 1]: first state index of each context
    care: np.ndarray  # int64[C]: bit d set when a comfort rule cares about device d
    want: np.ndarray  # int64[C]: wanted device bits (where cared)
    need_pos: np.ndarray  # int64[C, A]: local need bit of service a in context c, or -1
    set_mask: np.ndarray  # int64[A]: devices a service sets
    set_val: np.ndarray  # int64[A]: the states it sets them to
    prohibited_ctx: np.ndarray  # bool[C, A]: prohibited whatever the devices
    rule_start: np.ndarray  # int64[A + 1]: device-state prohibited rules of service a
    rule_ctx: np.ndarray  # bool[R, C]: the context part of each rule matches
    rule_mask: np.ndarray  # int64[R]: devices the rule constrains
    rule_val: np.ndarray  # int64[R]: the states it requires
    weights: np.ndarray  # float64[4]: terminal, progress, prohibited weights; magnitude


def _condition_contexts(codes: np.ndarray, cond: Condition) -> np.ndarray:
    """Boolean mask over all contexts where the feature part of a condition matches."""
    match = np.ones(len(codes), dtype=bool)
    for f, allowed in cond.features:
        match &= np.isin(codes[:, f], sorted(allowed))
    return match


def _device_bits(cond: Condition) -> tuple[int, int]:
    """(mask, value) of the devices a condition pins to one state."""
    mask = val = 0
    for d, allowed in cond.devices:
        if len(allowed) == 1:
            mask |= 1 << d
            if True in allowed:
                val |= 1 << d
    return mask, val


def build_tables(home: Home) -> Tables:
    """Evaluate every rule of a home over all its contexts."""
    n_contexts = home.context_count
    n_devices, n_services = len(home.devices), len(home.services)
    radix = [f.radix for f in home.features]
    codes = np.stack(np.unravel_index(np.arange(n_contexts), radix), axis=1).astype(np.int64)

    care = np.zeros(n_contexts, dtype=np.int64)
    want = np.zeros(n_contexts, dtype=np.int64)
    for d, rules in enumerate(home.comfort):
        decided = np.zeros(n_contexts, dtype=bool)
        for rule in rules:
            hit = _condition_contexts(codes, rule.when) & ~decided
            care[hit] |= 1 << d
            if rule.want:
                want[hit] |= 1 << d
            decided |= hit

    need_pos = np.full((n_contexts, n_services), -1, dtype=np.int64)
    need_count = np.zeros(n_contexts, dtype=np.int64)
    for a, rules in enumerate(home.needs):
        needed = np.zeros(n_contexts, dtype=bool)
        for cond in rules:
            needed |= _condition_contexts(codes, cond)
        need_pos[needed, a] = need_count[needed]
        need_count[needed] += 1

    set_mask = np.zeros(n_services, dtype=np.int64)
    set_val = np.zeros(n_services, dtype=np.int64)
    for a, service in enumerate(home.services):
        for device, state in service.sets:
            d = home.device_index(device)
            set_mask[a] |= 1 << d
            if state:
                set_val[a] |= 1 << d

    prohibited_ctx = np.zeros((n_contexts, n_services), dtype=bool)
    rule_start, rule_ctx, rule_mask, rule_val = [0], [], [], []
    for a, rules in enumerate(home.prohibited):
        for cond in rules:
            ctx = _condition_contexts(codes, cond)
            mask, val = _device_bits(cond)
            if mask == 0:
                prohibited_ctx[ctx, a] = True
            else:
                rule_ctx.append(ctx)
                rule_mask.append(mask)
                rule_val.append(val)
        rule_start.append(len(rule_mask))

    per_context = (np.int64(1) << n_devices) << need_count
    offsets = np.concatenate([[0], np.cumsum(per_context)]).astype(np.int64)
    r = home.rewards
    return Tables(
        n_devices=n_devices,
        need_count=need_count,
        offsets=offsets,
        care=care,
        want=want,
        need_pos=need_pos,
        set_mask=set_mask,
        set_val=set_val,
        prohibited_ctx=prohibited_ctx,
        rule_start=np.asarray(rule_start, dtype=np.int64),
        rule_ctx=np.asarray(rule_ctx, dtype=bool).reshape(len(rule_mask), n_contexts),
        rule_mask=np.asarray(rule_mask, dtype=np.int64),
        rule_val=np.asarray(rule_val, dtype=np.int64),
        weights=np.array([r.terminal, r.progress, r.prohibited, r.magnitude], dtype=np.float64),
    )


# -- kernels ------------------------------------------------------------------------------
# The kernels unpack the tables into local arrays once and pass arrays, not the tuple,
# to the inlined helpers: reading an array out of the tuple inside branchy code makes
# numba count references on every access, which costs ten times the step itself.


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
def reward(
    w_terminal: float,
    w_progress: float,
    w_prohibited: float,
    m: float,
    before: int,
    after: int,
    forbidden: bool,
) -> float:
    """Eq. 1: w_p·(±m by progress) + w_t·(m at the optimum) − w_x·(m when prohibited)."""
    r = w_progress * (m if after < before else -m)
    if after == 0:
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


@_jit
def step(t: Tables, c: int, h: int, n: int, a: int) -> tuple[int, int, float, bool, bool]:
    """One environment step: (h', n', reward, terminated, prohibited), rewards as Eq. 1."""
    (
        _,
        _,
        _,
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
        w,
    ) = t
    before = distance(care[c], want[c], h, n)
    h2, n2 = apply(set_mask, set_val, need_pos, c, h, n, a)
    after = distance(care[c], want[c], h2, n2)
    forbidden = is_prohibited(prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, c, h, a)
    return h2, n2, reward(w[0], w[1], w[2], w[3], before, after, forbidden), after == 0, forbidden


@_jit
def step_many(
    t: Tables, c: np.ndarray, h: np.ndarray, n: np.ndarray, a: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`step` over arrays of states and services at once."""
    (
        _,
        _,
        _,
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
        w,
    ) = t
    size = len(c)
    h2 = np.empty(size, dtype=np.int64)
    n2 = np.empty(size, dtype=np.int64)
    rewards = np.empty(size, dtype=np.float64)
    done = np.empty(size, dtype=np.bool_)
    forbidden = np.empty(size, dtype=np.bool_)
    for i in range(size):
        ci = c[i]
        before = distance(care[ci], want[ci], h[i], n[i])
        h2[i], n2[i] = apply(set_mask, set_val, need_pos, ci, h[i], n[i], a[i])
        after = distance(care[ci], want[ci], h2[i], n2[i])
        forbidden[i] = is_prohibited(
            prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val, ci, h[i], a[i]
        )
        rewards[i] = reward(w[0], w[1], w[2], w[3], before, after, forbidden[i])
        done[i] = after == 0
    return h2, n2, rewards, done, forbidden


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


class Core:
    """The environment of a home as arrays: sizes, state numbering and batched steps.

    >>> from homecog.home import load_home
    >>> core = Core(load_home("paper"))
    >>> c = core.context_of({"time": "night", "temperature": "suitable", "illumination":
    ...     "dark", "location": "bed", "posture": "lie", "behavior": "sleep"})
    >>> core.distance(c, core.bits([False, True, False, False, True, False, False, False]))
    2
    """

    def __init__(self, home: Home) -> None:
        self.home = home
        self.n_contexts = home.context_count
        self.n_devices = len(home.devices)
        self.n_services = len(home.services)
        if self.n_devices > 30:
            raise HomeTooLargeError(
                f"{home.name}: {self.n_devices} devices; a tabular Q table handles at most 30"
            )
        self.tables = build_tables(home)
        self.n_states = int(self.tables.offsets[-1])
        if self.n_states * self.n_services > MAX_TABLE_ENTRIES:
            raise HomeTooLargeError(
                f"{home.name}: {self.n_states:,} states × {self.n_services} services is too large "
                f"for a tabular Q table (at most {MAX_TABLE_ENTRIES:,} entries); "
                "use fewer features, values, devices or needs"
            )

    # -- numbering ---------------------------------------------------------------------
    def context_of(self, values: dict[str, str]) -> int:
        """Context index from value names (bin names or categories) per feature."""
        codes = [f.index(values[f.name]) for f in self.home.features]
        return context_index(self.home, codes)

    def codes(self, c: int) -> tuple[int, ...]:
        """Feature codes of context c."""
        return context_codes(self.home, c)

    @staticmethod
    def bits(states: list[bool] | tuple[bool, ...]) -> int:
        """Device states as bits (device 0 = bit 0)."""
        return sum(1 << d for d, on in enumerate(states) if on)

    def states(self, h: int) -> tuple[bool, ...]:
        """Bits as device states."""
        return tuple(bool(h >> d & 1) for d in range(self.n_devices))

    def full_needs(self, c: int) -> int:
        """Pending-needs bits at the start of an episode in context c."""
        return (1 << int(self.tables.need_count[c])) - 1

    def need_services(self, c: int) -> list[int]:
        """Services needed in context c, in need-bit order."""
        row = self.tables.need_pos[c]
        return [int(a) for a in np.argsort(row) if row[a] >= 0]

    def index(self, c: int, h: int, n: int) -> int:
        """Q-table row of state (c, h, n)."""
        return int(self.tables.offsets[c]) + (h << int(self.tables.need_count[c])) + n

    def decode(self, s: int) -> tuple[int, int, int]:
        """Inverse of :meth:`index`."""
        if not 0 <= s < self.n_states:
            raise ValueError(f"state {s} out of range 0..{self.n_states - 1}")
        c = int(np.searchsorted(self.tables.offsets, s, side="right") - 1)
        rest = s - int(self.tables.offsets[c])
        k = int(self.tables.need_count[c])
        return c, rest >> k, rest & ((1 << k) - 1)

    # -- dynamics ----------------------------------------------------------------------
    def distance(self, c: int, h: int, n: int | None = None) -> int:
        """Distance to the optimum (pending needs default to all needs of c)."""
        n = self.full_needs(c) if n is None else n
        return int(distance(self.tables.care[c], self.tables.want[c], h, n))

    def wanted(self, c: int) -> tuple[bool | None, ...]:
        """Per device, the wanted state in context c (None: don't care)."""
        care, want = int(self.tables.care[c]), int(self.tables.want[c])
        return tuple(bool(want >> d & 1) if care >> d & 1 else None for d in range(self.n_devices))

    def step(self, c: int, h: int, n: int, a: int) -> tuple[int, int, float, bool, bool]:
        """(h', n', reward, terminated, prohibited) of service a in state (c, h, n)."""
        h2, n2, r, done, forbidden = step(self.tables, c, h, n, a)
        return int(h2), int(n2), float(r), bool(done), bool(forbidden)

    def step_many(self, c: np.ndarray, h: np.ndarray, n: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, ...]:
        """:meth:`step` over arrays (int64) of states and services."""
        args = (np.asarray(x, dtype=np.int64) for x in (c, h, n, a))
        return step_many(self.tables, *args)

    def n_start_states(self) -> int:
        """Number of start states: every context and device state, all needs pending."""
        return self.n_contexts * (1 << self.n_devices)

    def table_bytes(self) -> int:
        """Bytes of a Q table (float32) plus its tried marks."""
        return self.n_states * self.n_services * 5
