"""A stream's answer: the keys' cells mixed by their posterior weights, sleeping experts.

In a stream the probability that a service is wanted is averaged over the keys by their
posterior weights (each key's prequential log loss), each key saying its cell's share (with
half an example of each label). A key whose cell here holds no example has nothing to say and
sleeps: the keys that know the cell share the weight, in proportion to theirs (sleeping experts,
Freund et al., "Using and combining predictors that specialize", STOC 1997), so a key that never
saw this moment does not pull the answer to ½; where no key knows it (no example yet), there is
no answer. The key of the most weight among those awake explains it.

>>> share, k = mixed(np.array([0, 3, 3]), np.array([0, 0, 1]), np.array([0.5, 1.0, 2.0]))
>>> round(share, 3), k  # the first key sleeps; the second weighs e times the third
(0.828, 1)
"""

from __future__ import annotations

import numpy as np


def mixed(wanted: np.ndarray, unwanted: np.ndarray, losses: np.ndarray) -> tuple[float, int] | None:
    """The mixed share of wanted examples over the keys ranked the most weight (least
    prequential loss ``losses``) first, each with its cell's counts, and the position of the
    first awake key; None where every key sleeps."""
    awake = np.flatnonzero(wanted + unwanted > 0)
    if not len(awake):
        return None
    losses = losses[awake]
    weights = np.exp(losses[0] - losses)
    shares = (wanted[awake] + 0.5) / (wanted[awake] + unwanted[awake] + 1)
    return float(weights @ shares / weights.sum()), int(awake[0])
