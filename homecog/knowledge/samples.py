"""Samples from the Q table (SPEC §5; the paper's §3.1, §4.2, Tables 5, 7, 8).

From every start state, the greedy roll-out of the learned policy gives an ordered
service sequence; numeric features get a random reading inside their bin (Table 7).
For each service of a sequence, the sample marks which dimensions (context features and
device states) matter to it — Table 5's zeros are the ones that do not.

*Which* dimensions matter is learned from the policy, never written per service: a
dimension matters to a service at a start state when changing it alone changes whether
the policy performs the service there. Where the decision is over-determined (the light
is wanted on because it is evening *and* because it is dark) no single change flips it and
that test alone would call both irrelevant; so the set is then grown, dimension by
dimension, until the sample's conditions are sufficient: every start state that meets
them has the policy perform the service. Conditions of a sample are therefore never
wrong on the training space, which is what lets the ``multi`` tree reach its precision.

>>> from homecog.home import load_home_text
>>> from homecog.environment.core import Core
>>> from homecog.learning.sarsa import SarsaConfig, train
>>> home = load_home_text('''
... name: hall
... context:
...   time: {kind: clock, bins: {day: [7, 20], night: [20, 7]}}
...   who: {kind: categorical, values: [nobody, someone]}
... devices: {light: {}, door: {}}
... services:
...   LightOn: {category: on, set: {light: on}}
...   LightOff: {category: off, set: {light: off}}
...   Lock: {category: off, set: {door: off}}
... comfort:
...   light: [{when: {time: [night], who: [someone]}, want: on}, {want: off}]
...   door: [{when: {who: [nobody]}, want: off}]
... ''')
>>> q = train(home, SarsaConfig(episodes=5_000, seed=0)).q_table.q
>>> samples = make_samples(Core(home), q, seed=0)
>>> len(samples)                       # 4 contexts × 4 device states
16
>>> s = samples[2 * 4 + 0b11]          # night, nobody home; light on, door open
>>> [home.services[a].name for a in s.services]
['Lock', 'LightOff']
>>> [[samples.space.names[j] for j in range(4) if m >> j & 1] for m in s.relevant]
[['who', 'door'], ['who', 'light']]
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numba
import numpy as np

from homecog.environment.core import Core
from homecog.environment.kernels import apply, argmax_row, distance
from homecog.environment.tables import Tables
from homecog.home.codec import Point, Space, finite_span
from homecog.home.groups import project
from homecog.home.model import Home
from homecog.learning.policy import Policy

_jit = numba.njit(cache=True, nogil=True)


@dataclass(frozen=True)
class Sample:
    """One start state: its context, the ordered services, and per service what matters.

    ``relevant[i]`` is a bit mask over the space's dimensions for ``services[i]``.
    """

    point: Point
    services: tuple[int, ...]
    relevant: tuple[int, ...]


@dataclass
class SampleSet:
    """All samples of a home as arrays, one row per start state.

    ``codes[i]`` are the point's codes, ``readings[i, j]`` the raw reading of numeric
    dimension ``j`` (NaN for discrete ones), ``positions[i, a]`` the step at which the policy
    performs service ``a`` (−1: not performed) and ``masks[i, a]`` what matters to it; the
    last column of ``masks`` is what matters to "nothing to do" where no service is performed
    (sample sets stored before that column existed have none: every dimension matters).

    The samples of one group of a home (SPEC §4.1) are those of the group's projection: its
    space is the context features and the group's devices, and ``dims`` and ``services`` give
    the position of each of its dimensions and services in the whole home (None: the same).
    """

    space: Space
    codes: np.ndarray
    readings: np.ndarray
    positions: np.ndarray
    masks: np.ndarray
    dims: tuple[int, ...] | None = None
    services: tuple[int, ...] | None = None

    def __len__(self) -> int:
        return len(self.codes)

    def __getitem__(self, i: int) -> Sample:
        row = self.positions[i]
        done = np.flatnonzero(row >= 0)
        order = tuple(int(a) for a in done[np.argsort(row[done], kind="stable")])
        point = Point(
            codes=tuple(int(x) for x in self.codes[i]),
            readings=tuple(None if np.isnan(r) else float(r) for r in self.readings[i]),
        )
        return Sample(point=point, services=order, relevant=tuple(int(self.masks[i, a]) for a in order))

    def table5(self, rows: int = 5, seed: int = 0) -> list[dict[str, str]]:
        """A few sample rows in the layout of the paper's Table 5 (one row per service)."""
        rng = np.random.default_rng(seed)
        out = []
        home = self.space.home
        for i in rng.permutation(len(self)):
            s = self[int(i)]
            described = self.space.describe(s.point)
            for a, mask in zip(s.services, s.relevant, strict=True):
                row = {
                    dim.name: (described[dim.name] if mask >> j & 1 else "0")
                    for j, dim in enumerate(self.space.dims)
                }
                row["service"] = home.services[a].name
                out.append(row)
                if len(out) == rows:
                    return out
        return out


