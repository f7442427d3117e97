"""Calibrated probabilities: how often a service was wanted where a method's score was this.

A method's score for a service (a learner's share of wanted examples, or whether it proposes the
service at all) is not a probability: a share of 0.9 from two examples is wanted less often than
nine times in ten. :class:`Calibrator` learns, from the household's own history of (score,
wanted) pairs, the probability that a service is wanted given its score: scikit-learn's isotonic
regression (a non-decreasing step function, fitted again each time the pairs have grown by half),
answered by interpolation between its steps for many scores at once. Until it has pairs of both
kinds it answers the scores as they are. It learns prequentially, as everything here does: each
answer is given before the pair it answers is learned.

>>> import numpy as np
>>> cal = Calibrator()
>>> rng = np.random.default_rng(0)
>>> scores = rng.uniform(size=2000)
>>> cal.learn_many(scores, rng.uniform(size=2000) < scores ** 2)  # wanted as often as score²
>>> cal.predict_many(np.array([0.5, 0.9])).round(1).tolist()
[0.3, 0.8]

The expected calibration error of such answers, over the pairs answered at least ``low``, in
``bins`` equal bins of the probability:

>>> p = np.array([0.15, 0.15, 0.85, 0.85]); y = np.array([0, 0, 1, 1])
>>> round(expected_calibration_error(p, y), 3)
0.15
"""

from __future__ import annotations

import numpy as np
from sklearn.isotonic import IsotonicRegression

#: pairs learned before the first fit
FIRST_FIT = 50
#: the most pairs a fit weighs (the latest)
WINDOW = 50_000


class Calibrator:
    """Scores to probabilities, learned from (score, wanted) pairs (river's ``learn``/``predict``
    names, many at once: an event's every service)."""

    def __init__(self) -> None:
        self._scores: list[np.ndarray] = []
        self._wanted: list[np.ndarray] = []
        self._n = 0
        self._next_fit = FIRST_FIT
        self._steps: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def n_pairs(self) -> int:
        return self._n

    def learn_many(self, scores: np.ndarray, wanted: np.ndarray) -> None:
        """Learn pairs: each service's score and whether it was wanted."""
        self._scores.append(np.asarray(scores, dtype=float))
        self._wanted.append(np.asarray(wanted, dtype=float))
        self._n += len(scores)
        if self._n >= self._next_fit:
            self._fit()
            self._next_fit = max(self._n + FIRST_FIT, self._n * 3 // 2)

    def _fit(self) -> None:
        x = np.concatenate(self._scores)[-WINDOW:]
        y = np.concatenate(self._wanted)[-WINDOW:]
        self._scores, self._wanted = [x], [y]
        if y.min() == y.max():  # one kind of pair only: nothing to calibrate against yet
            return
        fitted = IsotonicRegression(y_min=0.0, y_max=1.0, out_of_bounds="clip").fit(x, y)
        self._steps = (fitted.X_thresholds_, fitted.y_thresholds_)

    def predict_many(self, scores: np.ndarray) -> np.ndarray:
        """The probability that each service is wanted, given its score."""
        scores = np.asarray(scores, dtype=float)
        if self._steps is None:
            return np.clip(scores, 0.0, 1.0)
        return np.interp(scores, *self._steps)


def reliability(
    p: np.ndarray, wanted: np.ndarray, *, low: float = 0.1, bins: int = 10
) -> list[dict[str, float]]:
    """Per bin of the probability (``bins`` equal ones over [0, 1]) with pairs answered at
    least ``low``: its range, pairs, mean probability and the share wanted."""
    p, wanted = np.asarray(p, dtype=float), np.asarray(wanted, dtype=float)
    keep = p >= low
    p, wanted = p[keep], wanted[keep]
    which = np.minimum((p * bins).astype(int), bins - 1)
    out = []
    for b in range(bins):
        inside = which == b
        if inside.any():
            out.append(
                {
                    "from": b / bins,
                    "to": (b + 1) / bins,
                    "pairs": int(inside.sum()),
                    "probability": float(p[inside].mean()),
                    "wanted": float(wanted[inside].mean()),
                }
            )
    return out


def expected_calibration_error(
    p: np.ndarray, wanted: np.ndarray, *, low: float = 0.1, bins: int = 10
) -> float:
    """The pairs' weighted mean gap between a bin's mean probability and its share wanted (over
    the pairs answered at least ``low``); 0 without any."""
    rows = reliability(p, wanted, low=low, bins=bins)
    total = sum(r["pairs"] for r in rows)
    if not total:
        return 0.0
    return sum(r["pairs"] * abs(r["probability"] - r["wanted"]) for r in rows) / total
