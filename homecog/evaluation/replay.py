"""``homecog replay``: prequential evaluation of an event stream.

Events are read in order; every method first predicts a row, then learns it: the trees as a
correction by the household (the same path as ``homecog correct``, in memory), the Hoeffding
trees and K-means by ``learn_one`` (K-means: every event joins its nearest cluster, and its
centroids move every few dozen events; :class:`~homecog.evaluation.methods.KMeansMethod`). The
simple online learners (``frequency``, ``naive_bayes``, ``ha_usage``, ``markov``) start from
nothing and learn the household's events alone: they say what the stream itself teaches,
without the home's rules; ``ha_usage`` and ``markov`` also read each event's time and the
services wanted at the event before (``point.recent``). The running micro figures are kept after every
event, and how far ``multi`` is ahead of (or behind) every other method, with a 95 % paired
bootstrap interval over the events: on a short stream a difference of a few hundredths may be
the events' chance, and the interval says so.

With ``predictions``, every event's answers are written as they are made, one JSON line an
event (:func:`prediction_line`), so that methods outside homecog can be paired with these.
"""

from __future__ import annotations

import json
import time
from array import array
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from homecog.errors import EvaluationError
from homecog.evaluation.baselines import BASELINES, OnlineMethod
from homecog.evaluation.leads import Difference, leads
from homecog.evaluation.learn import Learned, learn_methods
from homecog.evaluation.methods import METHODS, HoeffdingMethod, KMeansMethod, TreeMethod
from homecog.evaluation.metrics import prf
from homecog.home.model import Home
from homecog.home.recent import RecentPast
from homecog.home.scenario_file import Scenario, load_scenarios
from homecog.knowledge.pipeline import ensure_policy
from homecog.learning.size import check_size

Progress = Callable[[str], None]
USER = "household"


@dataclass
class ReplayResult:
    events: int
    methods: dict[str, dict[str, float]]
    running: dict[str, list[tuple[int, float, float, float]]]  # (events, precision, recall, f1)
    seconds: float
    skipped: dict[str, str] = field(default_factory=dict)
    # per method, per event: (hits, predicted, true), an array of n × 3
    counts: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    _versus: dict[str, Difference] | None = field(default=None, init=False, compare=False, repr=False)

    def versus(self, base: str = "multi") -> dict[str, Difference]:
        """Per other method: ``base``'s F1 minus its F1, with a 95 % paired bootstrap interval
        over the events (empty without ``base``)."""
        if base != "multi":
            return leads(self.counts, base)
        if self._versus is None:
            self._versus = leads(self.counts, base)
        return self._versus

    def as_dict(self) -> dict[str, Any]:
        versus = self.versus()
        return {
            "events": self.events,
            "methods": self.methods,
            **({"multi_minus": {k: d.as_dict() for k, d in versus.items()}} if versus else {}),
            "seconds": round(self.seconds, 3),
            "running": {k: [list(r) for r in v] for k, v in self.running.items()},
            **({"skipped": self.skipped} if self.skipped else {}),
        }


def _learn(method: Any, point: Any, wanted: Sequence[str]) -> None:
    if isinstance(method, TreeMethod):
        method.tree.correct_one(point, list(wanted), user=USER)
    elif isinstance(method, HoeffdingMethod | OnlineMethod | KMeansMethod):
        method.learn_one(point, wanted)


def prediction_line(i: int, row: Scenario, answers: dict[str, Sequence[str]], order: Sequence[str]) -> str:
    """One event of a predictions file: its number (from 1), time, truth and every method's
    answer, services in the home's order.

    >>> from homecog.home.codec import Point
    >>> row = Scenario(context={}, point=Point((), ()), truth=frozenset({"B", "A"}))
    >>> prediction_line(1, row, {"markov": ["B", "A"]}, ["A", "B"])
    '{"event": 1, "timestamp": null, "truth": ["A", "B"], "markov": ["A", "B"]}\\n'
    """
    rank = {s: k for k, s in enumerate(order)}
    data: dict[str, Any] = {
        "event": i,
        "timestamp": None if row.timestamp is None else row.timestamp.isoformat(),
        "truth": sorted(row.truth, key=rank.__getitem__),
    }
    data.update({name: sorted(answer, key=rank.__getitem__) for name, answer in answers.items()})
    return json.dumps(data) + "\n"


