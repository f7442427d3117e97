"""A sample set learned into the tree at once (``IHDRTree.learn_many``).

The same as ``learn_one`` for each sample in order, but each distinct row — a service, what
matters to it, the codes there — is learned once with its count, which is what makes building
from hundreds of thousands of samples quick. A group's samples over its classes of contexts
(:mod:`homecog.home.classes`) are learned as boxes holding every value of a class (multi
mode), each row counting the contexts it stands for, so that the tree's counts and priorities
are those of a sample per context; the paper's clusters, which keep readings, learn the samples
expanded to every context of the home.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from homecog.knowledge.box_index import distinct_rows, group_min_max
from homecog.knowledge.model import bits

if TYPE_CHECKING:
    from homecog.knowledge.ihdr import IHDRTree


def learn_sample_set(tree: IHDRTree, samples: Any) -> None:
    """Learn a :class:`~homecog.knowledge.samples.SampleSet` into ``tree`` (see the module)."""
    if tree.mode == "paper":
        samples = samples.expand()
    sets_of = _class_sets(samples)
    codes, readings, positions, masks = samples.codes, samples.readings, samples.positions, samples.masks
    weight = samples.weights()  # how many of the home's start states each row stands for
    local_dims = samples.space.dims
    n_dims = len(local_dims)
    # a group's samples: their dimensions and services at their places in the whole home
    dims = samples.dims if samples.dims is not None else tuple(range(n_dims))
    n_services = positions.shape[1]
    where = samples.services if samples.services is not None else tuple(range(n_services))
    numeric = [j for j, d in enumerate(local_dims) if d.numeric]
    radices = tuple(len(d.values) for d in local_dims)
    idle = (positions < 0).all(axis=1)
    done = positions >= 0
    for a in range(n_services):
        both = done & done[:, [a]]
        later = both & (positions > positions[:, [a]])
        tree._precedence[where[a], list(where)] += (later * weight[:, None]).sum(axis=0)
    tree._before = None
    width = len(tree._space)
    for a in range(n_services + 1):
        if a < n_services:
            rows = np.flatnonzero(positions[:, a] >= 0)
            row_masks = masks[rows, a]
            row_pos = positions[rows, a].astype(np.float64)
        else:
            rows = np.flatnonzero(idle)
            if masks.shape[1] > n_services:
                row_masks = masks[rows, n_services]
            else:
                row_masks = np.full(len(rows), (1 << n_dims) - 1, dtype=np.int64)
            row_pos = np.zeros(len(rows))
        if rows.size == 0:
            continue
        first, inverse, _ = distinct_rows(row_masks, codes[rows], radices)
        counts = np.bincount(inverse, weights=weight[rows], minlength=len(first)).astype(np.int64)
        pos_sums = np.bincount(inverse, weights=row_pos * weight[rows], minlength=len(first))
        stats = {}
        # readings matter to the paper's clusters (mean ± range); multi keeps bins only
        if tree.mode == "paper" and numeric:
            grouped = np.argsort(inverse, kind="stable")
            for j in numeric:
                vals = readings[rows, j]
                low, high = group_min_max(grouped, inverse, vals, len(first))
                stats[j] = (np.bincount(inverse, weights=vals, minlength=len(first)), low, high)
        target = where[a] if a < n_services else len(tree.home.services)
        order = np.argsort(first, kind="stable")  # in the order the samples came
        picked = rows[first[order]]
        row_codes = codes[picked].tolist()
        row_readings = readings[picked].tolist()
        local_masks = row_masks[first[order]].tolist()
        row_counts, row_sums = counts[order].tolist(), pos_sums[order].tolist()
        row_stats = {j: [stats[j][k][order].tolist() for k in range(3)] for j in stats}
        for i in range(len(order)):
            local_mask = local_masks[i]
            full_codes = [0] * width
            full_readings: list[float | None] = [None] * width
            mask = 0
            sets = {}
            for j in bits(local_mask):
                g = dims[j]
                mask |= 1 << g
                full_codes[g] = row_codes[i][j]
                if j in sets_of:
                    sets[g] = sets_of[j][row_codes[i][j]]
                    full_codes[g] = min(sets[g])
                r = row_readings[i][j]
                full_readings[g] = None if r != r else r  # NaN: not a reading
            extra = {dims[j]: (st[0][i], st[1][i], st[2][i]) for j, st in row_stats.items()}
            tree._learn_row(
                target,
                mask,
                tuple(full_codes),
                tuple(full_readings),
                row_counts[i],
                row_sums[i],
                extra,
                sets,
            )


def _class_sets(samples: Any) -> dict[int, list[frozenset[int]]]:
    """Per feature dimension of a sample set over classes that holds several values in a class,
    the home's values of each class code."""
    classes = getattr(samples, "classes", None)
    if classes is None:
        return {}
    return {
        j: [frozenset(m) for m in members]
        for j, members in enumerate(classes.members)
        if len(members) < len(classes.of[j])
    }
