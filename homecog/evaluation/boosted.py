"""``boosted``: gradient-boosted trees, what a data scientist given a home's log reaches for.

One scikit-learn ``HistGradientBoostingClassifier`` per service (wanted or not), over the row of
:class:`~homecog.evaluation.columns.Columns`: the home's features and devices and the recent
past. In a replay it learns the household's events alone, from nothing, and is retrained on
every past event (the latest :data:`MAX_TRAIN`) at each day boundary — before the first event
of a new day is answered — and once :data:`FIRST_FIT` events are learned; a stream without
times has no days, so it is retrained each time its events have grown by half
(:data:`GROWTH`). Between fits its trees stay as they are: it never sees an event before
answering it. A service with one class so far (never wanted, or always) is answered with that
class, without a model. A service is proposed when its probability exceeds a threshold chosen
online, as the other baselines' (:class:`~homecog.knowledge.threshold.OnlineThreshold`: the
candidate with the best F1 on the past events, each judged before it was learned).

In ``eval`` it learns (at most ``max_samples`` of) the home's samples, the threshold chosen on
the last fifth of them held out of the fit.

It says why it did not run (:meth:`BoostedMethod.not_run`): too few events for a fit, one
class for every service, or a fit that failed (the first failure; it fits no more after it).

>>> from datetime import datetime, timedelta
>>> from homecog.home import load_home
>>> from homecog.home.codec import Space
>>> from homecog.home.recent import RecentPast
>>> home = load_home("tests/homes/studio.yaml")
>>> space, past, method, answers = Space(home), RecentPast(home), BoostedMethod(home), []
>>> for i in range(120):  # tea whenever the person works, an event every 30 minutes
...     when = datetime(2026, 3, 2, 6) + timedelta(minutes=30 * i)
...     context = {"time": when.strftime("%H:%M"), "light": "300", "activity": ["work", "relax"][i % 2],
...         "blind": "on", "desk_lamp": "off", "radio": "off"}
...     point = space.point(context)
...     point = type(point)(point.codes, point.readings, past.at(when, context))
...     answers.append(method.predict_one(point))
...     wanted = ["BringTea"] if context["activity"] == "work" else []
...     method.learn_one(point, wanted)
...     past.learn(when, context, wanted)
>>> answers[35:38], method.fits, method.not_run()  # fitted at each new day: 06:00 on the 3rd and 4th
([[], ['BringTea'], []], 2, None)
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from typing import Any

import numpy as np

from homecog.evaluation.columns import Columns
from homecog.evaluation.forest import Forest
from homecog.evaluation.sequence_baselines import SHARES
from homecog.home.codec import Point
from homecog.home.model import Home
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.threshold import OnlineThreshold

#: the first fit comes once this many events are learned (or at a day boundary, from MIN_FIT on)
FIRST_FIT = 50
#: fewer events than this are never fitted
MIN_FIT = 20
#: a fit learns at most the latest MAX_TRAIN events (a long stream's fits stay bounded)
MAX_TRAIN = 5_000
#: a stream without times is retrained when its events have grown by this factor since the last fit
GROWTH = 1.5


class BoostedMethod:
    """Gradient-boosted trees, one per service, retrained at day boundaries (see the module)."""

    name = "boosted"

    def __init__(
        self,
        home: Home,
        *,
        max_iter: int = 50,
        learning_rate: float = 0.1,
        max_leaf_nodes: int = 8,
        min_samples_leaf: int = 3,
        class_weight: str | None = None,
        max_samples: int = 2_000,
        seed: int = 0,
    ) -> None:
        self.home = home
        self.max_iter = max_iter
        self.learning_rate = learning_rate
        self.max_leaf_nodes = max_leaf_nodes
        self.min_samples_leaf = min_samples_leaf
        self.class_weight = class_weight
        self.max_samples = max_samples
        self.seed = seed
        self.columns = Columns(home)
        self._fits = 0  # fits done so far
        self._problem: str | None = None  # why it did not run, where a fit failed
        self._rows: list[np.ndarray] = []
        self._wanted: list[np.ndarray] = []
        self._forest: Forest | None = None
        self._threshold = OnlineThreshold(SHARES, start=0.5)
        self._fitted_at = 0  # events learned at the last fit
        self._last_day: Any = None  # the date of the latest event learned
        self._two_classes = False  # some fit so far had a service of two classes
        self._seen: tuple[Point, np.ndarray, np.ndarray | None] | None = None  # the last point answered

    @property
    def fits(self) -> int:
        """How many times its trees were fitted so far."""
        return self._fits

    @property
    def threshold(self) -> float:
        """The threshold in use: the best on the events learned so far."""
        return self._threshold.value

    def predict_one(self, point: Point) -> list[str]:
        self._refresh(None if point.recent is None else point.recent.at)
        row = self.columns.row(point)
        scores = None if self._forest is None else self._forest.proba(row)
        self._seen = (point, row, scores)
        if scores is None:
            return []
        t = self._threshold.value
        return [s for s, p in zip(self.home.service_names, scores, strict=True) if p > t]

    def learn_one(self, point: Point, wanted: Sequence[str]) -> None:
        """Learn one event: how every threshold would have answered it, then keep it for the
        next fit."""
        if self._seen is not None and self._seen[0] is point:
            _, row, scores = self._seen
        else:
            row = self.columns.row(point)
            scores = None if self._forest is None else self._forest.proba(row)
        done = np.array([s in wanted for s in self.home.service_names])
        for k, want in enumerate(done):
            self._threshold.judge(None if scores is None else float(scores[k]), bool(want))
        self._rows.append(row)
        self._wanted.append(done)
        if point.recent is not None and point.recent.at is not None:
            self._last_day = point.recent.at.date()
        self._seen = None

    def _refresh(self, at: datetime | None) -> None:
        """Fit again before answering where the schedule says so (never with the event asked)."""
        n = len(self._rows)
        if n < MIN_FIT or n == self._fitted_at or self._problem is not None:
            return
        new_day = at is not None and self._last_day is not None and at.date() != self._last_day
        timeless = at is None and n >= GROWTH * self._fitted_at
        if new_day or (not self._fits and n >= FIRST_FIT) or (timeless and n >= FIRST_FIT):
            self._fit(np.array(self._rows[-MAX_TRAIN:]), np.array(self._wanted[-MAX_TRAIN:]))
            self._fitted_at = n

    def _fit(self, x: np.ndarray, wanted: np.ndarray) -> bool:
        """A model per service of two classes, a constant per other; False where a fit failed
        (the failure said by :meth:`not_run`, the trees before it kept)."""
        from threadpoolctl import threadpool_limits

        # a column unknown throughout (the recent past of samples) tells nothing, and
        # scikit-learn cannot bin it: a constant, which no tree splits on
        x = np.where(np.isnan(x).all(axis=0), 0.0, x)

        # one thread: on a few hundred rows threads cost more than they give (joblib's binning
        # alone doubles a fit), and a replay's other methods run beside it
        with threadpool_limits(limits=1, user_api="openmp"):
            models = self._models(x, wanted)
        if models is None:
            return False
        self._forest = Forest(models)
        self._fits += 1
        self._two_classes = self._two_classes or any(not isinstance(m, float) for m in models)
        return True

    def _models(self, x: np.ndarray, wanted: np.ndarray) -> list[Any] | None:
        from sklearn.ensemble import HistGradientBoostingClassifier

        models: list[Any] = []
        for k in range(wanted.shape[1]):
            y = wanted[:, k]
            if y.all() or not y.any():
                models.append(float(y[0]))
                continue
            model = HistGradientBoostingClassifier(
                max_iter=self.max_iter,
                learning_rate=self.learning_rate,
                max_leaf_nodes=self.max_leaf_nodes,
                min_samples_leaf=self.min_samples_leaf,
                class_weight=self.class_weight,
                early_stopping=False,
                random_state=self.seed,
            )
            try:
                models.append(model.fit(x, y))
            except Exception as e:  # scikit-learn's errors are many kinds; each is reported
                self._problem = (
                    f"not run: fitting its trees on {len(x):,} events failed: {type(e).__name__}: {e}"
                )
                return None
        return models

    def fit(self, samples: SampleSet) -> BoostedMethod:
        """``eval``: learn (at most ``max_samples`` of) the home's samples in a random order,
        the last fifth held out to choose the threshold."""
        pick = np.random.default_rng([self.seed, 13]).permutation(len(samples))[: self.max_samples]
        x = self.columns.rows(samples.codes[pick], samples.readings[pick])
        wanted = samples.positions[pick] >= 0
        cut = len(pick) - len(pick) // 5
        if len(pick) < MIN_FIT:
            self._problem = f"not run: {len(pick):,} samples, too few to fit (it fits from {MIN_FIT} on)"
            return self
        if not self._fit(x[:cut], wanted[:cut]):
            return self
        assert self._forest is not None
        for row, done in zip(x[cut:], wanted[cut:], strict=True):
            for score, want in zip(self._forest.proba(row), done, strict=True):
                self._threshold.judge(float(score), bool(want))
        self._fitted_at = len(pick)
        return self

    def not_run(self) -> str | None:
        """Why its answers say nothing of gradient-boosted trees (None: they do)."""
        if self._problem is not None:
            return self._problem
        if not self._fits:
            n = max(len(self._rows), self._fitted_at)
            return (
                f"not run: {n:,} event{'' if n == 1 else 's'}, too few to fit: it fits from {MIN_FIT} "
                f"events on, at a new day or once {FIRST_FIT} are learned"
            )
        if not self._two_classes:
            return "not run: every service had a single class (never wanted, or always) at every fit"
        return None
