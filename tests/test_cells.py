"""A learner's cell counts in arrays answer as a table per key of tuples would."""

from __future__ import annotations

import random

import numpy as np
import pytest

from homecog.knowledge.cells import CellCounts
from homecog.knowledge.keys import keys_of


@pytest.mark.parametrize("seed", range(5))
def test_cell_counts_equal_a_table_per_key_through_counts_and_take_outs(seed):
    rng = random.Random(seed)
    n_atoms, order = 5, 3
    keys = keys_of(n_atoms, order, recent=True, n_recent=1)
    cells = CellCounts(n_atoms, order)
    cells.index_keys(keys)
    everything = np.arange(len(keys))
    values = ["a", "b", 3, ("bin", 1), -float("inf"), 2.5, "unknown"]
    reference: list[dict[tuple, list[int]]] = [{} for _ in keys]
    examples = []
    for _ in range(300):
        atoms = tuple(rng.choice(values) for _ in range(n_atoms))
        wanted, step = rng.random() < 0.4, rng.choice([1, 1, 5])
        if examples and rng.random() < 0.2:  # an example taken out again, as a moved threshold does
            atoms, wanted, step = examples.pop(rng.randrange(len(examples)))
            step = -step
        else:
            examples.append((atoms, wanted, step))
        p, n = cells.count(atoms, everything, wanted=wanted, step=step)
        for i, key in enumerate(keys):
            counts = reference[i].setdefault(tuple(atoms[j] for j in key), [0, 0, 0])
            assert (p[i], n[i]) == (counts[0], counts[1])
            counts[0 if wanted else 1] += step
            if step > 0:
                counts[2] = int(wanted)
    for i, key in enumerate(keys):
        expected = {cell: tuple(c) for cell, c in reference[i].items() if c[0] or c[1]}
        assert cells.table(i) == expected
        for cell, counts in reference[i].items():
            atoms = [None] * n_atoms
            for j, atom in zip(key, cell, strict=True):
                atoms[j] = atom
            assert cells.get(i, atoms) == (tuple(counts) if counts[0] or counts[1] else None)
    unseen = ("never", "seen", "atoms", "at", "all")
    p, n, _ = cells.read(unseen, everything)
    assert p[0] + n[0] == sum(w for _, _, w in examples)  # the empty key holds every example
    assert not (p[1:] + n[1:]).any()  # no other cell holds atoms never counted


def test_too_many_keys_or_atoms_are_refused():
    cells = CellCounts(3, 3)
    with pytest.raises(ValueError, match="at most 1024 keys"):
        cells.index_keys([(0,)] * 1025)
    with pytest.raises(ValueError, match="do not fit"):
        cells.index_keys([(0, 1, 2, 0, 1, 2)])
