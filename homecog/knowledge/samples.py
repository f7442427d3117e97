"""Samples from the Q table (the paper's §3.1, §4.2, Tables 5, 7, 8).

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
from homecog.environment.kernels import greedy_walk
from homecog.environment.tables import Tables
from homecog.home.classes import Classes, group_classes
from homecog.home.codec import Point, Space, reading_in_bin
from homecog.home.groups import Group, project
from homecog.home.model import Home
from homecog.knowledge.relevance import relevance, sufficient_masks
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

    The samples of one group of a home are those of the group's projection: its
    space is the context features and the group's devices, and ``dims`` and ``services`` give
    the position of each of its dimensions and services in the whole home (None: the same).
    Its contexts are the group's classes (``classes``, :mod:`homecog.home.classes`): a row
    stands for every context of its class, a feature's code is the class; ``origin`` (the home,
    the group and the seed) makes the rows of the home's own start states (:meth:`expand`).
    """

    space: Space
    codes: np.ndarray
    readings: np.ndarray
    positions: np.ndarray
    masks: np.ndarray
    dims: tuple[int, ...] | None = None
    services: tuple[int, ...] | None = None
    classes: Classes | None = None
    origin: tuple[Home, Group, int] | None = None

    def __len__(self) -> int:
        return len(self.codes)

    def weights(self) -> np.ndarray:
        """Per row, how many of the home's start states it stands for (1 without classes)."""
        if self.classes is None:
            return np.ones(len(self), dtype=np.int64)
        return np.repeat(self.classes.weights(), 1 << (len(self.space.dims) - self.space.n_features))

    def rows(self, codes: np.ndarray, h: np.ndarray) -> np.ndarray:
        """The row of each start state given by the home's feature codes (one row each) and the
        sample set's device bits (device ``k`` of its space is bit ``k``)."""
        n_f = self.space.n_features
        if self.classes is not None:
            ctx = self.classes.indices(np.asarray(codes)[:, :n_f])
        else:
            radix = [len(d.values) for d in self.space.dims[:n_f]]
            ctx = np.ravel_multi_index(tuple(np.asarray(codes)[:, :n_f].T), radix)
        return (ctx.astype(np.int64) << (len(self.space.dims) - n_f)) + np.asarray(h, dtype=np.int64)

    def expand(self) -> SampleSet:
        """The same samples with a row per start state of the home's own contexts, readings drawn
        inside their bins as a build without classes draws them (for learners that read the
        readings: the paper's clusters, the baselines)."""
        if self.classes is None or self.origin is None:
            return self
        home, group, seed = self.origin
        full = project(home, group, classes=False)
        space = Space(full)
        codes = start_codes(full)
        n_f = space.n_features
        h = (codes[:, n_f:].astype(np.int64) << np.arange(len(space.dims) - n_f)).sum(axis=1)
        rows = self.rows(codes, h)
        return SampleSet(
            space=space,
            codes=codes.astype(code_dtype(space)),
            readings=draw_readings(space, codes, np.random.default_rng([seed, group.index])),
            positions=self.positions[rows],
            masks=self.masks[rows],
            dims=self.dims,
            services=self.services,
        )

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
    n_contexts = len(t.need_count)
    n_h = 1 << t.n_devices
    services = np.empty(limit, dtype=np.int64)
    out = np.full((n_contexts, n_h, q.shape[1]), -1, dtype=np.int8)
    for c in range(n_contexts):
        for h0 in range(n_h):
            count, _ = greedy_walk(t, q, c, h0, (1 << t.need_count[c]) - 1, False, services)
            for step in range(count):
                if out[c, h0, services[step]] < 0:
                    out[c, h0, services[step]] = step
    return out


def start_codes(home: Home) -> np.ndarray:
    """Codes of every start state's point, shape (C·H, dims), in (c, h) order."""
    radix = [f.radix for f in home.features]
    n_contexts, n_devices = home.context_count, len(home.devices)
    ctx = np.stack(np.unravel_index(np.arange(n_contexts), radix), axis=1)
    n_h = 1 << n_devices
    dev = (np.arange(n_h)[:, None] >> np.arange(n_devices)[None, :]) & 1
    return np.concatenate([np.repeat(ctx, n_h, axis=0), np.tile(dev, (n_contexts, 1))], axis=1)


def draw_readings(space: Space, codes: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A random reading inside its bin for every numeric dimension of every point (NaN for the
    others): two decimals, rounded down so that a reading never leaves its half-open bin."""
    n_points = codes.shape[0]
    numeric = np.full((n_points, len(space.dims)), np.nan)
    for j, dim in enumerate(space.dims):
        if not dim.numeric:
            continue
        numeric[:, j] = reading_in_bin(space.home.features[j], codes[:, j], rng.random(n_points))
    return numeric


def make_samples(
    core: Core,
    q: np.ndarray,
    *,
    seed: int = 0,
    limit: int | None = None,
    rng: np.random.Generator | None = None,
    weights: np.ndarray | None = None,
) -> SampleSet:
    """Samples of every start state of a home from a Q table (deterministic given ``seed``, or
    the generator ``rng`` of the readings); ``weights``: per context, how many of a home's
    contexts it stands for (a group's classes)."""
    space = Space(core.home)
    limit = limit or 2 * (core.n_devices + int(core.tables.need_count.max())) + 2
    positions = greedy_positions(core.tables, q, limit)
    performed = positions >= 0
    # "nothing to do" is learned like a service: what matters to it is found the same way
    performed = np.concatenate([performed, ~performed.any(axis=2, keepdims=True)], axis=2)
    sensitive = relevance(space, performed)
    codes = start_codes(core.home)
    per_row = None if weights is None else np.repeat(weights, 1 << core.n_devices)
    masks = sufficient_masks(space, performed, sensitive, codes, per_row)
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
    """The samples of every start state of group ``i`` of a policy, never of the
    joint space: the group's projection, with the group's place in the home in ``dims`` and
    ``services``. A joint policy's one group gives the home's samples as before."""
    group = policy.groups[i]
    if policy.joint:
        return make_samples(Core(home), policy.q(i), seed=seed)
    classes = group_classes(home, group)
    samples = make_samples(
        Core(project(home, group)),
        policy.q(i),
        rng=np.random.default_rng([seed, group.index]),
        weights=classes.weights(),
    )
    return placed(samples, home, group, seed)


def placed(samples: SampleSet, home: Home, group: Group, seed: int) -> SampleSet:
    """A group's samples told where they lie in the home: its dimensions, services, classes."""
    n_f = len(home.features)
    samples.dims = tuple(range(n_f)) + tuple(n_f + d for d in group.device_index)
    samples.services = group.service_index
    samples.classes = group_classes(home, group)
    samples.origin = (home, group, seed)
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
