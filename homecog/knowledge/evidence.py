"""What one user's corrections say about one service: counted evidence and the
features that matter, learned from the corrections themselves.

Every correction is a labelled example for every service it could concern: the service is
wanted there or not. A service that would change nothing in a context (switching on a device
that is on) is not concerned, so it learns nothing there and is never proposed there.

An example is described by *atoms*, one per context feature — the value of a categorical
feature, the interval of a numeric reading between the home's bin edges and the thresholds
learned from the user's own readings — and one more: whether the shared tree proposes the
service there (the prior, so a user who agrees with the shared knowledge keeps it). For every
key — a set of at most ``order`` atoms — a table counts the wanted and unwanted examples per
cell. The key that answers is the one whose cells would have predicted the examples best, each
left out in turn (leave-one-out log loss of the cells' shares; a cell of one example could only
have said one half): a feature whose change flips the wish lowers that loss, a feature that
varies while the wish stays the same only splits cells and raises it. The answer at a context
is the share of wanted examples in its cell under that key, compared with a threshold — ½, or
the user's own (:mod:`homecog.knowledge.corrections`). So a wish repeated ten times outweighs
one odd event; on a tie the latest word wins; where the cell holds no example, a cell with
fewer atoms and enough examples answers, else the shared tree.

Thresholds: for each numeric feature, the reading that best separates the user's wanted and
unwanted examples (Gini) is added to the home's bin edges, rounded to the roundest number
between the two readings it separates (nearest their midpoint), so the user's "fan from 23 °C"
becomes a cut at 23. Thresholds are chosen again each time the evidence has doubled, and the
examples they move recounted.

>>> learner = ServiceLearner(n_atoms=2, numeric={0: (25.0, 30.0)}, order=2)
>>> for t, y in [(20.0, False), (22.0, False), (23.5, True), (24.0, True), (26.0, True), (21.0, False)]:
...     learner.add([t, 0], [None, 0], y, shared=False)
>>> learner.cuts[0]
(23.0, 25.0, 30.0)
>>> learner.decide([23.2, 0], [None, 0], shared=False).sign
1
>>> learner.decide([22.8, 0], [None, 0], shared=False).sign
-1
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from homecog.knowledge.cells import CellCounts
from homecog.knowledge.cuts import best_cut, loo_losses, widened
from homecog.knowledge.keys import Atom, Decision, Key, Recent, cell_of, keys_of, sign_of
from homecog.knowledge.locality import Hull
from homecog.knowledge.mixture import mixed

#: the fewest examples a cell of a key with fewer atoms must hold to answer for an empty one
BACKOFF = 5
#: corrections' worth that must agree in a cell before its answer holds beyond their hull
WIDEN = 10


@dataclass(eq=False)
class ServiceLearner:
    """One user's evidence about one service.

    Parameters
    ----------
    n_atoms
        Context features, plus one for the shared tree's answer (the last atom).
    numeric
        Per numeric feature position, the home's bin edges (finite ones, sorted).
    order
        The most atoms a key may have.
    prior
        The atoms that the shared knowledge says matter to the service: between keys that
        answer the evidence equally well, the one with more of them and fewer others wins
        (what a single correction generalizes over).
    n_recent
        How many of the atoms, just before the shared answer, are the recent past's; their keys
        join at the first example that knows it.
    clock
        The positions of clock features among the numeric ones (their hull is an arc of the day).
    """

    n_atoms: int
    numeric: dict[int, tuple[float, ...]]
    order: int = 2
    prior: frozenset[int] = frozenset()
    n_recent: int = 0
    clock: frozenset[int] = frozenset()

    def __post_init__(self) -> None:
        self._unknown = ("unknown",) * self.n_recent
        # the recent past's keys join at the first example that knows it (until then every
        # such key would only repeat its sub-keys' counts)
        self.keys = keys_of(self.n_atoms, self.order, recent=False, n_recent=self.n_recent)
        self._recent_on = False
        self.cuts: dict[int, tuple[float, ...]] = dict(self.numeric)
        # per example: readings, codes, wanted, the shared answer, the caller's id, recent atoms
        self._examples: list[tuple[Sequence[float | None], Sequence[int], bool, bool, int, Recent]] = []
        self._atoms: list[tuple[Atom, ...]] = []
        self._weights: list[int] = []  # per example, how many it counts as
        self._partials: list[bool] = []  # per example, whether it is partial (see add)
        self._partial = False  # any partial example: only the keys with the shared answer answer
        # every key's cells' counts (wanted, unwanted, latest); per key (by position in
        # self.keys) its leave-one-out loss and, in a stream, its prequential log loss (each
        # example predicted by the cell's examples before it), and the keys ranked by it
        self._cells = CellCounts(self.n_atoms, max(self.order, 2))
        self._loo = np.zeros(0)
        self._preq = np.zeros(0)
        self._ranking: dict[bool, np.ndarray] | None = None
        self._index_keys()
        self._best: int | None = None  # the best key's position, and every key's loss rounded
        self._rounded: list[float] = []
        self._backoff: list[Key] | None = None
        self._hulls: dict[tuple[int, tuple[Atom, ...], bool], Hull] = {}
        self._next_cut = 4

    def _index_keys(self) -> None:
        """Counts for keys new in ``self.keys``, and what is derived from the keys."""
        self._cells.index_keys(self.keys)
        self._loo = np.concatenate([self._loo, np.zeros(len(self.keys) - len(self._loo))])
        self._preq = np.concatenate([self._preq, np.zeros(len(self.keys) - len(self._preq))])
        self._cell = [cell_of(k) for k in self.keys]
        self._index = {k: i for i, k in enumerate(self.keys)}
        # per key, its keys with one atom less
        index = self._index
        self._subs = [
            [index[s] for m in range(len(k)) if (s := k[:m] + k[m + 1 :]) in index] for k in self.keys
        ]
        shared_atom = self.n_atoms - 1
        self._shared_keys = [i for i, k in enumerate(self.keys) if shared_atom in k]
        recents = range(self.n_atoms - 1 - self.n_recent, shared_atom)
        self._recent_keys = {i for i, k in enumerate(self.keys) if any(j in recents for j in k)}
        self._shared_subs = [[j for j in subs if shared_atom in self.keys[j]] for subs in self._subs]
        # the keys partial examples answer by: the shared answer refined by the context alone (a
        # few switches cannot tell which of the recent past's many keys matters; measured in the
        # closed loop, keying them on it raised the household's own switches)
        self._partial_keys = [i for i in self._shared_keys if i not in self._recent_keys]
        self._prior_rank = [(-len(self.prior.intersection(k)), len(set(k) - self.prior)) for k in self.keys]
        self._all_keys = np.arange(len(self.keys))
        self._partial_array = np.array(self._partial_keys, dtype=np.intp)
        self._shared_array = np.array(self._shared_keys, dtype=np.intp)
        self._context_array = np.array(
            [i for i in range(len(self.keys)) if i not in self._recent_keys], dtype=np.intp
        )
        self._rank_prior, self._rank_other = (
            np.array(r, dtype=np.intp).reshape(-1) for r in zip(*self._prior_rank, strict=True)
        )

    def __getstate__(self) -> dict[str, object]:
        """The learner as pickle keeps it: without what is made again from its keys and counts."""
        made = ("_cell", "_hulls", "_backoff", "_ranking", "_best")
        return {k: v for k, v in self.__dict__.items() if k not in made}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._cell = [cell_of(k) for k in self.keys]
        self._hulls, self._backoff, self._ranking, self._best = {}, None, None, None

    def _start_recent(self) -> None:
        """The recent past's keys join, with every example so far counted in them."""
        start = len(self.keys)
        self.keys = keys_of(self.n_atoms, self.order, recent=True, n_recent=self.n_recent)
        self._recent_on = True
        self._index_keys()
        new = np.arange(start, len(self.keys))
        shared = np.array([i for i in new.tolist() if i in set(self._shared_keys)], dtype=np.intp)
        for e, atoms in enumerate(self._atoms):
            self._count(atoms, self._examples[e][2], shared if self._partials[e] else new, self._weights[e])

    @property
    def streaming(self) -> bool:
        """Whether the learner learns a stream: its examples know the recent past and each says
        whether the service was wanted (none partial). A stream of whole examples — a
        household's event log — stands on its own: keys are judged by how each predicted every
        example before it was counted, and averaged by that (:mod:`homecog.knowledge.mixture`). Partial
        examples — a person's hands, mostly "wanted" — only refine the shared knowledge, by the
        leave-one-out choice of a key that holds the shared answer."""
        return self._recent_on and not self._partial

    @property
    def n_examples(self) -> int:
        return len(self._examples)

    def atoms(
        self, readings: Sequence[float | None], codes: Sequence[int], shared: bool, recent: Recent = ()
    ) -> tuple[Atom, ...]:
        """An example's atoms: codes, numeric readings as intervals between cuts, the recent
        past's atoms (``unknown`` where not given), the prior; a code of −1 is a missing
        reading, ``unknown``."""
        out: list[Atom] = []
        for j in range(self.n_atoms - 1 - self.n_recent):
            cuts = self.cuts.get(j)
            if codes[j] == -1:  # a missing reading
                out.append("unknown")
            elif cuts is None:
                out.append(codes[j])
            else:
                r = readings[j]
                if r is None:
                    out.append(("bin", codes[j]))
                else:  # the interval, by its lower end: a new cut moves only what it splits off
                    i = bisect.bisect_right(cuts, r)
                    out.append(cuts[i - 1] if i else -math.inf)
        out.extend(recent or self._unknown)
        out.append(int(shared))
        return tuple(out)

    def add(
        self,
        readings: Sequence[float | None],
        codes: Sequence[int],
        wanted: bool,
        *,
        shared: bool,
        ident: int = 0,
        weight: int = 1,
        partial: bool = False,
        recent: Recent = (),
    ) -> None:
        """Count one example: the service ``wanted`` or not in a context (``ident``: the
        caller's name for it, given back by :meth:`members`), as ``weight`` examples.

        A ``partial`` example (one of a correction that spoke of some services only: what a
        person's hands said) is counted under the keys that hold the shared answer alone: it
        refines what the shared knowledge says where it says it, and a service with such
        examples answers by those of them over the context alone — so a few switches, all of
        them "wanted", do not spread over every context or every recent past."""
        if recent and not self._recent_on and any(a != "unknown" for a in recent):
            self._start_recent()
        self._examples.append((readings, codes, wanted, shared, ident, recent))
        self._weights.append(weight)
        self._partials.append(partial)
        self._partial |= partial
        atoms = self.atoms(readings, codes, shared, recent)
        self._atoms.append(atoms)
        keys = self._shared_array if partial else self._all_keys
        self._count(atoms, wanted, keys, weight, score=self.streaming)
        self._best = self._backoff = self._ranking = None
        self._hulls = {}
        n = len(self._examples)
        if n >= self._next_cut:
            self._next_cut = max(n + 8, 2 * n)
            self._recut()

    def _count(
        self, atoms: tuple[Atom, ...], wanted: bool, keys: np.ndarray, step: int = 1, *, score: bool = False
    ) -> None:
        """Count an example ``step`` times in the cells of ``keys`` (a negative ``step``: take it
        out again; a cell's latest example is then left as it was). With ``score``, first every
        key's prequential loss on it: how well its cell predicted it before it was counted."""
        p, n = self._cells.count(atoms, keys, wanted=wanted, step=step)
        if score:
            q = (p + 0.5) / (p + n + 1)
            self._preq[keys] -= step * np.log(q if wanted else 1.0 - q)
        after = loo_losses(p + step, n) if wanted else loo_losses(p, n + step)
        self._loo[keys] += after - loo_losses(p, n)

    def _recut(self) -> None:
        """Choose the thresholds again; the examples whose interval moved change cells."""
        moved = []
        for j, edges in self.numeric.items():
            pairs = [(ex[0][j], ex[2]) for ex in self._examples if ex[0][j] is not None]
            cut = best_cut([r for r, _ in pairs], [y for _, y in pairs])  # type: ignore[misc]
            cuts = tuple(sorted((*edges, cut))) if cut is not None and cut not in edges else edges
            if cuts != self.cuts[j]:
                self.cuts[j] = cuts
                moved.append(j)
        if not moved:
            return
        self._hulls = {}
        keys = np.array([i for i, k in enumerate(self.keys) if any(j in k for j in moved)], dtype=np.intp)
        shared_keys = np.array([i for i in keys.tolist() if i in set(self._shared_keys)], dtype=np.intp)
        for e, (readings, codes, wanted, shared, _, recent) in enumerate(self._examples):
            atoms = self.atoms(readings, codes, shared, recent)
            if atoms != self._atoms[e]:
                these = shared_keys if self._partials[e] else keys
                self._count(self._atoms[e], wanted, these, -self._weights[e])
                self._count(atoms, wanted, these, self._weights[e])
                self._atoms[e] = atoms

    def best_key(self) -> Key:
        """The key with the least leave-one-out loss — in a stream, the least prequential loss —
        (ties: more atoms of the prior, fewer others, then the first)."""
        if self._best is None:
            losses = self._preq if self.streaming else self._loo
            rounded = np.round(losses, 6)
            self._rounded = rounded.tolist()
            candidates = self._all_keys if self.streaming else self._partial_array
            among = rounded[candidates]
            tied = candidates[among == among.min()].tolist()
            self._best = min(tied, key=self._prior_rank.__getitem__)
        return self.keys[self._best]

    def _rank(self, i: int) -> tuple[float, tuple[int, int]]:
        return (self._rounded[i], self._prior_rank[i])

    def decide(
        self,
        readings: Sequence[float | None],
        codes: Sequence[int],
        *,
        shared: bool,
        threshold: float = 0.5,
        recent: Recent = (),
    ) -> Decision:
        """The answer at a context: the share of wanted examples in its cell under the best key
        (the key was chosen for how well its cells' shares predict, so they are not drawn toward
        coarser ones: on the real households' streams that cost 0.02 F1, on the simulated ones
        nothing); proposed above ``threshold``, rejected below it, on a tie the latest example
        of the cell decides. Where the cell under the best key holds no
        example, the next key of the chain whose cell holds at least BACKOFF examples answers;
        where none does, the evidence says nothing (0) and the shared tree answers."""
        atoms = self.atoms(readings, codes, shared, recent)
        if self.streaming:
            return self._mixed(atoms, threshold, snapshot=not recent)
        chain = self.backoff()
        for depth, key in enumerate(chain):
            cell = tuple(atoms[k] for k in key)
            counts = self._cells.get(self._index[key], atoms)
            if counts is not None and (depth == 0 or counts[0] + counts[1] >= BACKOFF):
                break
        else:
            return Decision(0, chain[0], (), 0, 0, threshold)
        p, n, last = counts
        share = p / (p + n)
        sign = sign_of(share, threshold, last)
        departs = (sign > 0) != shared and (p if sign > 0 else n) < WIDEN
        if departs and not self._near(self._index[key], cell, sign > 0, readings, atoms):
            return Decision(0, key, cell, p, n, threshold, share)  # beyond what it has shown
        return Decision(sign, key, cell, p, n, threshold, share)

    def _near(
        self,
        i: int,
        cell: tuple[Atom, ...],
        wanted: bool,
        readings: Sequence[float | None],
        atoms: tuple[Atom, ...],
    ) -> bool:
        """Whether a context is within the hull of the examples of key ``i``'s ``cell`` that say
        ``wanted`` (:mod:`homecog.knowledge.locality`), where a departing answer holds."""
        n_context = self.n_atoms - 1 - self.n_recent
        hull = self._hulls.get((i, cell, wanted))
        if hull is None:
            of_cell = self._cell[i]
            members = (
                (self._examples[e][0], atoms_e[:n_context])
                for e, atoms_e in enumerate(self._atoms)
                if self._examples[e][2] == wanted and of_cell(atoms_e) == cell
            )
            numeric = frozenset(self.numeric)
            hull = self._hulls[(i, cell, wanted)] = Hull.of(members, clock=self.clock, numeric=numeric)
        return hull.holds(readings, atoms[:n_context])

    def _mixed(self, atoms: tuple[Atom, ...], threshold: float, *, snapshot: bool) -> Decision:
        """In a stream: the keys' cells mixed by posterior weight (:mod:`homecog.knowledge.mixture`),
        explained by the awake key of the most weight and its cell."""
        ranked = self._ranked(snapshot)
        p, n, last = self._cells.read(atoms, ranked)
        answer = mixed(p, n, self._preq[ranked])
        if answer is None:
            return Decision(sign_of(0.5, threshold, 0), (), (), 0, 0, threshold)
        share, k = answer
        i = int(ranked[k])
        sign = sign_of(share, threshold, int(last[k]))
        return Decision(sign, self.keys[i], self._cell[i](atoms), int(p[k]), int(n[k]), threshold, share)

    def _ranked(self, snapshot: bool) -> np.ndarray:
        """The keys a stream's answer weighs — every key, or the context's alone (a snapshot) —
        the most weight first (least prequential loss; ties: the prior's rank, then the first)."""
        if self._ranking is None:
            self._ranking = {}
        if snapshot not in self._ranking:
            among = self._context_array if snapshot else self._all_keys
            preq = np.round(self._preq[among], 6)
            order = np.lexsort((among, self._rank_other[among], self._rank_prior[among], preq))
            self._ranking[snapshot] = among[order]
        return self._ranking[snapshot]

    def backoff(self) -> list[Key]:
        """The best key, then the best of its keys with one atom less, and so on to the empty key
        (to the key of the shared answer alone, where the service has partial examples)."""
        if self._backoff is None:
            i = self._index[self.best_key()]
            chain = [self.keys[i]]
            subs = self._subs if self.streaming else self._shared_subs
            while subs[i]:
                i = min(subs[i], key=self._rank)
                chain.append(self.keys[i])
            self._backoff = chain
        return self._backoff

    def members(self, decision: Decision) -> list[tuple[int, bool]]:
        """The examples in a decision's cell: their ids and labels."""
        cell, pairs = self._cell[self._index[decision.key]], zip(self._examples, self._atoms, strict=True)
        return [(ex[4], ex[2]) for ex, atoms in pairs if cell(atoms) == decision.cell]

    def interval(self, decision: Decision, j: int) -> tuple[float, float]:
        """The interval of numeric feature ``j`` in a decision's cell, widened over neighbouring
        cells (the same other atoms) that decide the same way: the learned interval."""
        table = self._cells.table(self._index[decision.key])
        return widened(table, decision, decision.key.index(j), self.cuts[j])
