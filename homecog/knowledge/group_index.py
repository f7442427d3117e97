"""Fast cognition on large homes: the responding cluster of every service, group by group.

A multi tree built from a grouped policy has, for each service, clusters over the context
features and the devices of the service's group (SPEC §4.1). So for each group a table over
(context, the group's device states) can hold the responding cluster of each of its services:
its size is that of the group's Q table, never the joint space's. One cognition reads one row
of every group's table, all at once with NumPy, instead of looking up every cluster of every
service. Services with a cluster outside their group (``learn_one`` over other devices) are
left to the tree's own lookup.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from homecog.home.groups import device_groups
from homecog.home.model import Home

#: Most bytes the tables of all groups may take together.
LIMIT_BYTES = 512 * 2**20


class GroupIndex:
    """Per group, a table ``[context · 2^devices + device states, service] -> cluster index``."""

    def __init__(self, home: Home, nodes: Sequence[Any]) -> None:
        """``nodes[a]`` is the service node of service ``a`` (its ``clusters`` are read)."""
        self.home = home
        n_f = len(home.features)
        radix = [f.radix for f in home.features]
        self._strides = [int(np.prod(radix[j + 1 :], dtype=np.int64)) for j in range(n_f)]
        self.n_features = n_f
        tables, services, offsets, sizes = [], [], [0], []
        self.outside: list[int] = []  # services left to the tree's own lookup
        dev_group = np.zeros(len(home.devices), dtype=np.int64)
        dev_weight = np.zeros(len(home.devices), dtype=np.int64)
        covered = [g for g in device_groups(home) if g.services]
        for gi, group in enumerate(covered):
            g = len(group.devices)
            shape = [*radix, *([2] * g)]
            own = {j: j for j in range(n_f)} | {n_f + d: n_f + k for k, d in enumerate(group.device_index)}
            table = np.full([*shape, len(group.services)], -1, dtype=np.int16)
            kept = []
            for k, a in enumerate(group.service_index):
                clusters = nodes[a].clusters
                if any(j not in own for c in clusters for j in c.conditions) or len(clusters) >= 2**15:
                    self.outside.append(a)
                    continue
                kept.append(a)
                # the first cluster (lowest id) wins where boxes overlap, as in the tree's lookup
                for i in sorted(range(len(clusters)), key=lambda i: -clusters[i].id):
                    axes = [np.arange(n) for n in shape]
                    for j, cond in clusters[i].conditions.items():
                        axes[own[j]] = np.array(sorted(cond), dtype=np.intp)  # type: ignore[arg-type]
                    table[(*np.ix_(*axes), k)] = i
            tables.append(table.reshape(-1, len(group.services)))
            services.append(list(group.service_index))
            sizes.append(1 << g)
            offsets.append(offsets[-1] + tables[-1].shape[0])
            for k, d in enumerate(group.device_index):
                dev_group[d] = gi
                dev_weight[d] = 1 << (g - 1 - k)  # the first device is the most significant axis
        width = max((t.shape[1] for t in tables), default=0)
        self.table = np.full((offsets[-1], width), -1, dtype=np.int16)
        for t, start in zip(tables, offsets, strict=False):
            self.table[start : start + t.shape[0], : t.shape[1]] = t
        self.offsets = np.array(offsets[:-1], dtype=np.int64)
        self.sizes = np.array(sizes, dtype=np.int64)
        self.service = np.full((len(tables), width), -1, dtype=np.int64)
        for gi, svc in enumerate(services):
            self.service[gi, : len(svc)] = svc
        self.service[np.isin(self.service, self.outside)] = -1
        self._dev_group, self._dev_weight = dev_group, dev_weight
        self.groups = len(tables)

    @staticmethod
    def size(home: Home) -> int:
        """Bytes the tables of a home would take."""
        c = home.context_count
        return sum((c << len(g.devices)) * len(g.services) * 2 for g in device_groups(home) if g.services)

    def responding(self, codes: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """(services, cluster indices) of every service whose cluster responds at ``codes``."""
        c = sum(codes[j] * s for j, s in enumerate(self._strides))
        devices = np.asarray(codes[self.n_features :], dtype=np.int64)
        h = np.bincount(self._dev_group, weights=devices * self._dev_weight, minlength=self.groups)
        rows = self.table[self.offsets + c * self.sizes + h.astype(np.int64)]
        hit = (rows >= 0) & (self.service >= 0)
        return self.service[hit], rows[hit]
