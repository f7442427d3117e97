"""The vocabulary of a user's evidence: atoms, keys, cells and the answer a learner gives.

An example is described by *atoms* (one per context feature, the recent past's, and the shared
tree's answer, last); a *key* is a tuple of atom positions, and an example's *cell* under a key
is its atoms at those positions. :mod:`homecog.knowledge.evidence` counts examples per cell.
"""

from __future__ import annotations

import operator
from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from homecog.home.codec import Point

Atom = object
Key = tuple[int, ...]
Recent = tuple[Atom, ...]  # the recent past's atoms of an example, in order


def keys_of(n_atoms: int, order: int, *, recent: bool, n_recent: int) -> list[Key]:
    """The keys a learner weighs. Of the context's atoms and the shared answer (the last atom):
    every key of up to two, and of three or more only with the shared answer among them (the
    shared knowledge refined by two features). With ``recent``, after them, each of the
    ``n_recent`` atoms of the recent past: alone, beside one context atom, beside the shared
    answer, and beside another atom of the recent past (what was wanted just before *and* how
    long ago) — a sequence refines a snapshot, it does not replace it.

    >>> keys_of(3, 2, recent=True, n_recent=1)  # one context atom (0), one recent (1), the shared (2)
    [(), (0,), (2,), (0, 2), (1,), (0, 1), (1, 2)]
    >>> keys_of(4, 2, recent=True, n_recent=2)[-1]  # one context atom, two recent (1, 2), the shared
    (1, 2)
    """
    shared = n_atoms - 1
    context = [*range(n_atoms - 1 - n_recent), shared]
    keys = [k for r in range(order + 1) for k in combinations(context, r) if r <= 2 or shared in k]
    recents = range(n_atoms - 1 - n_recent, shared) if recent else range(0)
    for j in recents:
        keys += [(j,), *((c, j) for c in context[:-1]), (j, shared)]
    keys += list(combinations(recents, 2))
    return keys


def cell_of(key: Key) -> Callable[[tuple[Atom, ...]], tuple[Atom, ...]]:
    """A function from atoms to a key's cell.

    >>> cell_of((0, 2))(("a", "b", "c")), cell_of(())(("a",))
    (('a', 'c'), ())
    """
    if not key:
        return lambda atoms: ()
    if len(key) == 1:
        k = key[0]
        return lambda atoms: (atoms[k],)
    return operator.itemgetter(*key)  # type: ignore[return-value]


def sign_of(share: float, threshold: float, last: int) -> int:
    """An answer from a share of wanted examples: above the threshold propose, below it reject,
    on a tie the latest example (the user's latest word).

    >>> sign_of(0.6, 0.5, 0), sign_of(0.5, 0.5, 1), sign_of(0.5, 0.5, 0)
    (1, 1, -1)
    """
    if abs(share - threshold) <= 1e-9:
        return 1 if last else -1
    return 1 if share > threshold else -1


@dataclass
class Decision:
    """A learner's answer at a context: +1 propose, −1 reject, 0 (no evidence) leave it to the
    shared tree; the key that answered, its cell, and the wanted and unwanted examples in it."""

    sign: int
    key: Key
    cell: tuple[Atom, ...]
    wanted: int
    unwanted: int
    threshold: float = 0.5
    share: float = 0.5  # the estimated probability that the service is wanted here


def learner_codes(p: Point) -> tuple[int, ...]:
    """A point's codes as the learners read them: −1 where a reading is missing.

    >>> from homecog.home.codec import Point
    >>> learner_codes(Point((2, 0, 1), (None, None, None), missing=frozenset({1})))
    (2, -1, 1)
    """
    if not p.missing:
        return p.codes
    return tuple(-1 if j in p.missing else c for j, c in enumerate(p.codes))
