"""What matters to a service, learned from the policy (the paper's Table 5 zeros).

Over the table of "does the policy perform service *a* from start state *s*", dimension *j*
matters at *s* when changing *j* alone flips the answer (:func:`relevance`). Where the decision
is over-determined no single change flips it, so each positive's set is grown, the dimensions
most often relevant to the service first, until its box holds only positives
(:func:`sufficient_masks`). Start states may stand for several of the home's (a group's classes
of contexts, :mod:`homecog.home.classes`): ``weights`` counts them, so the order in which
dimensions are added is the one the home's own start states would give.
"""

from __future__ import annotations

import numpy as np

from homecog.home.codec import Space


def axes_of(space: Space) -> list[int]:
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
    for bit, axis in enumerate(axes_of(space)):
        varies = table.any(axis=axis, keepdims=True) & ~table.all(axis=axis, keepdims=True)
        mask |= np.where(varies, np.int64(1) << bit, 0)
    return mask.reshape(n_c, n_h, n_a)


def dim_size(dim: object) -> int:
    return len(dim.values)  # type: ignore[attr-defined]


def sufficient_masks(
    space: Space,
    performed: np.ndarray,
    sensitive: np.ndarray,
    codes: np.ndarray,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """Grow each positive's sensitive set until its box holds only positives (see the module);
    ``weights[i]``: how many of the home's start states row ``i`` stands for (default 1)."""
    n_c, n_h, n_a = performed.shape
    n_dims = len(space.dims)
    axes = axes_of(space)
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
        w = np.ones(len(pos), dtype=np.int64) if weights is None else weights[pos]
        freq = [int((((masks >> j) & 1) * w).sum()) for j in range(n_dims)]
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