@_jit
def greedy_positions(t: Tables, q: np.ndarray, limit: int) -> np.ndarray:
    """For every start state, the step at which the greedy roll-out performs each service."""
    (n_devices, need_count, offsets, care, want, need_pos, set_mask, set_val, _, _, _, _, _, _) = t
    n_contexts = len(need_count)
    n_h = 1 << n_devices
    out = np.full((n_contexts, n_h, q.shape[1]), -1, dtype=np.int8)
    for c in range(n_contexts):
        k = need_count[c]
        for h0 in range(n_h):
            h, n = h0, (1 << k) - 1
            step = 0
            while distance(care[c], want[c], h, n) > 0 and step < limit:
                a = argmax_row(q, offsets[c] + (h << k) + n)
                if out[c, h0, a] < 0:
                    out[c, h0, a] = step
                h, n = apply(set_mask, set_val, need_pos, c, h, n, a)
                step += 1
    return out


def _axes(space: Space) -> list[int]:
    """Axis of each dimension in the performed table reshaped to one axis per dimension."""
    n_f, n_d = space.n_features, len(space.dims) - space.n_features
    # contexts are mixed-radix with the first feature most significant; device d is bit d of h,
    # so in C order the last device comes first among the device axes.
    return list(range(n_f)) + [n_f + (n_d - 1 - d) for d in range(n_d)]


def relevance(space: Space, performed: np.ndarray) -> np.ndarray:
    """Per (c, h, a), the bit mask of dimensions whose change alone flips ``performed``."""
    n_c, n_h, n_a = performed.shape
    shape = [dim_size(d) for d in space.dims[: space.n_features]]
    shape += [2] * (len(space.dims) - space.n_features) + [n_a]
    table = performed.reshape(shape)
    mask = np.zeros(table.shape, dtype=np.int64)
    for bit, axis in enumerate(_axes(space)):
        varies = table.any(axis=axis, keepdims=True) & ~table.all(axis=axis, keepdims=True)
        mask |= np.where(varies, np.int64(1) << bit, 0)
    return mask.reshape(n_c, n_h, n_a)


def dim_size(dim: object) -> int:
    return len(dim.values)  # type: ignore[attr-defined]


def start_codes(home: Home) -> np.ndarray:
    """Codes of every start state's point, shape (C·H, dims), in (c, h) order."""
    radix = [f.radix for f in home.features]
    n_contexts, n_devices = home.context_count, len(home.devices)
    ctx = np.stack(np.unravel_index(np.arange(n_contexts), radix), axis=1)
    n_h = 1 << n_devices
    dev = (np.arange(n_h)[:, None] >> np.arange(n_devices)[None, :]) & 1
    return np.concatenate([np.repeat(ctx, n_h, axis=0), np.tile(dev, (n_contexts, 1))], axis=1)


def sufficient_masks(
    space: Space, performed: np.ndarray, sensitive: np.ndarray, codes: np.ndarray
) -> np.ndarray:
    """Grow each positive's sensitive set until its box holds only positives (see module doc)."""
    n_c, n_h, n_a = performed.shape
    n_dims = len(space.dims)
    axes = _axes(space)
    shape = [dim_size(d) for d in space.dims[: space.n_features]] + [2] * (n_dims - space.n_features)
    out = np.zeros((n_c * n_h, n_a), dtype=np.int64)
    strides = np.array([int(np.prod(shape[i + 1 :])) for i in range(n_dims)], dtype=np.int64)
    flat = codes.astype(np.int64) @ strides[axes]  # each point's index in the reshaped table
    for a in range(n_a):
        table = np.ascontiguousarray(performed[:, :, a]).reshape(shape)
        pos = np.flatnonzero(performed[:, :, a].reshape(-1))
        if pos.size == 0:
            continue
        masks = sensitive[:, :, a].reshape(-1)[pos]
        # dimensions most often sensitive for this service are added first
        freq = [int(((masks >> j) & 1).sum()) for j in range(n_dims)]
        order = sorted(range(n_dims), key=lambda j: -freq[j])
        # Points are grouped by mask; a point's box is all-positive when the table reduced
        # with `all` over the other dimensions is true at the point, so each mask is one
        # vectorized test however many boxes it has.
        pending: dict[int, list[np.ndarray]] = {}
        for mask in np.unique(masks):
            pending[int(mask)] = [pos[masks == mask]]
        while pending:
            mask = min(pending)  # any order gives the same result; this one is reproducible
            members = np.concatenate(pending.pop(mask))
            ok = _box_all(table, axes, mask, codes, members, flat[members])
            out[members[ok], a] = mask
            if not ok.all():
                extra = next(j for j in order if not mask >> j & 1)
                pending.setdefault(mask | (1 << extra), []).append(members[~ok])
    return out


