"""The arithmetic of a user's evidence: a cell's leave-one-out loss and its estimate of the share
of wanted examples, the thresholds a person would say between readings, and the interval a
learned answer holds over
(:mod:`homecog.knowledge.evidence` uses them)."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence

import numpy as np

from homecog.knowledge.keys import Decision, sign_of


@functools.lru_cache(maxsize=1 << 16)
def loo_loss(p: int, n: int) -> float:
    """Leave-one-out log loss (nats) of a cell's estimate over its p wanted and n unwanted
    examples: each example left out is predicted by the others, with half an example of each
    label added (a cell of one example then says one half: log 2)."""
    m = p + n
    out = 0.0
    if p:
        out -= p * math.log((p - 0.5) / m)
    if n:
        out -= n * math.log((n - 0.5) / m)
    return out


def loo_losses(p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """:func:`loo_loss` of many cells at once.

    >>> loo_losses(np.array([0, 1, 3]), np.array([0, 1, 0])).round(4).tolist()
    [0.0, 2.7726, 0.547]
    """
    m = np.maximum(p + n, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        wanted = np.where(p > 0, p * np.log((p - 0.5) / m), 0.0)
        unwanted = np.where(n > 0, n * np.log((n - 0.5) / m), 0.0)
    return (0.0 - wanted) - unwanted


def kt_share(counts: Sequence[int] | None) -> float:
    """A cell's estimate of the share of wanted examples, with half an example of each label
    added (the Krichevsky–Trofimov estimator): ½ for a cell without examples.

    >>> kt_share(None), kt_share([3, 0, 1]), kt_share([0, 1, 0])
    (0.5, 0.875, 0.25)
    """
    if counts is None:
        return 0.5
    return (counts[0] + 0.5) / (counts[0] + counts[1] + 1)


def round_cut(low: float, high: float) -> float:
    """A threshold between two readings as a person says it: of the roundest numbers in
    (low, high] — multiples of 10, 5, 1, 0.5, 0.1, … — the nearest to the midpoint.

    >>> round_cut(22.8, 24.1), round_cut(15.3, 15.8), round_cut(0.1234, 0.1236), round_cut(-3.2, 40)
    (23.0, 15.5, 0.1235, 0.0)
    >>> round_cut(1e300, 1.6e308)  # huge readings: a cut still, never an error
    8.00000005e+307
    """
    mid = low / 2 + high / 2  # no overflow near the largest floats
    for digits in range(-1, 7):
        for step in (5.0, 1.0):
            size = step * 10.0**-digits
            try:
                nearest = round(mid / size) * size
            except (OverflowError, ValueError):  # beyond what a float holds at this step
                continue
            for cand in (nearest, nearest - size, nearest + size):
                if low < cand <= high:
                    return round(cand, max(digits + 1, 0))
    return high


def best_cut(readings: Sequence[float], labels: Sequence[bool]) -> float | None:
    """The threshold that best splits the readings by label (least Gini impurity), or None."""
    pairs = sorted(zip(readings, labels, strict=True))
    n = len(pairs)
    total_pos = sum(1 for _, y in pairs if y)
    if n < 4 or total_pos in (0, n):
        return None
    best, best_i = math.inf, -1
    pos = 0
    for i in range(n - 1):
        pos += pairs[i][1]
        if pairs[i][0] == pairs[i + 1][0]:
            continue
        left, right = i + 1, n - i - 1
        rpos = total_pos - pos
        gini = pos * (left - pos) / left + rpos * (right - rpos) / right
        if gini < best - 1e-12:
            best, best_i = gini, i
    if best_i < 0:
        return None
    return round_cut(pairs[best_i][0], pairs[best_i + 1][0])


def widened(
    table: Mapping[tuple[object, ...], Sequence[int]], decision: Decision, pos: int, cuts: tuple[float, ...]
) -> tuple[float, float]:
    """The interval of the numeric atom at ``pos`` of a decision's cell (its lower cut),
    widened over the neighbouring cells of ``table`` (the same other atoms) that decide the
    same way; ``(-inf, inf)`` where the atom is no interval between ``cuts``."""
    atom = decision.cell[pos]
    if not isinstance(atom, float) or (atom not in cuts and atom != -math.inf):
        return (-math.inf, math.inf)
    k = 0 if atom == -math.inf else cuts.index(atom) + 1  # the interval's position

    def same(i: int) -> bool:
        lower = cuts[i - 1] if i else -math.inf
        cell = (*decision.cell[:pos], lower, *decision.cell[pos + 1 :])
        p, n, last = table.get(cell, (0, 0, 0))
        return p + n > 0 and sign_of(p / (p + n), decision.threshold, last) == decision.sign

    low, high = k, k
    while low > 0 and same(low - 1):
        low -= 1
    while high < len(cuts) and same(high + 1):
        high += 1
    return (cuts[low - 1] if low > 0 else -math.inf, cuts[high] if high < len(cuts) else math.inf)
