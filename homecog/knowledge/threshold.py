"""A decision threshold chosen online for F1, used by the users' layers and the baselines.

A learner that answers with a score (a share of wanted examples, a frequency) proposes a
service above a threshold. The best threshold depends on the household: where wishes are rare,
a low one gives the better F1. :class:`OnlineThreshold` keeps, for every candidate, the hits,
proposals and wishes it would have had on the examples so far, each judged *before* it was
learned, and uses the candidate with the best micro F1 (ties: the nearest to where it started):
it uses nothing from the future.

>>> t = OnlineThreshold((0.1, 0.25, 0.5), calibrate=20)
>>> for _ in range(20):
...     t.judge(0.9, True); t.judge(0.3, True); t.judge(0.3, False); t.judge(0.1, False)
>>> t.value
0.25
"""

from __future__ import annotations

from collections.abc import Sequence


def f1_of_counts(hits: int, proposed: int, wanted: int) -> float:
    """Micro F1 from counts: ``2·hits / (proposed + wanted)``; 0 when both are 0."""
    return 2 * hits / (proposed + wanted) if proposed + wanted else 0.0


class OnlineThreshold:
    """Of ``candidates``, the threshold with the best F1 on the examples judged so far (ties: the
    nearest to ``start``); ``start`` until ``calibrate`` examples were judged."""

    def __init__(self, candidates: Sequence[float], *, start: float = 0.5, calibrate: int = 0) -> None:
        self.candidates = tuple(candidates)
        self.start = start
        self.calibrate = calibrate
        self.value = start
        self._tallies = [[0, 0, 0] for _ in self.candidates]  # hits, proposed, wanted
        self._judged = 0

    def judge(self, score: float | None, wanted: bool) -> None:
        """Count how every candidate would have answered an example (``score`` None: no answer,
        so nothing proposed) and choose again."""
        for t, tally in zip(self.candidates, self._tallies, strict=True):
            proposed = score is not None and score > t
            tally[0] += proposed and wanted
            tally[1] += proposed
            tally[2] += wanted
        self._judged += 1
        if self._judged >= self.calibrate:
            best = max(
                range(len(self.candidates)),
                key=lambda i: (f1_of_counts(*self._tallies[i]), -abs(self.candidates[i] - self.start)),
            )
            self.value = self.candidates[best]
