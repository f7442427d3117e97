"""The boxes of a multi-mode service node, indexed (``multi`` mode).

A multi node keeps boxes: clusters whose conditions are value sets on the dimensions that matter.
:class:`BoxIndex` finds, for a point, the responding box (the lowest id where boxes of different
dimensions overlap), whether a box over a set of dimensions covers a sample, and a box to merge
with (same dimensions, equal on all but one: their union is again a box).
:func:`distinct_rows` groups a batch of sample rows into the distinct boxes they make.

>>> from homecog.knowledge.model import Cluster
>>> index = BoxIndex()
>>> index.add(Cluster(id=1, conditions={0: frozenset({1, 2}), 2: frozenset({0})}))
>>> index.lookup((2, 5, 0)).id, index.lookup((0, 5, 0))
(1, None)
"""

from __future__ import annotations

import itertools
import operator
from collections.abc import Sequence
from typing import Any

import numpy as np

from homecog.knowledge.model import Cluster, Condition, bits


class _One:
    """codes -> (codes[j],): itemgetter returns a bare value for a single index."""

    def __init__(self, j: int | None) -> None:
        self.j = j

    def __call__(self, codes: Sequence[int]) -> tuple[int, ...]:
        return () if self.j is None else (codes[self.j],)


def _getter(dims: tuple[int, ...]) -> Any:
    """codes -> the tuple of codes at ``dims``."""
    if len(dims) >= 2:
        return operator.itemgetter(*dims)
    return _One(dims[0] if dims else None)


class BoxIndex:
    """The clusters of a multi-mode node, grouped by related dimensions for fast lookup."""

    def __init__(self) -> None:
        self.by_mask: dict[int, tuple[Any, dict[tuple[int, ...], Cluster]]] = {}
        # (mask, j, the box's values on its other dimensions) -> boxes: merge partners at a glance
        self.partners: dict[tuple[Any, ...], dict[int, Cluster]] = {}
        self._keys: dict[int, list[tuple[Any, ...]]] = {}  # cluster id (unique in a node) -> partner keys

    @staticmethod
    def partner_keys(cluster: Cluster, mask: int | None = None) -> list[tuple[Any, ...]]:
        dims = bits(cluster.mask if mask is None else mask)
        values = [cluster.conditions[d] for d in dims]
        mask = sum(1 << j for j in dims)
        return [(mask, j, (*values[:i], *values[i + 1 :])) for i, j in enumerate(dims)]

    def add(self, cluster: Cluster, keys: list[tuple[Any, ...]] | None = None) -> None:
        self.point_to(cluster, cluster.conditions)
        self.link(cluster, keys if keys is not None else self.partner_keys(cluster))

    def point_to(self, cluster: Cluster, conditions: dict[int, Condition], mask: int | None = None) -> None:
        """Make every point of the box ``conditions`` answer ``cluster``."""
        mask = cluster.mask if mask is None else mask
        entry = self.by_mask.get(mask)
        if entry is None:
            entry = self.by_mask[mask] = (_getter(bits(mask)), {})
        table = entry[1]
        values = [conditions[j] for j in bits(mask)]
        if all(len(v) == 1 for v in values):  # type: ignore[arg-type]
            table[tuple(next(iter(v)) for v in values)] = cluster  # type: ignore[call-overload]
            return
        for key in itertools.product(*values):  # type: ignore[arg-type]
            table[key] = cluster

    def link(self, cluster: Cluster, keys: list[tuple[Any, ...]]) -> None:
        """Register a box as a merge partner under its keys."""
        self._keys[cluster.id] = keys
        for key in keys:
            self.partners.setdefault(key, {})[cluster.id] = cluster

    def unlink(self, cluster: Cluster) -> None:
        """Withdraw a box from the merge partners (its points still answer it)."""
        for key in self._keys.pop(cluster.id):
            del self.partners[key][cluster.id]

    def partner(self, box: Cluster, keys: list[tuple[Any, ...]]) -> Cluster | None:
        """A box over the same dimensions equal to ``box`` on all but one (their union is a box).

        ``keys`` are ``partner_keys(box)``."""
        for key in keys:
            j = key[1]
            found = [
                c
                for c in self.partners.get(key, {}).values()
                if c is not box and c.conditions[j] != box.conditions[j]
            ]
            if found:
                return min(found, key=lambda c: c.id)
        return None

    def lookup(self, codes: Sequence[int]) -> Cluster | None:
        best = None
        for get, table in self.by_mask.values():
            hit = table.get(get(codes))
            if hit is not None and (best is None or hit.id < best.id):
                best = hit
        return best

    def covering(self, mask: int, key: tuple[int, ...]) -> Cluster | None:
        entry = self.by_mask.get(mask)
        return None if entry is None else entry[1].get(key)

    def covering_box(self, mask: int, values: Sequence[frozenset[int]], limit: int = 4096) -> Cluster | None:
        """The one box over ``mask`` that holds every point of a box of values (its values per
        dimension of ``mask``, lowest first), or None; boxes of more than ``limit`` points are
        not looked into."""
        entry = self.by_mask.get(mask)
        size = 1
        for v in values:
            size *= len(v)
        if entry is None or size > limit:
            return None
        found = {id(entry[1].get(key)): entry[1].get(key) for key in itertools.product(*values)}
        (hit,) = found.values() if len(found) == 1 else (None,)
        return hit


def distinct_rows(
    masks: np.ndarray, codes: np.ndarray, radices: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Groups of rows with the same mask and the same codes on it: (first row, group, size)."""
    n_dims = codes.shape[1]
    bits = ((masks[:, None] >> np.arange(n_dims)[None, :]) & 1).astype(bool)
    shifted = np.where(bits, codes.astype(np.int64) + 1, 0)  # 0: unrelated
    span = 1
    for r in radices:
        span *= r + 1
    if span * (1 << n_dims) < 2**62:  # one int64 key per row: fast to sort
        key = masks.astype(np.int64)
        for j in range(n_dims):
            key = key * (radices[j] + 1) + shifted[:, j]
        _, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    else:
        rows = np.concatenate([masks[:, None], shifted], axis=1)
        _, first, inverse, counts = np.unique(
            rows, axis=0, return_index=True, return_inverse=True, return_counts=True
        )
    return first, inverse.reshape(-1), counts


def group_min_max(
    order: np.ndarray, inverse: np.ndarray, values: np.ndarray, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per group of ``inverse``, the least and greatest value (``order`` sorts ``inverse``)."""
    starts = np.searchsorted(inverse[order], np.arange(size))
    ordered = values[order]
    return np.minimum.reduceat(ordered, starts), np.maximum.reduceat(ordered, starts)