def _box_all(
    table: np.ndarray, axes: list[int], mask: int, codes: np.ndarray, members: np.ndarray, flat: np.ndarray
) -> np.ndarray:
    """Whether each member's box (its codes on ``mask``, anything elsewhere) is all true.

    Small boxes are read point by point; large ones from ``table`` reduced over the free axes
    once for all members — whichever touches fewer cells.
    """
    n_dims = len(axes)
    free = sorted(axes[j] for j in range(n_dims) if not mask >> j & 1)
    box = int(np.prod([table.shape[i] for i in free])) if free else 1
    if box * len(members) <= table.size:
        strides = np.array([int(np.prod(table.shape[i + 1 :])) for i in range(n_dims)], dtype=np.int64)
        offsets = np.zeros(1, dtype=np.int64)
        for i in free:  # every combination of the free axes, as flat offsets
            offsets = (offsets[:, None] + np.arange(table.shape[i]) * strides[i]).reshape(-1)
        fixed = [j for j in range(n_dims) if not mask >> j & 1]
        base = flat - (codes[members][:, fixed].astype(np.int64) @ strides[[axes[j] for j in fixed]])
        return table.reshape(-1)[base[:, None] + offsets[None, :]].all(axis=1)
    holds = table.all(axis=tuple(free)) if free else table
    kept = sorted((j for j in range(n_dims) if mask >> j & 1), key=lambda j: axes[j])
    if not kept:
        return np.full(len(members), bool(holds))
    return holds[tuple(codes[members, j] for j in kept)]


def draw_readings(space: Space, codes: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random reading inside its bin for every numeric dimension of every point (NaN for the
    others): two decimals, rounded down so that a reading never leaves its half-open bin."""
    n_points = codes.shape[0]
    numeric = np.full((n_points, len(space.dims)), np.nan)
    for j, dim in enumerate(space.dims):
        if not dim.numeric:
            continue
        feature = space.home.features[j]
        bounds = np.array(finite_span(feature.bins)).reshape(-1, 2)  # type: ignore[arg-type]
        low, high = bounds[codes[:, j], 0], bounds[codes[:, j], 1]
        if dim.kind == "clock":  # a bin wrapping midnight: draw on the unwrapped span
            high = np.where(high <= low, high + 24, high)
        values = np.maximum(np.floor((low + (high - low) * rng.random(n_points)) * 100) / 100, low)
        numeric[:, j] = values % 24 if dim.kind == "clock" else values
    return numeric


def make_samples(
    core: Core,
    q: np.ndarray,
    *,
    seed: int = 0,
    limit: int | None = None,
    rng: np.random.Generator | None = None,
) -> SampleSet:
    """Samples of every start state of a home from a Q table (deterministic given ``seed``, or
    the generator ``rng`` of the readings)."""
    space = Space(core.home)
    limit = limit or 2 * (core.n_devices + int(core.tables.need_count.max())) + 2
    positions = greedy_positions(core.tables, q, limit)
    performed = positions >= 0
    # "nothing to do" is learned like a service: what matters to it is found the same way
    performed = np.concatenate([performed, ~performed.any(axis=2, keepdims=True)], axis=2)
    sensitive = relevance(space, performed)
    codes = start_codes(core.home)
    masks = sufficient_masks(space, performed, sensitive, codes)
    readings = draw_readings(space, codes, rng if rng is not None else np.random.default_rng(seed))
    return SampleSet(
        space=space,
        codes=codes.astype(code_dtype(space)),
        readings=readings,
        positions=positions.reshape(codes.shape[0], -1),
        masks=masks,
    )


def code_dtype(space: Space) -> type:
    """The smallest integer type for the codes of a space."""
    return np.int8 if max(len(d.values) for d in space.dims) < 128 else np.int16


def group_samples(home: Home, policy: Policy, i: int, *, seed: int = 0) -> SampleSet:
    """The samples of every start state of group ``i`` of a policy (SPEC §4.1), never of the
    joint space: the group's projection, with the group's place in the home in ``dims`` and
    ``services``. A joint policy's one group gives the home's samples as before."""
    group = policy.groups[i]
    if policy.joint:
        return make_samples(Core(home), policy.q(i), seed=seed)
    samples = make_samples(
        Core(project(home, group)), policy.q(i), rng=np.random.default_rng([seed, group.index])
    )
    n_f = len(home.features)
    samples.dims = tuple(range(n_f)) + tuple(n_f + d for d in group.device_index)
    samples.services = group.service_index
    return samples


def policy_samples(home: Home, policy: Policy, *, seed: int = 0, ahead: int = 2) -> Iterator[SampleSet]:
    """:func:`group_samples` of every group that has services, in group order.

    The next ``ahead`` groups are made in a worker thread while the caller uses the current
    one (making samples is NumPy and compiled code that releases the GIL; learning them into
    a tree is Python), so at most ``ahead + 1`` groups' samples are in memory at once.
    """
    from concurrent.futures import ThreadPoolExecutor

    todo = [i for i, group in enumerate(policy.groups) if group.services]
    with ThreadPoolExecutor(max_workers=1) as pool:
        pending = [pool.submit(group_samples, home, policy, i, seed=seed) for i in todo[:ahead]]
        for k in range(len(todo)):
            if k + ahead < len(todo):
                pending.append(pool.submit(group_samples, home, policy, todo[k + ahead], seed=seed))
            yield pending.pop(0).result()
