"""The methods ``homecog eval`` compares, all learned from the same samples.

- ``multi`` and ``paper``: the IHDR tree in its two modes.
- ``kmeans``: the paper's Table 9 baseline — scikit-learn K-means over the training samples
  (normalized as Table 7), each cluster predicting the services present in at least half of
  its members; a context gets the services of its nearest centroid. In ``replay`` it learns
  the stream as the other methods do (:meth:`KMeansMethod.learn_one`).
- ``hoeffding``: river's Hoeffding tree, one binary classifier per service, learned online
  from a stream of samples (features as the tree sees them: categories and bins as nominal
  values, readings as numbers, devices as on/off).
- ``frequency``, ``naive_bayes``, ``ha_usage`` and ``markov``: simple online learners
  (:mod:`homecog.evaluation.baselines`), learned from the samples in ``eval`` and from the
  household's own events alone in ``replay``.

Every method speaks river's protocol: ``learn_one(point, wanted)`` learns one event and
``predict_one(point)`` answers with the services in priority order; ``fit(samples)`` learns the
home's samples, where a method's work starts (none is done when it is made). The methods are
named, made and described in one place: :mod:`homecog.evaluation.registry`.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

from homecog.home.codec import Point, Space, finite_span
from homecog.home.model import Home
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.samples import SampleSet

#: K-means in a replay: its centroids move every REFIT events (at least k), and its clusters'
#: services are those of the last HISTORY events.
REFIT = 50
HISTORY = 10_000


class Method(Protocol):
    """What ``eval`` and ``replay`` ask of a method."""

    name: str

    def fit(self, samples: SampleSet) -> Method:
        """Learn the home's samples (the trees: one group's, called once a group)."""
        ...

    def predict_one(self, point: Point) -> list[str]:
        """The services wanted at a point, in priority order."""
        ...

    def learn_one(self, point: Point, wanted: Sequence[str]) -> None:
        """Learn one event: the services wanted at a point."""
        ...


def not_run(method: Method) -> str | None:
    """Why a method's answers say nothing of it, said by a method that can find that out only
    once it has learned (too few events, a single class, a fit that failed); None: they do."""
    why = getattr(method, "not_run", None)
    return why() if callable(why) else None


class TreeMethod:
    """The IHDR tree (``multi`` or ``paper``) as an evaluation method."""

    def __init__(self, tree: IHDRTree, user: str | None = None) -> None:
        self.tree = tree
        self.name = tree.mode
        self.user = user

    def fit(self, samples: SampleSet) -> TreeMethod:
        """Add samples to the tree (it learns them incrementally: one group's at a time)."""
        self.tree.learn_many(samples)
        return self

    def predict_one(self, point: Point) -> list[str]:
        return self.tree.predict_one(point, user=self.user)

    def scores_one(self, point: Point) -> dict[str, float]:
        """Per service, the score a calibrator makes a probability of (:meth:`IHDRTree.scores_one`)."""
        return self.tree.scores_one(point, user=self.user)

    def learn_one(self, point: Point, wanted: Sequence[str]) -> None:
        """A correction by the user: ``multi`` through the user's layer (the same path as
        ``homecog correct``, in memory); ``paper`` as the paper learns one (its Algorithm 2), the
        corrected services a sample of its one-cluster-per-node tree."""
        if self.tree.mode == "paper":
            self.tree.learn_one(point, list(wanted))
        else:
            self.tree.correct_one(point, list(wanted), user=self.user)


def _priorities(samples: SampleSet) -> np.ndarray:
    """Mean position of each service in the learned sequences (for ordering answers)."""
    pos = samples.positions.astype(np.float64)
    done = pos >= 0
    return np.where(
        done.any(axis=0), np.where(done, pos, 0).sum(axis=0) / np.maximum(done.sum(axis=0), 1), 99
    )


class Normalizer:
    """A point as the paper's Table 7 row: normalized codes, readings scaled to [0, 1]."""

    def __init__(self, space: Space) -> None:
        self.space = space
        self.spans: dict[int, tuple[float, float]] = {}
        for j, dim in enumerate(space.dims):
            if dim.numeric:
                bounds = finite_span(space.home.features[j].bins)  # type: ignore[arg-type]
                self.spans[j] = (min(bounds), max(bounds))

    def rows(self, codes: np.ndarray, readings: np.ndarray) -> np.ndarray:
        out = np.empty(codes.shape, dtype=np.float64)
        for j, dim in enumerate(self.space.dims):
            if j in self.spans and not np.isnan(readings[:, j]).any():
                low, high = self.spans[j]
                out[:, j] = np.clip((readings[:, j] - low) / (high - low), 0, 1)
            else:
                out[:, j] = codes[:, j] / max(1, len(dim.values) - 1)
        return out

    def row(self, point: Point) -> np.ndarray:
        """A point's row; a missing reading at the middle of its range (K-means needs a number,
        and the middle favours no bin)."""
        readings = np.array([np.nan if r is None else r for r in point.readings], dtype=np.float64)
        out = self.rows(np.array([point.codes]), readings[None, :])[0]
        out[list(point.missing)] = 0.5
        return out


class KMeansMethod:
    """K-means over the training samples; a cluster predicts services in ≥ half of its members.

    In a replay it learns the stream (:meth:`learn_one`), since a K-means that answered from
    its training clusters throughout would be judged on what it never had the chance to learn:
    every event joins its nearest cluster at once, and every :data:`REFIT` events (at least k)
    the centroids move to the new events by scikit-learn's ``MiniBatchKMeans.partial_fit``
    (started from the trained centroids) and the last :data:`HISTORY` events are assigned
    again. A cluster that has events of the stream predicts the services in at least half of
    them; one that has none still those of its training samples. Both steps cost a bounded
    time an event, so a long stream stays fast.
    """

    name = "kmeans"

    def __init__(self, home: Home, *, k: int = 64, max_samples: int = 30_000, seed: int = 0) -> None:
        self.home = home
        self.k = k
        self.max_samples = max_samples
        self.seed = seed

    def fit(self, samples: SampleSet) -> KMeansMethod:
        """Cluster (at most ``max_samples`` of) the training samples: the clusters' services,
        and the counts a stream then adds to."""
        from sklearn.cluster import KMeans

        rng = np.random.default_rng(self.seed)
        pick = rng.permutation(len(samples))[: self.max_samples]
        self.norm = Normalizer(samples.space)
        x = self.norm.rows(samples.codes[pick], samples.readings[pick])
        model = KMeans(n_clusters=min(self.k, len(pick)), n_init=3, random_state=self.seed).fit(x)
        self.centers = np.asarray(model.cluster_centers_, dtype=np.float64)
        performed = samples.positions[pick] >= 0
        labels = model.labels_
        self.services = [
            np.flatnonzero(performed[labels == c].mean(axis=0) >= 0.5)
            if (labels == c).any()
            else np.array([], int)
            for c in range(model.n_clusters)
        ]
        self.priority = _priorities(samples)
        n, a = model.n_clusters, len(self.home.services)
        self._members = np.zeros(n, dtype=np.int64)  # per cluster: events of the stream
        self._wanted = np.zeros((n, a), dtype=np.int64)  # per cluster and service: wanted
        self._history: deque[tuple[np.ndarray, np.ndarray]] = deque(maxlen=HISTORY)
        self._new: list[np.ndarray] = []
        self._stream: Any = None  # the MiniBatchKMeans, from the first refit on
        return self

    def _nearest(self, rows: np.ndarray) -> np.ndarray:
        """The nearest centroid of every row."""
        d = (rows * rows).sum(axis=1)[:, None] - 2 * rows @ self.centers.T + (self.centers**2).sum(axis=1)
        return np.argmin(d, axis=1)

    def _cluster_services(self, c: int) -> np.ndarray:
        if self._members[c]:
            return np.flatnonzero(self._wanted[c] / self._members[c] >= 0.5)
        return self.services[c]

    def predict_one(self, point: Point) -> list[str]:
        c = int(self._nearest(self.norm.row(point)[None, :])[0])
        chosen = sorted(self._cluster_services(c).tolist(), key=lambda a: (self.priority[a], a))
        return [self.home.services[a].name for a in chosen]

    def learn_one(self, point: Point, wanted: Sequence[str]) -> None:
        """Learn one event of a stream: it joins its nearest cluster; every :data:`REFIT`
        events the centroids move and the recent events are assigned again."""
        row = self.norm.row(point)
        done = np.array([s.name in wanted for s in self.home.services], dtype=np.int64)
        c = int(self._nearest(row[None, :])[0])
        self._members[c] += 1
        self._wanted[c] += done
        self._history.append((row, done))
        self._new.append(row)
        if len(self._new) >= max(REFIT, len(self.centers)):
            self._refit()

    def _refit(self) -> None:
        from sklearn.cluster import MiniBatchKMeans

        if self._stream is None:
            self._stream = MiniBatchKMeans(
                n_clusters=len(self.centers), init=self.centers, n_init=1, random_state=self.seed
            )
        self._stream.partial_fit(np.array(self._new))
        self._new.clear()
        self.centers = np.asarray(self._stream.cluster_centers_, dtype=np.float64)
        rows = np.array([r for r, _ in self._history])
        done = np.array([d for _, d in self._history])
        labels = self._nearest(rows)
        self._members = np.bincount(labels, minlength=len(self.centers))
        self._wanted = np.zeros_like(self._wanted)
        np.add.at(self._wanted, labels, done)


class HoeffdingMethod:
    """river's Hoeffding tree, one binary classifier per service, learned online from samples."""

    name = "hoeffding"

    def __init__(
        self,
        home: Home,
        *,
        max_samples: int = 8_000,
        seed: int = 0,
        features: list[list[str]] | None = None,
    ) -> None:
        from river import tree as river_tree

        self.home = home
        self.space = Space(home)
        self.max_samples = max_samples
        self.seed = seed
        # per service, the features its tree sees (default: all of them)
        self.features = features or [list(self.space.names)] * len(home.services)
        nominal = [d.name for d in self.space.dims if not d.numeric]
        self.models = [
            river_tree.HoeffdingTreeClassifier(nominal_attributes=nominal, grace_period=100)
            for _ in home.services
        ]
        self.priority = np.full(len(home.services), 99.0)  # as a service no sample performs

    def fit(self, samples: SampleSet) -> HoeffdingMethod:
        """Learn a stream of ``max_samples`` instances: every sample once in a random order,
        and again while the home has fewer (a Hoeffding tree splits only after enough instances)."""
        rng = np.random.default_rng(self.seed)
        passes = -(-self.max_samples // len(samples))
        pick = np.concatenate([rng.permutation(len(samples)) for _ in range(passes)])[: self.max_samples]
        performed = samples.positions[pick] >= 0
        for row, i in enumerate(pick):
            x = self._features(samples.codes[i], samples.readings[i])
            for a, model in enumerate(self.models):
                model.learn_one(self._seen(x, a), bool(performed[row, a]))
        self.priority = _priorities(samples)
        return self

    def _seen(self, x: dict[str, Any], a: int) -> dict[str, Any]:
        names = self.features[a]
        return x if len(names) == len(x) else {k: x[k] for k in names if k in x}

    def learn_one(self, point: Point, wanted: Sequence[str]) -> None:
        """Learn one context and the services wanted there (the replay's step)."""
        x = self._features(point.codes, point.readings, point.missing)
        for a, model in enumerate(self.models):
            model.learn_one(self._seen(x, a), self.home.services[a].name in wanted)

    def _features(self, codes: Any, readings: Any, missing: frozenset[int] = frozenset()) -> dict[str, Any]:
        """A row as river sees it; a missing reading is left out (river's trees take an
        absent feature as missing)."""
        x: dict[str, Any] = {}
        for j, dim in enumerate(self.space.dims):
            if j in missing:
                continue
            r = readings[j]
            if dim.numeric and r is not None and not (isinstance(r, float) and np.isnan(r)):
                x[dim.name] = float(r)
            else:
                x[dim.name] = dim.values[int(codes[j])]
        return x

    def predict_one(self, point: Point) -> list[str]:
        x = self._features(point.codes, point.readings, point.missing)
        chosen = [a for a, model in enumerate(self.models) if model.predict_one(self._seen(x, a))]
        chosen.sort(key=lambda a: (self.priority[a], a))
        return [self.home.services[a].name for a in chosen]
