"""Several fitted gradient-boosted classifiers answered for one row at once, fast.

scikit-learn's ``HistGradientBoostingClassifier.predict_proba`` costs about 1.7 ms for a single
row (its input checks, then one call per tree), so a learner with one model per service that
answers every event of a stream one at a time would spend most of a replay there. A
:class:`Forest` copies the trees of every service's model into flat arrays once a fit is done
and walks all of them together, one depth level per NumPy step: every service's probability for
a row in tens of microseconds, the same numbers as ``predict_proba`` (the tests compare them).

The copy reads the fitted trees (``_predictors``, ``_baseline_prediction``): there is no public
way to them, and scikit-learn is pinned. Only numeric splits are read, as the learner gives its
models no categorical feature; a model that has another kind of split is refused
(``ValueError``), never answered wrongly.

>>> import numpy as np
>>> from sklearn.ensemble import HistGradientBoostingClassifier
>>> x = np.array([[0.0], [1.0]] * 30)
>>> model = HistGradientBoostingClassifier(max_iter=5, min_samples_leaf=5).fit(x, x[:, 0] > 0.5)
>>> forest = Forest([model, 0.0])
>>> p = forest.proba(np.array([1.0]))
>>> bool(np.isclose(p[0], model.predict_proba([[1.0]])[0, 1])), float(p[1])
(True, 0.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy.special import expit

#: a model, or a constant probability (a service with one class so far)
Model = Any


class Forest:
    """The trees of one binary classifier per service, or a constant probability per service."""

    def __init__(self, models: Sequence[Model]) -> None:
        self.constant = np.array([np.nan if _fitted(m) else float(m) for m in models])
        self.baseline = np.zeros(len(models))
        parts: list[np.ndarray] = []
        roots, owners = [], []
        offset = 0
        for s, model in enumerate(models):
            if not _fitted(model):
                continue
            self.baseline[s] = float(np.ravel(model._baseline_prediction)[0])
            for (tree,) in model._predictors:
                nodes = tree.nodes
                if nodes["is_categorical"].any():
                    raise ValueError("a categorical split: not read by the forest")
                parts.append(nodes)
                roots.append(offset)
                owners.append(s)
                offset += len(nodes)
        self._arrays(parts, offset)
        self.roots = np.array(roots, dtype=np.int64)
        self.owners = np.array(owners, dtype=np.int64)

    def _arrays(self, parts: list[np.ndarray], total: int) -> None:
        """Every node of every tree in flat arrays, children as indices into them; a leaf is
        its own child on both sides, so a walk that reached it stays there."""
        self.feature = np.zeros(total, dtype=np.int64)
        self.threshold = np.zeros(total)
        self.left = np.zeros(total, dtype=np.int64)
        self.right = np.zeros(total, dtype=np.int64)
        self.missing_left = np.zeros(total, dtype=bool)
        self.value = np.zeros(total)
        self.depth = 0
        start = 0
        for nodes in parts:
            end = start + len(nodes)
            leaf = nodes["is_leaf"].astype(bool)
            own = np.arange(start, end)
            self.feature[start:end] = np.where(leaf, 0, nodes["feature_idx"])
            self.threshold[start:end] = np.where(leaf, np.inf, nodes["num_threshold"])
            self.left[start:end] = np.where(leaf, own, nodes["left"].astype(np.int64) + start)
            self.right[start:end] = np.where(leaf, own, nodes["right"].astype(np.int64) + start)
            self.missing_left[start:end] = leaf | nodes["missing_go_to_left"].astype(bool)
            self.value[start:end] = nodes["value"]
            self.depth = max(self.depth, int(nodes["depth"].max()))
            start = end

    def proba(self, row: np.ndarray) -> np.ndarray:
        """Per service, the probability that it is wanted at ``row`` (its features)."""
        out = self.constant.copy()
        if not len(self.roots):
            return out
        at = self.roots
        for _ in range(self.depth):
            x = row[self.feature[at]]
            left = np.where(np.isnan(x), self.missing_left[at], x <= self.threshold[at])
            at = np.where(left, self.left[at], self.right[at])
        raw = self.baseline + np.bincount(self.owners, self.value[at], minlength=len(out))
        fitted = np.isnan(out)
        out[fitted] = expit(raw[fitted])
        return out


def _fitted(model: Model) -> bool:
    return not isinstance(model, (int, float))
