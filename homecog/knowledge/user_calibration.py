"""Every user's calibrator: the probability that a service is wanted, from their own history.

Each correction is judged before it is learned (:class:`~homecog.knowledge.corrections.UserLayers`):
for every service it speaks of, the score the user's layer gave there just before — its share of
wanted examples where the evidence decides, else whether the shared tree proposes the service —
and whether the correction wanted it. Those pairs train the user's
:class:`~homecog.knowledge.calibration.Calibrator`. A user with fewer than ``OWN`` pairs is
answered by the calibrator of the household member with the most (the home's best evidence);
where no one has pairs, by the scores themselves.

>>> import numpy as np
>>> cals = UserCalibration()
>>> cals.learn("ann", np.array([0.9] * 60), np.array([True, False] * 30))
>>> cals.predict("ann", np.array([0.9])).tolist(), cals.predict("kim", np.array([0.9])).tolist()
([0.5], [0.5])
>>> UserCalibration().predict("kim", np.array([0.9])).tolist()  # no one's history yet: the score
[0.9]
"""

from __future__ import annotations

import numpy as np

from homecog.knowledge.calibration import Calibrator

#: the pairs a user's own calibrator needs to answer for them
OWN = 50


class UserCalibration:
    """Per user, a calibrator of their layer's scores."""

    def __init__(self) -> None:
        self._by_user: dict[str, Calibrator] = {}

    def learn(self, user: str, scores: np.ndarray, wanted: np.ndarray) -> None:
        if len(scores):
            self._by_user.setdefault(user, Calibrator()).learn_many(scores, wanted)

    def forget(self, user: str) -> None:
        self._by_user.pop(user, None)

    def get(self, user: str) -> Calibrator | None:
        return self._by_user.get(user)

    def put(self, user: str, calibrator: Calibrator | None) -> None:
        """A user's calibrator as kept (a snapshot's), or none."""
        self._by_user.pop(user, None)
        if calibrator is not None:
            self._by_user[user] = calibrator

    def predict(self, user: str | None, scores: np.ndarray) -> np.ndarray:
        """The probabilities of these scores for ``user``."""
        own = self._by_user.get(user) if user is not None else None
        if own is None or own.n_pairs < OWN:
            best = max(self._by_user.items(), key=lambda kv: (kv[1].n_pairs, kv[0]), default=None)
            own = best[1] if best is not None else None
        return np.clip(scores, 0.0, 1.0) if own is None else own.predict_many(scores)
