"""How far one method is ahead of another on the same events, and how sure that is.

On a few hundred events two methods 0.02 F1 apart may differ by chance. :func:`f1_difference`
gives one method's micro F1 minus another's with a 95 % *paired* bootstrap interval
(``scipy.stats.bootstrap``, percentile): the events are drawn again with replacement, the same
for both methods, so what the events have in common cancels. An interval that holds 0 says the
events cannot tell the two apart. ``eval`` and ``replay`` show it for ``multi`` against every
other method (:func:`leads`). Over several homes, :func:`pooled_difference` weighs each home
the same and draws each home's events from that home alone (a bootstrap stratified by home).

>>> multi = [(1, 1, 1)] * 90 + [(0, 1, 1)] * 10
>>> count = [(1, 1, 1)] * 50 + [(0, 1, 1)] * 50
>>> d = leads({"multi": multi, "count": count})["count"]
>>> str(d)
'+0.400 [+0.300, +0.500]'
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

#: per event: (services in common, services predicted, services wanted) — rows of three ints
Counts = Sequence[tuple[int, int, int]] | np.ndarray
#: fewer events than this give no interval: a bootstrap of a handful says nothing
MIN_EVENTS = 20
#: at most this many events drawn for one interval (then fewer draws) ...
DRAWS = 20_000_000
#: ... but never fewer draws than this
FEWEST = 100


@dataclass(frozen=True)
class Difference:
    """One method's micro F1 minus another's on the same events, and its 95 % interval (None
    where the events are too few for one)."""

    difference: float
    low: float | None
    high: float | None

    def as_dict(self) -> dict[str, float | None]:
        return {k: None if v is None else round(v, 6) for k, v in asdict(self).items()}

    def __str__(self) -> str:
        if self.low is None or self.high is None:
            return f"{self.difference:+.3f} [too few events]"
        return f"{self.difference:+.3f} [{self.low:+.3f}, {self.high:+.3f}]"


def _f1_of_sums(hits: np.ndarray, predicted: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Micro F1 as :func:`homecog.evaluation.metrics.prf` gives it: 1 where nothing was wanted
    and nothing said."""
    total = predicted + true
    return np.divide(2 * hits, total, out=np.ones(np.shape(total)), where=total > 0)


def _rows(counts: Counts) -> np.ndarray:
    rows = np.asarray(counts, dtype=np.int64)
    return rows.reshape(-1, 3) if rows.size else np.zeros((0, 3), dtype=np.int64)


