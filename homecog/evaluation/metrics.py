"""Quality of service sets (SPEC §9): micro, scenario-averaged and per-service precision, recall
and F1, and the exact-match rate — one definition for ``eval``, ``replay`` and the tests.

The counts come from scikit-learn's multilabel confusion matrix over the services; the ratios
follow one rule where a denominator is empty: the ratio is 1 only where the other side is empty
too (nothing to find and nothing said), 0 otherwise — so a method that never answers gets
precision 0 for a service, not 1 (scikit-learn's ``zero_division`` cannot look at the other
side). The averaged figures are the means of each scenario's precision, recall and F1.

>>> m = scores([["A", "B"], []], [["A", "C"], []])
>>> m.precision, m.recall, m.f1, m.exact
(0.5, 0.5, 0.5, 0.5)
>>> averaged([["A", "B"], []], [["A", "C"], []])["f1"]
0.75
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
from sklearn.metrics import multilabel_confusion_matrix
from sklearn.preprocessing import MultiLabelBinarizer


def ratio(hits: int, n: int, other: int) -> float:
    """``hits / n``; where ``n`` is 0 the ratio is 1 if ``other`` is 0 too (nothing to find and
    nothing said) and 0 otherwise.

    >>> ratio(3, 4, 5), ratio(0, 0, 0), ratio(0, 0, 7)
    (0.75, 1.0, 0.0)
    """
    if n:
        return hits / n
    return 1.0 if other == 0 else 0.0


def f1(precision: float, recall: float) -> float:
    """The harmonic mean of precision and recall (0 where both are 0)."""
    return 2 * precision * recall / (precision + recall) if precision + recall else 0.0


@dataclass(frozen=True)
class Scores:
    """Micro precision Σ|p∩t|/Σ|p|, recall Σ|p∩t|/Σ|t|, their F1, and the exact-match rate."""

    precision: float
    recall: float
    f1: float
    exact: float

    def as_dict(self) -> dict[str, float]:
        return asdict(self)

    def __getitem__(self, key: str) -> float:
        return float(getattr(self, key))


def prf(hits: int, predicted: int, true: int) -> tuple[float, float, float]:
    """(precision, recall, F1) from running totals: hits, predicted and true services."""
    p, r = ratio(hits, predicted, true), ratio(hits, true, predicted)
    return p, r, f1(p, r)


def _confusion(
    predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]], labels: Sequence[str] | None
) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    names = sorted({s for row in [*predicted, *truth] for s in row}) if labels is None else list(labels)
    binarizer = MultiLabelBinarizer(classes=names)
    y_true = binarizer.fit_transform([set(t) for t in truth])
    y_pred = binarizer.transform([set(p) for p in predicted])
    return (
        names,
        y_true,
        y_pred,
        multilabel_confusion_matrix(y_true, y_pred) if names else np.zeros((0, 2, 2)),
    )


def scores(predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]]) -> Scores:
    """Micro figures and the exact-match rate of predicted service sets against true ones."""
    if len(predicted) != len(truth):
        raise ValueError(f"{len(predicted)} predictions for {len(truth)} truths")
    _, y_true, y_pred, confusion = _confusion(predicted, truth, None)
    tp, fp, fn = (int(confusion[:, i, j].sum()) for i, j in ((1, 1), (0, 1), (1, 0)))
    p, r, f = prf(tp, tp + fp, tp + fn)
    exact = float((y_true == y_pred).all(axis=1).mean()) if len(truth) else 0.0
    return Scores(precision=p, recall=r, f1=f, exact=exact)


def averaged(predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]]) -> dict[str, float]:
    """Each scenario's precision, recall and F1 (the rule above for empty sets), averaged."""
    rows = [
        prf(len(set(p) & set(t)), len(set(p)), len(set(t))) for p, t in zip(predicted, truth, strict=True)
    ]
    n = max(1, len(rows))
    return {k: sum(r[i] for r in rows) / n for i, k in enumerate(("precision", "recall", "f1"))}


def per_service(
    predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]], services: Sequence[str]
) -> dict[str, dict[str, float]]:
    """Per service: support (scenarios that want it), precision, recall and F1."""
    names, _, _, confusion = _confusion(predicted, truth, services)
    out = {}
    for k, name in enumerate(names):
        tp, fp, fn = int(confusion[k, 1, 1]), int(confusion[k, 0, 1]), int(confusion[k, 1, 0])
        p, r, f = prf(tp, tp + fp, tp + fn)
        out[name] = {"support": tp + fn, "precision": round(p, 6), "recall": round(r, 6), "f1": round(f, 6)}
    return out