@contextmanager
def _predictions_file(path: Path | None) -> Iterator[TextIO | None]:
    """The predictions file, line-buffered (every event's line written as it is made)."""
    if path is None:
        yield None
        return
    try:
        f = path.open("w", encoding="utf-8", buffering=1)
    except OSError as e:
        raise EvaluationError(f"--predictions {path}: cannot write there: {e.strerror}") from None
    with f:
        yield f


def replay(
    home: Home,
    events: Path,
    *,
    methods: Sequence[str] = METHODS,
    seed: int = 0,
    points: int = 200,
    joint: bool = False,
    progress: Progress | None = None,
    predictions: Path | None = None,
) -> ReplayResult:
    """Predict, then learn, every event in order; figures per method and their running course
    (and with ``predictions``, every answer into that file)."""
    check_size(home, joint=joint)  # before anything that takes time
    rows = load_scenarios(events, home, home, events=True)
    return replay_rows(
        home,
        rows,
        methods=methods,
        seed=seed,
        points=points,
        joint=joint,
        progress=progress,
        predictions=predictions,
    )


def replay_rows(
    home: Home,
    rows: Sequence[Scenario],
    *,
    methods: Sequence[str] = METHODS,
    seed: int = 0,
    points: int = 200,
    joint: bool = False,
    progress: Progress | None = None,
    predictions: Path | None = None,
) -> ReplayResult:
    """:func:`replay` of rows already read (events, or scenarios whose truth is another home's:
    where several sets of services are optimal, each method is judged against, and learns, the
    one nearest its answer, as ``eval`` does)."""
    start = time.perf_counter()
    check_size(home, joint=joint)
    learning = Learned(methods={})
    if any(m not in BASELINES for m in methods):
        policy = ensure_policy(home, joint=joint, progress=progress)
        learning = learn_methods(
            home, policy, [m for m in methods if m not in BASELINES], seed=seed, progress=progress
        )
    learned: dict[str, Any] = {
        name: OnlineMethod(name, home) if name in BASELINES else learning.methods[name]
        for name in methods
        if name in BASELINES or name in learning.methods
    }
    for m in learned.values():
        if isinstance(m, TreeMethod):
            m.user = USER
    every = max(1, len(rows) // points)
    totals = {name: [0, 0, 0] for name in learned}  # hits, predicted, true
    running: dict[str, list[tuple[int, float, float, float]]] = {name: [] for name in learned}
    counts = {name: array("i") for name in learned}  # hits, predicted, true per event, flat
    past = RecentPast(home)
    with _predictions_file(predictions) as sink:
        for i, row in enumerate(rows, start=1):
            point = replace(row.point, recent=past.at(row.timestamp, row.context))
            answers = {}
            for name, method in learned.items():
                answer = answers[name] = method.predict_one(point)
                predicted, truth = set(answer), row.truth_for(answer)
                event = (len(predicted & truth), len(predicted), len(truth))
                counts[name].extend(event)
                t = totals[name]
                for k in range(3):
                    t[k] += event[k]
                _learn(method, point, sorted(truth))
                if i % every == 0 or i == len(rows):
                    running[name].append((i, *prf(*t)))
            past.learn(row.timestamp, row.context, row.truth)
            if sink is not None:
                sink.write(prediction_line(i, row, answers, home.service_names))
            if progress and i % 1000 == 0:
                progress(f"{i:,} of {len(rows):,} events")
    figures = {}
    for name, t in totals.items():
        p, r, f = prf(*t)
        figures[name] = {"precision": round(p, 6), "recall": round(r, 6), "f1": round(f, 6)}
    return ReplayResult(
        events=len(rows),
        methods=figures,
        running=running,
        seconds=time.perf_counter() - start,
        skipped=learning.skipped,
        counts={name: np.frombuffer(c, dtype=np.int32).reshape(-1, 3) for name, c in counts.items()},
    )
