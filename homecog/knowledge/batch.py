"""A sample set learned into the tree's data at once (``IHDRTree.learn_many``).

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
from homecog.knowledge.update import SampleRow, learn_row

if TYPE_CHECKING:
    from homecog.knowledge.tree import Tree


def learn_sample_set(tree: Tree, samples: Any) -> None:
    """Learn a :class:`~homecog.knowledge.samples.SampleSet` into ``tree`` (see the module)."""
    if tree.mode == "paper":
        samples = samples.expand()
    positions = samples.positions
    weight = samples.weights()  # how many of the home's start states each row stands for
    n_services = positions.shape[1]
    # a group's samples: their services at their places in the whole home
    where = samples.services if samples.services is not None else tuple(range(n_services))
    done = positions >= 0
    for a in range(n_services):
        later = done & done[:, [a]] & (positions > positions[:, [a]])
        tree.precedence[where[a], list(where)] += (later * weight[:, None]).sum(axis=0)
    tree.before = None
    for a in range(n_services + 1):
        rows, row_masks, row_pos = _rows_of(samples, a)
        if rows.size:
            target = where[a] if a < n_services else len(tree.home.services)
            _learn_rows(tree, samples, target, rows, row_masks, row_pos, weight)


def _rows_of(samples: Any, a: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows of the samples that perform service ``a`` (past the last service: those that
    perform none), what matters to it in each, and the step it comes at."""
    positions, masks = samples.positions, samples.masks
    n_services = positions.shape[1]
    if a < n_services:
        rows = np.flatnonzero(positions[:, a] >= 0)
        return rows, masks[rows, a], positions[rows, a].astype(np.float64)
    rows = np.flatnonzero((positions < 0).all(axis=1))
    if masks.shape[1] > n_services:
        row_masks = masks[rows, n_services]
    else:
        row_masks = np.full(len(rows), (1 << len(samples.space.dims)) - 1, dtype=np.int64)
    return rows, row_masks, np.zeros(len(rows))


def _learn_rows(
    tree: Tree,
    samples: Any,
    target: int,
    rows: np.ndarray,
    row_masks: np.ndarray,
    row_pos: np.ndarray,
    weight: np.ndarray,
) -> None:
    """Learn the distinct rows among ``rows`` into service ``target``, each with its count."""
    codes, readings = samples.codes, samples.readings
    radices = tuple(len(d.values) for d in samples.space.dims)
    first, inverse, _ = distinct_rows(row_masks, codes[rows], radices)
    counts = np.bincount(inverse, weights=weight[rows], minlength=len(first)).astype(np.int64)
    pos_sums = np.bincount(inverse, weights=row_pos * weight[rows], minlength=len(first))
    stats = _reading_stats(tree, samples, rows, inverse, len(first))
    order = np.argsort(first, kind="stable")  # in the order the samples came
    picked = rows[first[order]]
    row_codes = codes[picked].tolist()
    row_readings = readings[picked].tolist()
    local_masks = row_masks[first[order]].tolist()
    row_counts, row_sums = counts[order].tolist(), pos_sums[order].tolist()
    row_stats = {j: [stats[j][k][order].tolist() for k in range(3)] for j in stats}
    dims = samples.dims if samples.dims is not None else tuple(range(len(samples.space.dims)))
    place = _Placer(len(tree.space), dims, _class_sets(samples))
    for i in range(len(order)):
        mask, full_codes, full_readings, sets = place(local_masks[i], row_codes[i], row_readings[i])
        extra = {dims[j]: (st[0][i], st[1][i], st[2][i]) for j, st in row_stats.items()}
        row = SampleRow(mask, full_codes, full_readings, row_counts[i], row_sums[i], extra, sets)
        learn_row(tree, target, row)


def _reading_stats(
    tree: Tree, samples: Any, rows: np.ndarray, inverse: np.ndarray, n_distinct: int
) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Per numeric dimension, the sum, least and greatest reading of each distinct row: readings
    matter to the paper's clusters (mean ± range); multi keeps bins only."""
    numeric = [j for j, d in enumerate(samples.space.dims) if d.numeric]
    if tree.mode != "paper" or not numeric:
        return {}
    stats = {}
    grouped = np.argsort(inverse, kind="stable")
    for j in numeric:
        vals = samples.readings[rows, j]
        low, high = group_min_max(grouped, inverse, vals, n_distinct)
        stats[j] = (np.bincount(inverse, weights=vals, minlength=n_distinct), low, high)
    return stats


class _Placer:
    """A sample row's codes and readings at their places in the whole home's space."""

    def __init__(self, width: int, dims: tuple[int, ...], sets_of: dict[int, list[frozenset[int]]]) -> None:
        self.width, self.dims, self.sets_of = width, dims, sets_of

    def __call__(
        self, local_mask: int, codes: list[int], readings: list[float]
    ) -> tuple[int, tuple[int, ...], tuple[float | None, ...], dict[int, frozenset[int]]]:
        """(mask, codes, readings, sets of a class's values) of one row over the home."""
        full_codes = [0] * self.width
        full_readings: list[float | None] = [None] * self.width
        mask = 0
        sets = {}
        for j in bits(local_mask):
            g = self.dims[j]
            mask |= 1 << g
            full_codes[g] = codes[j]
            if j in self.sets_of:
                sets[g] = self.sets_of[j][codes[j]]
                full_codes[g] = min(sets[g])
            r = readings[j]
            full_readings[g] = None if r != r else r  # NaN: not a reading
        return mask, tuple(full_codes), tuple(full_readings), sets


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
