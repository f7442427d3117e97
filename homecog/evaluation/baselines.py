"""Simple online learners beside the knowledge tree, so that every report says how ``multi``
compares with what a plain count learns from the same stream.

All speak river's API: ``learn_one(x, y)`` and ``predict_one(x)``, where ``x`` is a dict of
feature name -> value (every value a string: category, bin, ``on``/``off``) and ``y`` the set of
services wanted there. None reads a feature by its name: what they key on is said by kinds.

- :class:`ServiceFrequency` (``frequency``): per service, how often it was wanted among the past
  events of the same *key* — the home's categorical context (every categorical feature; a home
  without one: its clock features' bins; else nothing) and the state of the devices the
  service sets. A service is proposed when its frequency in the key exceeds a threshold, and
  the threshold is chosen online: the one of :data:`THRESHOLDS` that would have given the best
  micro F1 on the past events (each judged before it was counted), so it uses nothing from the
  future.
- :class:`ServiceNaiveBayes` (``naive_bayes``): river's Bernoulli naive Bayes, one binary model
  per service (one-vs-rest) over the one-hot features ``name=value``.
- ``ha_usage`` and ``markov`` (:mod:`homecog.evaluation.sequence_baselines`): Home Assistant's
  most used services per time of day over 30 days, and a last-event Markov chain; they also
  read the event's time and the services wanted before it (``point.recent``).

:class:`OnlineMethod` puts any of them on a home's points for ``eval`` and ``replay``.

>>> f = ServiceFrequency({"TurnOnLamp": ["location", "lamp"]})
>>> for _ in range(3):
...     f.learn_one({"location": "sofa", "lamp": "off"}, {"TurnOnLamp"})
>>> f.predict_one({"location": "sofa", "lamp": "off"}), f.predict_one({"location": "bed", "lamp": "off"})
({'TurnOnLamp'}, set())
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from homecog.evaluation.sequence_baselines import AT, HOUR, PREVIOUS, HAUsage, ServiceMarkov, bin_middle
from homecog.home.codec import Point, Space
from homecog.home.model import Home
from homecog.home.recent import Recent
from homecog.knowledge.threshold import OnlineThreshold

if TYPE_CHECKING:
    from homecog.knowledge.samples import SampleSet

#: The thresholds the frequency learner chooses among (a service is proposed above it).
THRESHOLDS = tuple(i / 10 for i in range(10))
Features = Mapping[str, Any]


def key_features(home: Home) -> list[str]:
    """The context features of the frequency key, by kind: every categorical feature; a home
    without one, its clock features (their bins); else none (the key is the devices alone)."""
    for kind in ("categorical", "clock"):
        names = [f.name for f in home.features if f.kind == kind]
        if names:
            return names
    return []


def frequency_keys(home: Home) -> dict[str, list[str]]:
    """Per service, the features of its key: the context key and the devices the service sets."""
    context = key_features(home)
    return {s.name: [*context, *(d for d, _ in s.sets)] for s in home.services}


class ServiceFrequency:
    """Per service, the frequency with which it was wanted in its key; a threshold chosen online.

    ``keys`` maps each service to the names of the features its key is made of;
    ``thresholds`` are the candidates, ``start`` the one used before any event decides.
    """

    def __init__(
        self, keys: Mapping[str, Sequence[str]], thresholds: Sequence[float] = THRESHOLDS, start: float = 0.5
    ) -> None:
        self.keys = keys
        self.thresholds = thresholds
        self.start = start
        self._counts: dict[str, dict[tuple[Any, ...], list[int]]] = {s: {} for s in keys}  # seen, wanted
        self._threshold = OnlineThreshold(thresholds, start=start)

    @property
    def threshold(self) -> float:
        """The threshold in use: the best on the events learned so far."""
        return self._threshold.value

    def frequency(self, service: str, x: Features) -> float | None:
        """How often ``service`` was wanted in the key of ``x`` (None: the key was never seen)."""
        seen, wanted = self._counts[service].get(self._key(service, x), (0, 0))
        return wanted / seen if seen else None

    def _key(self, service: str, x: Features) -> tuple[Any, ...]:
        return tuple(x.get(name) for name in self.keys[service])

    def predict_one(self, x: Features) -> set[str]:
        out = set()
        for service in self.keys:
            f = self.frequency(service, x)
            if f is not None and f > self._threshold.value:
                out.add(service)
        return out

    def learn_one(self, x: Features, y: Collection[str]) -> None:
        for service in self.keys:
            key = self._key(service, x)
            counts = self._counts[service].setdefault(key, [0, 0])
            wanted = service in y
            # how each threshold would have answered before this event is counted
            self._threshold.judge(counts[1] / counts[0] if counts[0] else None, wanted)
            counts[0] += 1
            counts[1] += wanted


def one_hot(x: Features) -> dict[str, int]:
    """``{name: value}`` as ``{"name=value": 1}``."""
    return {f"{k}={v}": 1 for k, v in x.items()}


class ServiceNaiveBayes:
    """river's ``BernoulliNB``, one per service (one-vs-rest), on one-hot features."""

    def __init__(self, services: Sequence[str], alpha: float = 1.0) -> None:
        self.services = services
        self.alpha = alpha
        self._models: dict[str, Any] = {}

    def _model(self, service: str) -> Any:
        if service not in self._models:
            from river.naive_bayes import BernoulliNB

            self._models[service] = BernoulliNB(alpha=self.alpha)
        return self._models[service]

    def predict_one(self, x: Features) -> set[str]:
        hot = one_hot(x)
        return {s for s, m in self._models.items() if m.predict_one(hot) is True}

    def learn_one(self, x: Features, y: Collection[str]) -> None:
        hot = one_hot(x)
        for s in self.services:
            self._model(s).learn_one(hot, s in y)


