"""A method's answers as probabilities, calibrated on the stream as it goes.

For every event and every service of the home, a method's score — the trees' share of wanted
examples where the user's evidence decides, else whether the shared tree proposes the service
(:meth:`~homecog.knowledge.ihdr.IHDRTree.scores_one`); for a method without scores, 1 for a
service it answers and 0 for one it does not — is made a probability by the method's own
:class:`~homecog.knowledge.calibration.Calibrator`, fitted on the events before it, then the
event's pairs are learned. The expected calibration error (over the pairs answered 0.1 or more,
ten equal bins) and the reliability table are over those prequential probabilities.

>>> import numpy as np
>>> c = Calibrated(["A", "B"])
>>> for _ in range(60):
...     p = c.step({"A": 1.0}, {"A"})
>>> round(p["A"], 2), "B" in p  # A always wanted where answered; B never, answered 0
(1.0, False)
>>> c.figures()["ece"] < 0.05
True
"""

from __future__ import annotations

from array import array
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from homecog.knowledge.calibration import Calibrator, expected_calibration_error, reliability

#: a probability below this is left out of a predictions line
SHOWN = 0.01


class Calibrated:
    """One method's probabilities over a stream, and its calibration figures."""

    def __init__(self, services: Sequence[str]) -> None:
        self.services = list(services)
        self._index = {s: k for k, s in enumerate(self.services)}
        self.calibrator = Calibrator()
        self._p = array("f")
        self._wanted = array("b")

    def step(self, scores: Mapping[str, float], truth: frozenset[str] | set[str]) -> dict[str, float]:
        """An event: the probability of every service given its score (0 where the method has
        none), judged against ``truth`` and then learned; those of ``SHOWN`` or more, by name."""
        raw = np.zeros(len(self.services))
        for s, score in scores.items():
            raw[self._index[s]] = score
        p = self.calibrator.predict_many(raw)
        wanted = np.zeros(len(self.services), dtype=bool)
        wanted[[self._index[s] for s in truth if s in self._index]] = True
        self._p.extend(p.astype(np.float32))
        self._wanted.extend(wanted.astype(np.int8))
        self.calibrator.learn_many(raw, wanted)
        return {self.services[k]: round(float(p[k]), 4) for k in np.flatnonzero(p >= SHOWN)}

    def figures(self) -> dict[str, Any]:
        """The expected calibration error, the pairs it is over and the reliability table."""
        p, wanted = np.frombuffer(self._p, dtype=np.float32), np.frombuffer(self._wanted, dtype=np.int8)
        table = reliability(p, wanted)
        return {
            "ece": round(expected_calibration_error(p, wanted), 6),
            "pairs": sum(r["pairs"] for r in table),
            "reliability": [{k: round(v, 4) for k, v in r.items()} for r in table],
        }


def scores_of(method: Any, point: Any, answer: Sequence[str]) -> dict[str, float]:
    """A method's scores at a point: its own where it has them, else 1 for each service answered."""
    scores = getattr(method, "scores_one", None)
    return scores(point) if scores is not None else dict.fromkeys(answer, 1.0)
