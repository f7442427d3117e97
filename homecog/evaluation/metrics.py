"""Quality of service sets: micro, scenario-averaged and per-service precision, recall
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
