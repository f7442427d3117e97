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

import math
from collections.abc import Hashable, Sequence
from itertools import combinations

#: FTRL-proximal's settings: learning rate α, its offset β, the L1 and L2 strengths
ALPHA, BETA, L1, L2 = 0.1, 1.0, 0.5, 1.0
#: the log-odds are kept within ±LIMIT (a probability within 10⁻¹⁵ of 0 or 1)
LIMIT = 35.0


class AtomLogistic:
    """A logistic model over atoms and their pairs, learned online by FTRL-proximal.

    Parameters are stored as given (``alpha``, ``beta``, ``l1``, ``l2``); what it learned lives in
    ``_z`` and ``_n`` (FTRL's accumulated gradients and squared gradients per feature).
    """

    def __init__(self, alpha: float = ALPHA, beta: float = BETA, l1: float = L1, l2: float = L2) -> None:
        self.alpha = alpha
        self.beta = beta
        self.l1 = l1
        self.l2 = l2
        self._z: dict[Hashable, float] = {}
        self._n: dict[Hashable, float] = {}
        self._w: dict[Hashable, float] = {}  # the weights FTRL's z and n give (0: absent)

    @staticmethod
    def features(service: int, atoms: Sequence[Hashable]) -> list[Hashable]:
        """An example's features: a bias, every atom and every pair of atoms (shared by all
        services), and the service's own bias and atoms."""
        named = [(j, atom) for j, atom in enumerate(atoms)]
        return [
            "bias",
            *named,
            *combinations(named, 2),
            (service, "bias"),
            *((service, j, atom) for j, atom in named),
        ]

    def _weight(self, z: float, n: float) -> float:
        if abs(z) <= self.l1:
            return 0.0
        return -(z - math.copysign(self.l1, z)) / ((self.beta + math.sqrt(n)) / self.alpha + self.l2)

    def _probability(self, features: list[Hashable]) -> float:
        w = self._w
        x = sum(w.get(f, 0.0) for f in features)
        return 1.0 / (1.0 + math.exp(-max(-LIMIT, min(LIMIT, x))))

    def predict_one(self, service: int, atoms: Sequence[Hashable]) -> float:
        """The probability that ``service`` is wanted where an example has these atoms."""
        return self._probability(self.features(service, atoms))

    def learn_one(self, service: int, atoms: Sequence[Hashable], wanted: bool, weight: float = 1.0) -> None:
        """One example: ``service`` wanted or not, counted ``weight`` times (its gradient scaled)."""
        features = self.features(service, atoms)
        g = weight * (self._probability(features) - wanted)
        for f in features:
            n = self._n.get(f, 0.0)
            sigma = (math.sqrt(n + g * g) - math.sqrt(n)) / self.alpha
            z = self._z[f] = self._z.get(f, 0.0) + g - sigma * self._w.get(f, 0.0)
            n = self._n[f] = n + g * g
            w = self._weight(z, n)
            if w:
                self._w[f] = w
            else:
                self._w.pop(f, None)