def f1_difference(a: Counts, b: Counts, *, resamples: int = 2000, seed: int = 0) -> Difference:
    """Micro F1 of ``a`` minus that of ``b``, both given per event, with a 95 % paired bootstrap
    interval; None for the interval under :data:`MIN_EVENTS` events. On long streams the draws
    are fewer (``resamples`` × events at most :data:`DRAWS`, never under :data:`FEWEST` draws),
    where the interval is narrow anyway.

    >>> a = [(1, 1, 1)] * 30 + [(0, 1, 1)] * 10
    >>> b = [(1, 1, 1)] * 20 + [(0, 1, 1)] * 20
    >>> d = f1_difference(a, b)
    >>> round(d.difference, 3), d.low > 0
    (0.25, True)
    >>> f1_difference(a, a).as_dict()
    {'difference': 0.0, 'low': 0.0, 'high': 0.0}
    >>> str(f1_difference(a[:3], b[:3]))
    '+0.000 [too few events]'
    """
    from scipy.stats import bootstrap

    one, two = _rows(a), _rows(b)
    if len(one) != len(two):
        raise ValueError(f"{len(one)} events for one method, {len(two)} for the other")
    columns = [*one.T, *two.T]

    def statistic(h1, p1, t1, h2, p2, t2, axis=-1):  # type: ignore[no-untyped-def]
        first = _f1_of_sums(h1.sum(axis), p1.sum(axis), t1.sum(axis))
        second = _f1_of_sums(h2.sum(axis), p2.sum(axis), t2.sum(axis))
        return first - second

    point = float(statistic(*columns))
    n = len(one)
    if n < MIN_EVENTS:
        return Difference(point, None, None)
    result = bootstrap(
        columns,
        statistic,
        paired=True,
        vectorized=True,
        n_resamples=min(resamples, max(FEWEST, DRAWS // n)),
        batch=max(1, 1_000_000 // n),  # about 50 MB of draws at a time
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    low, high = result.confidence_interval
    return Difference(point, float(low), float(high))


def pooled_difference(
    homes: Sequence[tuple[Counts, Counts]], *, resamples: int = 2000, seed: int = 0
) -> Difference:
    """Over several homes, each weighing the same: the mean of the homes' micro F1 differences
    (the first method's minus the second's), with a 95 % bootstrap interval *stratified* by
    home: every draw resamples each home's events from that home alone, paired, and averages
    the homes' differences; the percentile interval of those means. None for the interval
    where a home has under :data:`MIN_EVENTS` events.

    >>> a = [(1, 1, 1)] * 30 + [(0, 1, 1)] * 10
    >>> b = [(1, 1, 1)] * 20 + [(0, 1, 1)] * 20
    >>> d = pooled_difference([(a, b), (b, b)])
    >>> round(d.difference, 3), 0 < d.low < d.high < 0.25
    (0.125, True)
    """
    rows = [(_rows(one), _rows(two)) for one, two in homes]
    if not rows:
        raise ValueError("no home to pool")
    point = float(np.mean([_home_difference(one[None], two[None])[0] for one, two in rows]))
    if any(len(one) < MIN_EVENTS for one, _ in rows):
        return Difference(point, None, None)
    means = np.zeros(resamples)
    for k, (one, two) in enumerate(rows):
        if len(one) != len(two):
            raise ValueError(f"{len(one)} events for one method, {len(two)} for the other")
        rng = np.random.default_rng([seed, k])
        for start in range(0, resamples, batch := max(1, 1_000_000 // len(one))):
            draws = rng.integers(0, len(one), (min(batch, resamples - start), len(one)))
            means[start : start + len(draws)] += _home_difference(one[draws], two[draws]) / len(rows)
    low, high = np.percentile(means, [2.5, 97.5])
    return Difference(point, float(low), float(high))


def _home_difference(one: np.ndarray, two: np.ndarray) -> np.ndarray:
    """Per draw (the first axis) of events (the second), micro F1 of ``one`` minus ``two``."""
    first, second = one.sum(axis=1), two.sum(axis=1)
    return _f1_of_sums(*first.T) - _f1_of_sums(*second.T)


def pooled_leads(
    homes: dict[str, dict[str, Counts]], base: str = "multi", *, resamples: int = 2000
) -> dict[str, tuple[Difference, int]]:
    """Per method other than ``base``: ``base``'s lead over it pooled over the homes where
    both ran (:func:`pooled_difference`), and the number of those homes."""
    names = dict.fromkeys(m for counts in homes.values() for m in counts if m != base)
    out = {}
    for name in names:
        pairs = [(c[base], c[name]) for c in homes.values() if base in c and name in c]
        if pairs:
            out[name] = (pooled_difference(pairs, resamples=resamples), len(pairs))
    return out


def leads(counts: dict[str, Counts], base: str = "multi") -> dict[str, Difference]:
    """Per method other than ``base``: ``base``'s micro F1 minus its own, with the interval of
    :func:`f1_difference`; empty where ``base`` is not among them."""
    if base not in counts:
        return {}
    return {name: f1_difference(counts[base], c) for name, c in counts.items() if name != base}


def event_counts(predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]]) -> np.ndarray:
    """Per scenario or event: (hits, predicted, true), as :func:`f1_difference` takes them.

    >>> event_counts([["A", "B"], []], [["A"], ["C"]]).tolist()
    [[1, 2, 1], [0, 0, 1]]
    """
    rows = [(len(set(p) & set(t)), len(set(p)), len(set(t))) for p, t in zip(predicted, truth, strict=True)]
    return _rows(rows).astype(np.int32)
