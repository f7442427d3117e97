"""The counts of one learner's cells, every key's at once, in arrays.

A learner (:mod:`homecog.knowledge.evidence`) counts the wanted and unwanted examples of each
cell of each of its keys. Every example touches one cell of every key, a hundred or more: kept
as a dict of tuples per key, that is a hundred Python steps per example and service. Here an
atom is coded by the order it was first seen at its position, a cell is named by one integer
(its key's position in the low bits, its atoms' codes above), and the counts live in arrays
indexed by a slot per named cell; an example's cells are found, read and counted with a few
array operations.

A cell whose counts fell back to nothing (an example taken out when a threshold moved) reads as
absent, as a cell never seen does.

>>> cells = CellCounts(n_atoms=2, order=2)
>>> cells.index_keys([(), (0,), (0, 1)])
>>> keys = np.arange(3)
>>> before = cells.count(("sofa", 1), keys, wanted=True, step=1)
>>> before[0].tolist(), before[1].tolist()  # every cell was empty
([0, 0, 0], [0, 0, 0])
>>> _ = cells.count(("bed", 1), keys, wanted=False, step=1)
>>> cells.get(0, ("sofa", 0)), cells.get(1, ("sofa", 0)), cells.get(2, ("sofa", 0))
((1, 1, 0), (1, 0, 1), None)
>>> cells.table(1)
{('sofa',): (1, 0, 1), ('bed',): (0, 1, 0)}
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from itertools import repeat

import numpy as np

#: the low bits of a cell's name: its key's position (a learner has at most 2**KEY_BITS keys)
KEY_BITS = 10
#: the bits of a cell's name in all (they stay within a signed 64-bit integer)
NAME_BITS = 62


class CellCounts:
    """Per cell of every key: wanted and unwanted examples (weighted) and the latest label."""

    def __init__(self, n_atoms: int, order: int) -> None:
        self.n_atoms = n_atoms
        # per atom position, its atoms' codes; a code past what a cell's name can hold is the
        # last one (a position with that many different atoms shares its rarest cells)
        self._codes: list[dict[Hashable, int]] = [{} for _ in range(n_atoms + 1)]
        self._atoms: list[list[Hashable]] = [[] for _ in range(n_atoms + 1)]
        self._bits = (NAME_BITS - KEY_BITS) // max(order, 1)
        self._slot: dict[int, int] = {}
        self._names = np.zeros(0, dtype=np.int64)  # per slot, its cell's name
        self.wanted = np.zeros(0, dtype=np.int64)
        self.unwanted = np.zeros(0, dtype=np.int64)
        self.latest = np.zeros(0, dtype=np.int8)
        self._positions = np.zeros((0, 0), dtype=np.intp)
        self._keys: list[tuple[int, ...]] = []

    def index_keys(self, keys: Sequence[tuple[int, ...]]) -> None:
        """The learner's keys (those known already keep their positions)."""
        if len(keys) > 1 << KEY_BITS:
            raise ValueError(f"a learner has at most {1 << KEY_BITS} keys, not {len(keys)}")
        width = max((len(k) for k in keys), default=0)
        if width * self._bits + KEY_BITS > NAME_BITS + 1:
            raise ValueError(f"keys of {width} atoms do not fit a cell's name")
        # per key, its atom positions padded with the position that is always coded 0
        pad = self.n_atoms
        self._positions = np.array([[*k, *([pad] * (width - len(k)))] for k in keys], dtype=np.intp)
        self._shifts = np.arange(width, dtype=np.int64) * self._bits + KEY_BITS
        self._keys = list(keys)

    def code(self, atoms: Sequence[Hashable]) -> np.ndarray:
        """An example's atoms as codes (new atoms given the next code at their position)."""
        top = (1 << self._bits) - 1
        out = np.zeros(self.n_atoms + 1, dtype=np.int64)
        for j, atom in enumerate(atoms):
            codes = self._codes[j]
            c = codes.get(atom)
            if c is None:
                c = codes[atom] = min(len(codes), top)
                if c < top or len(self._atoms[j]) <= top:
                    self._atoms[j].append(atom)
            out[j] = c
        return out

    def names(self, codes: np.ndarray, keys: np.ndarray) -> np.ndarray:
        """The names of an example's cells under ``keys`` (positions)."""
        return (codes[self._positions[keys]] << self._shifts).sum(axis=1) | keys

    def slots(self, names: np.ndarray) -> np.ndarray:
        """The cells' slots, −1 for a cell never counted."""
        listed = names.tolist()
        return np.fromiter(map(self._slot.get, listed, repeat(-1)), dtype=np.intp, count=len(listed))

    def read(self, atoms: Sequence[Hashable], keys: np.ndarray) -> tuple[np.ndarray, ...]:
        """Wanted, unwanted and latest of an example's cells under ``keys`` (0 where empty)."""
        codes = np.zeros(self.n_atoms + 1, dtype=np.int64)
        for j, atom in enumerate(atoms):
            codes[j] = self._codes[j].get(atom, -1)  # an atom never counted: no cell holds it
        slots = self.slots(self.names(codes, keys))
        slots[(codes[self._positions[keys]] < 0).any(axis=1)] = -1
        known = slots >= 0
        p, n, last = (np.where(known, a[slots], 0) for a in (self.wanted, self.unwanted, self.latest))
        return p, n, last

    def count(
        self, atoms: Sequence[Hashable], keys: np.ndarray, *, wanted: bool, step: int
    ) -> tuple[np.ndarray, ...]:
        """Count an example ``step`` times in its cells of ``keys`` (a negative ``step`` takes it
        out; the latest label is then left as it was); gives the counts before."""
        names = self.names(self.code(atoms), keys)
        slots = self.slots(names)
        new = np.flatnonzero(slots < 0)
        if len(new):
            slots[new] = self._new_slots(names[new])
        p, n = self.wanted[slots], self.unwanted[slots]
        if wanted:
            self.wanted[slots] = p + step
        else:
            self.unwanted[slots] = n + step
        if step > 0:
            self.latest[slots] = wanted
        return p, n

    def _new_slots(self, names: np.ndarray) -> np.ndarray:
        start = len(self._slot)
        for k, name in enumerate(names.tolist()):
            self._slot[name] = start + k
        size = len(self._slot)
        if size > len(self.wanted):
            grown = max(size, 2 * len(self.wanted), 256)
            self._names, self.wanted, self.unwanted, self.latest = (
                np.concatenate([a, np.zeros(grown - len(a), dtype=a.dtype)])
                for a in (self._names, self.wanted, self.unwanted, self.latest)
            )
        self._names[start:size] = names
        return np.arange(start, size)

    def get(self, i: int, atoms: Sequence[Hashable]) -> tuple[int, int, int] | None:
        """Key ``i``'s counts of an example's cell: (wanted, unwanted, latest), None if empty."""
        name = i
        for m, j in enumerate(self._keys[i]):
            c = self._codes[j].get(atoms[j])
            if c is None:
                return None
            name |= c << (m * self._bits + KEY_BITS)
        slot = self._slot.get(name)
        if slot is None or not (self.wanted[slot] or self.unwanted[slot]):
            return None
        return int(self.wanted[slot]), int(self.unwanted[slot]), int(self.latest[slot])

    def table(self, i: int) -> dict[tuple[Hashable, ...], tuple[int, int, int]]:
        """Key ``i``'s cells with examples, by their atoms."""
        key, mask = self._keys[i], (1 << self._bits) - 1
        out = {}
        for slot in np.flatnonzero((self._names[: len(self._slot)] & ((1 << KEY_BITS) - 1)) == i).tolist():
            p, n = int(self.wanted[slot]), int(self.unwanted[slot])
            if p or n:
                name = int(self._names[slot]) >> KEY_BITS
                cell = tuple(self._atoms[j][(name >> (m * self._bits)) & mask] for m, j in enumerate(key))
                out[cell] = (p, n, int(self.latest[slot]))
        return out

    def __len__(self) -> int:
        return len(self._slot)
