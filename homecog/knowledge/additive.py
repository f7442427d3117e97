"""One user's additive model of a stream: evidence from several atoms at once.

A user's per-service learners (:mod:`homecog.knowledge.evidence`) answer from the cell of one key:
one conjunction of atoms. In a stream — a household's events in time order, each judged before
it is learned — much of what predicts a service adds up from several atoms at once: the
location, what was wanted just before, how long ago the device switched. :class:`AtomLogistic`
is a logistic model of "service wanted here" over the atoms of an example and every pair of them,
learned online by FTRL-proximal (McMahan et al., "Ad Click Prediction: a View from the
Trenches", KDD 2013): per-coordinate learning rates, and an L1 term that keeps the weights of
rare atoms at exactly 0 until they have earned one.

Its features are shared by all the user's services — an atom's weight says how much happens in
that situation, whatever the service: a kitchen at breakfast time, a device switched a minute ago
— beside a bias and a weight per atom of each service's own. So a service seen a few times
borrows what the others taught. The per-service learners' average over their keys and this
model's probability are averaged into one answer (:class:`~homecog.knowledge.corrections.UserLayers`).

>>> model = AtomLogistic()
>>> for _ in range(30):
...     model.learn_one(0, ("kitchen", "True"), True)
...     model.learn_one(0, ("bedroom", "False"), False)
>>> model.predict_one(0, ("kitchen", "True")) > 0.8, model.predict_one(0, ("bedroom", "False")) < 0.2
(True, True)
>>> round(AtomLogistic().predict_one(3, ("anything",)), 3)  # nothing learned: one half
0.5
"""

from __future__ import annotations

import functools
import math
from collections.abc import Hashable, Sequence
from itertools import repeat

import numpy as np

#: FTRL-proximal's settings: learning rate α, its offset β, the L1 and L2 strengths
ALPHA, BETA, L1, L2 = 0.1, 1.0, 0.5, 1.0
#: the log-odds are kept within ±LIMIT (a probability within 10⁻¹⁵ of 0 or 1)
LIMIT = 35.0


@functools.lru_cache(maxsize=64)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The positions of every pair of ``n`` atoms, in the order of ``itertools.combinations``."""
    first, second = np.triu_indices(n, 1)
    return first, second


class AtomLogistic:
    """A logistic model over atoms and their pairs, learned online by FTRL-proximal.

    Parameters are stored as given (``alpha``, ``beta``, ``l1``, ``l2``); what it learned lives in
    arrays indexed by a feature's slot (``_slot``, in the order features were first seen): FTRL's
    accumulated gradients ``_z`` and squared gradients ``_n``, and the weights they give ``_w``
    (0 for a feature that has not earned one). An example's features are updated together, as
    each feature's update depends on its own state and the example's gradient alone.
    """

    def __init__(self, alpha: float = ALPHA, beta: float = BETA, l1: float = L1, l2: float = L2) -> None:
        self.alpha = alpha
        self.beta = beta
        self.l1 = l1
        self.l2 = l2
        self._atom_ids: dict[tuple[int, Hashable], int] = {}
        self._slot: dict[int, int] = {}
        self._z = np.zeros(64)
        self._n = np.zeros(64)
        self._w = np.zeros(64)

    def features(self, service: int, atoms: Sequence[Hashable]) -> np.ndarray:
        """An example's features, as ints: a bias, every atom and every pair of atoms (shared
        by all services), and the service's own bias and atoms. An atom (its position and
        value) is named by the order it was first seen in; a feature's int says its kind in
        the two low bits."""
        ids = self._atom_ids
        named = np.fromiter(
            (ids.setdefault(a, len(ids)) for a in enumerate(atoms)), dtype=np.int64, count=len(atoms)
        )
        first, second = _pairs(len(atoms))
        own = (service << 32) | np.concatenate([[0], named + 1])
        return np.concatenate(
            [[0], 1 + 4 * named, 2 + 4 * ((named[first] << 26) | named[second]), 3 + 4 * own]
        )

    def _probability(self, weights: list[float]) -> float:
        x = sum(weights)  # in the features' order, as every answer adds them
        return 1.0 / (1.0 + math.exp(-max(-LIMIT, min(LIMIT, x))))

    def predict_one(self, service: int, atoms: Sequence[Hashable]) -> float:
        """The probability that ``service`` is wanted where an example has these atoms."""
        features = self.features(service, atoms).tolist()
        idx = np.fromiter(map(self._slot.get, features, repeat(-1)), dtype=np.intp, count=len(features))
        return self._probability(self._w[idx[idx >= 0]].tolist())

    def _slots(self, features: np.ndarray) -> np.ndarray:
        """The features' slots, new features given the next ones (the arrays grown to hold them)."""
        slot, listed = self._slot, features.tolist()
        idx = np.fromiter(map(slot.get, listed, repeat(-1)), dtype=np.intp, count=len(listed))
        new = np.flatnonzero(idx < 0)
        if len(new):
            for k in new.tolist():
                idx[k] = slot.setdefault(listed[k], len(slot))
            if len(slot) > len(self._z):
                size = max(len(slot), 2 * len(self._z))
                self._z, self._n, self._w = (
                    np.concatenate([a, np.zeros(size - len(a))]) for a in (self._z, self._n, self._w)
                )
        return idx

    def learn_one(self, service: int, atoms: Sequence[Hashable], wanted: bool, weight: float = 1.0) -> None:
        """One example: ``service`` wanted or not, counted ``weight`` times (its gradient scaled)."""
        idx = self._slots(self.features(service, atoms))
        w_old = self._w[idx]
        g = weight * (self._probability(w_old.tolist()) - wanted)
        n_old = self._n[idx]
        sigma = (np.sqrt(n_old + g * g) - np.sqrt(n_old)) / self.alpha
        z = self._z[idx] + g - sigma * w_old
        n = n_old + g * g
        self._z[idx], self._n[idx] = z, n
        shrunk = z - np.copysign(self.l1, z)
        w = -shrunk / ((self.beta + np.sqrt(n)) / self.alpha + self.l2)
        self._w[idx] = np.where(np.abs(z) <= self.l1, 0.0, w)