@dataclass(frozen=True)
class Difference:
    """One method's micro F1 minus another's on the same events, and its 95 % interval."""

    difference: float
    low: float
    high: float

    def as_dict(self) -> dict[str, float]:
        return {k: round(v, 6) for k, v in asdict(self).items()}

    def __str__(self) -> str:
        return f"{self.difference:+.3f} [{self.low:+.3f}, {self.high:+.3f}]"


#: the most events drawn in all for one interval, and the fewest draws whatever the stream's length
DRAWS = 20_000_000
FEWEST = 400


def _f1_of_sums(hits: np.ndarray, predicted: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Micro F1 as :func:`prf` gives it: 1 where nothing was wanted and nothing said."""
    total = predicted + true
    return np.divide(2 * hits, total, out=np.ones(np.shape(total)), where=total > 0)


def f1_difference(
    a: Sequence[tuple[int, int, int]],
    b: Sequence[tuple[int, int, int]],
    *,
    resamples: int = 2000,
    seed: int = 0,
) -> Difference:
    """Micro F1 of ``a`` minus that of ``b``, both given per event as (hits, predicted, true),
    with a 95 % paired bootstrap interval (scipy's, percentile): the events are drawn again
    with replacement, the same for both, so what they have in common cancels. An interval
    that holds 0 says the events cannot tell the two methods apart. On long streams the draws
    are fewer (``resamples`` × events at most 20 million, and at least :data:`FEWEST` draws),
    where the interval is narrow anyway, so that a replay of 100,000 events is not held up.

    >>> a = [(1, 1, 1)] * 30 + [(0, 1, 1)] * 10
    >>> b = [(1, 1, 1)] * 20 + [(0, 1, 1)] * 20
    >>> d = f1_difference(a, b)
    >>> round(d.difference, 3), d.low > 0
    (0.25, True)
    >>> f1_difference(a, a).as_dict()
    {'difference': 0.0, 'low': 0.0, 'high': 0.0}
    """
    from scipy.stats import bootstrap

    if len(a) != len(b):
        raise ValueError(f"{len(a)} events for one method, {len(b)} for the other")
    columns = [np.asarray(c, dtype=float) for c in (*zip(*a, strict=True), *zip(*b, strict=True))]
    if len(a) == 0:
        return Difference(0.0, 0.0, 0.0)

    def statistic(h1, p1, t1, h2, p2, t2, axis=-1):  # type: ignore[no-untyped-def]
        one = _f1_of_sums(h1.sum(axis), p1.sum(axis), t1.sum(axis))
        two = _f1_of_sums(h2.sum(axis), p2.sum(axis), t2.sum(axis))
        return one - two

    point = float(statistic(*columns))
    if len(a) < 2:
        return Difference(point, point, point)
    result = bootstrap(
        columns,
        statistic,
        paired=True,
        vectorized=True,
        n_resamples=min(resamples, max(FEWEST, DRAWS // len(a))),
        batch=max(1, 10_000_000 // len(a)),
        method="percentile",
        rng=np.random.default_rng(seed),
    )
    low, high = result.confidence_interval
    return Difference(point, float(low), float(high))


Counts = Sequence[tuple[int, int, int]]


def leads(counts: dict[str, Counts], base: str = "multi") -> dict[str, Difference]:
    """Per method other than ``base``: ``base``'s micro F1 minus its own, with the interval of
    :func:`f1_difference` (empty where ``base`` is not among them).

    >>> d = leads({"multi": [(1, 1, 1)] * 9 + [(0, 1, 1)], "count": [(1, 1, 1)] * 5 + [(0, 1, 1)] * 5})
    >>> list(d), round(d["count"].difference, 2)
    (['count'], 0.4)
    """
    if base not in counts:
        return {}
    return {name: f1_difference(counts[base], c) for name, c in counts.items() if name != base}


def event_counts(
    predicted: Sequence[Sequence[str]], truth: Sequence[Sequence[str]]
) -> list[tuple[int, int, int]]:
    """Per scenario or event: (hits, predicted, true), as :func:`f1_difference` takes them."""
    return [(len(set(p) & set(t)), len(set(p)), len(set(t))) for p, t in zip(predicted, truth, strict=True)]