BASELINES = ("frequency", "naive_bayes", "ha_usage", "markov")
#: The baselines that also read the event's time and the services wanted before it.
SEQUENCE = ("ha_usage", "markov")

Learner = Any  # ServiceFrequency, ServiceNaiveBayes, HAUsage or ServiceMarkov


def features_of(space: Space, point: Point) -> dict[str, str]:
    """A point as the baselines see it: every feature's value or bin (``unknown`` where its
    reading is missing), every device on/off."""
    return {dim.name: space.word(point, j) for j, dim in enumerate(space.dims)}


def make_learner(name: str, home: Home) -> Learner:
    """The learner of baseline ``name`` for a home, knowing nothing yet."""
    if name == "frequency":
        return ServiceFrequency(frequency_keys(home))
    if name == "naive_bayes":
        return ServiceNaiveBayes(home.service_names)
    sets = {s.name: s.sets for s in home.services}
    return HAUsage(sets) if name == "ha_usage" else ServiceMarkov(sets)


class OnlineMethod:
    """A baseline on a home's points: predicts the services in the home's order, learns a row."""

    def __init__(self, name: str, home: Home, *, max_samples: int = 8_000, seed: int = 0) -> None:
        if name not in BASELINES:
            raise ValueError(f"unknown baseline {name!r}; expected one of {', '.join(BASELINES)}")
        self.name = name
        self.home = home
        self.max_samples = max_samples
        self.seed = seed
        self.space = Space(home)
        self.learner: Learner = make_learner(name, home)
        self.clock = next((j for j, f in enumerate(home.features) if f.kind == "clock"), None)

    def features(
        self,
        codes: Sequence[int],
        readings: Sequence[float | None] | None = None,
        recent: Recent | None = None,
        missing: frozenset[int] = frozenset(),
    ) -> dict[str, Any]:
        """What the learner sees of a row: :func:`features_of`, and for ``ha_usage`` and
        ``markov`` the event's time, its clock's hour and the services wanted before it."""
        dims = self.space.dims
        x: dict[str, Any] = {
            dim.name: "unknown" if j in missing else dim.values[int(c)]
            for j, (dim, c) in enumerate(zip(dims, codes, strict=True))
        }
        if self.name in SEQUENCE:
            x[AT] = None if recent is None else recent.at
            x[PREVIOUS] = None if recent is None else recent.previous
            x[HOUR] = None if self.clock in missing else self._hour(codes, readings)
        return x

    def _hour(self, codes: Sequence[int], readings: Sequence[float | None] | None) -> float | None:
        """The clock feature's reading, else the middle of its bin (None: the home has none)."""
        if self.clock is None:
            return None
        reading = None if readings is None else readings[self.clock]
        if reading is not None and reading == reading:  # not NaN
            return float(reading)
        bins = self.home.features[self.clock].bins
        assert bins is not None
        return bin_middle(*bins[int(codes[self.clock])])

    def predict_one(self, point: Point) -> list[str]:
        chosen = self.learner.predict_one(self._seen(point))
        return [s for s in self.home.service_names if s in chosen]

    def learn_one(self, point: Point, wanted: Iterable[str]) -> None:
        self.learner.learn_one(self._seen(point), set(wanted))

    def _seen(self, point: Point) -> dict[str, Any]:
        return self.features(point.codes, point.readings, point.recent, point.missing)

    def fit(self, samples: SampleSet) -> OnlineMethod:
        """Learn ``max_samples`` of the home's samples, in a random order."""
        pick = np.random.default_rng([self.seed, 11]).permutation(len(samples))[: self.max_samples]
        self.learn_samples(samples.codes[pick], samples.positions[pick] >= 0, samples.readings[pick])
        return self

    def learn_samples(
        self, codes: np.ndarray, performed: np.ndarray, readings: np.ndarray | None = None
    ) -> None:
        """Learn rows of start states (codes, and readings where known: NaN or None are not)
        and the services performed there (a bool matrix). Samples have no time and no
        sequence: ``ha_usage`` places them by their clock, ``markov`` counts them alone."""
        names = self.home.service_names
        rows = readings.tolist() if readings is not None else [None] * len(codes)
        for row, done, read in zip(codes.tolist(), performed.tolist(), rows, strict=True):
            x = self.features(row, read)
            self.learner.learn_one(x, {names[a] for a, d in enumerate(done) if d})
