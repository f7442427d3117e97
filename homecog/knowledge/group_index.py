"""Fast cognition on large homes: the responding cluster of every service, group by group.

A multi tree built from a grouped policy has, for each service, clusters over the context
features and the devices of the service's group, and each of its conditions on a
feature is a union of the group's classes of that feature's values (:mod:`homecog.home.classes`).
So for each group a table over (the group's classes of contexts, the group's device states) can
hold the responding cluster of each of its services: its size is that of the group's Q table,
never the joint space's, and it does not grow with context values the group cannot tell apart.
One cognition reads one row of every group's table, all at once with NumPy, instead of looking
up every cluster of every service. Services with a cluster outside their group (``learn_one``
over other devices) or a condition that splits a class are left to the tree's own lookup.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from homecog.home.classes import Classes, group_classes
from homecog.home.groups import Group, device_groups
from homecog.home.model import Home

#: Most bytes the tables of all groups may take together.
LIMIT_BYTES = 512 * 2**20


def _axis(classes: Classes, f: int, cond: Any) -> np.ndarray | None:
    """The class codes of a condition on feature ``f``, or None when it splits a class."""
    chosen = sorted({classes.of[f][k] for k in cond})
    if any(not set(classes.members[f][c]) <= cond for c in chosen):
        return None
    return np.array(chosen, dtype=np.intp)


class GroupIndex:
    """Per group, a table ``[class context · 2^devices + device states, service] -> cluster``."""

    def __init__(self, home: Home, nodes: Sequence[Any]) -> None:
        """``nodes[a]`` is the service node of service ``a`` (its ``clusters`` are read)."""
        self.home = home
        n_f = len(home.features)
        self.n_features = n_f
        tables, services, offsets, sizes = [], [], [0], []
        self.outside: list[int] = []  # services left to the tree's own lookup
        dev_group = np.zeros(len(home.devices), dtype=np.int64)
        dev_weight = np.zeros(len(home.devices), dtype=np.int64)
        covered = [g for g in device_groups(home) if g.services]
        # per feature, per group, the value -> class code times the class context's stride
        self._class_of = [np.zeros((len(covered), f.radix), dtype=np.int64) for f in home.features]
        for gi, group in enumerate(covered):
            classes = group_classes(home, group)
            stride = 1
            for f in reversed(range(n_f)):
                self._class_of[f][gi] = np.asarray(classes.of[f], dtype=np.int64) * stride
                stride *= len(classes.members[f])
            tables.append(self._table(group, classes, nodes, self.outside))
            services.append(list(group.service_index))
            g = len(group.devices)
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

    def _table(self, group: Group, classes: Classes, nodes: Sequence[Any], outside: list[int]) -> np.ndarray:
        n_f = self.n_features
        shape = [*classes.radices, *([2] * len(group.devices))]
        own = {j: j for j in range(n_f)} | {n_f + d: n_f + k for k, d in enumerate(group.device_index)}
        table = np.full([*shape, len(group.services)], -1, dtype=np.int16)
        for k, a in enumerate(group.service_index):
            clusters = nodes[a].clusters
            if any(j not in own for c in clusters for j in c.conditions) or len(clusters) >= 2**15:
                outside.append(a)
                continue
            boxes = []
            for cluster in clusters:
                axes = [np.arange(n) for n in shape]
                for j, cond in cluster.conditions.items():
                    axis = _axis(classes, j, cond) if j < n_f else np.array(sorted(cond), dtype=np.intp)  # type: ignore[arg-type]
                    if axis is None:
                        break
                    axes[own[j]] = axis
                else:
                    boxes.append(axes)
                    continue
                break
            if len(boxes) < len(clusters):
                outside.append(a)
                continue
            # the first cluster (lowest id) wins where boxes overlap, as in the tree's lookup
            for i in sorted(range(len(clusters)), key=lambda i: -clusters[i].id):
                table[(*np.ix_(*boxes[i]), k)] = i
        return table.reshape(-1, len(group.services))

    @staticmethod
    def size(home: Home) -> int:
        """Bytes the tables of a home would take."""
        return sum(
            (group_classes(home, g).count << len(g.devices)) * len(g.services) * 2
            for g in device_groups(home)
            if g.services
        )

    def responding(self, codes: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """(services, cluster indices) of every service whose cluster responds at ``codes``."""
        c = sum(self._class_of[f][:, codes[f]] for f in range(self.n_features))
        devices = np.asarray(codes[self.n_features :], dtype=np.int64)
        h = np.bincount(self._dev_group, weights=devices * self._dev_weight, minlength=self.groups)
        rows = self.table[self.offsets + c * self.sizes + h.astype(np.int64)]
        hit = (rows >= 0) & (self.service >= 0)
        return self.service[hit], rows[hit]
