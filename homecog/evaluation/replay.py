"""``homecog replay``: prequential evaluation of an event stream.

Events are read in order; every method first predicts a row, then learns it: ``multi`` as a
correction by the household (the same path as ``homecog correct``, in memory), ``paper`` as the
paper learns a correction (a sample of its one-cluster-per-node tree), the Hoeffding
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
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, TextIO, TypedDict, Unpack

import numpy as np

from homecog.errors import EvaluationError
from homecog.evaluation.calibrated import Calibrated, scores_of
from homecog.evaluation.leads import Difference, leads
from homecog.evaluation.learn import Learned, learn_methods
from homecog.evaluation.methods import Method, not_run
from homecog.evaluation.metrics import prf
from homecog.evaluation.registry import METHOD_NAMES, REGISTRY, Setting, check_methods
from homecog.home.codec import Point
from homecog.home.model import Home
from homecog.home.recent import RecentPast
from homecog.home.scenario_file import Scenario, load_scenarios
from homecog.knowledge.pipeline import ensure_policy
from homecog.learning.size import check_size
from homecog.progress import Counted, Progress

USER = "household"
#: progress is reported every 1,000 events, and at least this often on a slow stream (a large home)
PROGRESS_SECONDS = 2.0


@dataclass
class ReplayResult:
    events: int
    methods: dict[str, dict[str, float]]
    running: dict[str, list[tuple[int, float, float, float]]]  # (events, precision, recall, f1)
    seconds: float
    skipped: dict[str, str] = field(default_factory=dict)
    # per method: its expected calibration error, the pairs it is over, its reliability table
    calibration: dict[str, dict[str, Any]] = field(default_factory=dict)
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
            **({"calibration": self.calibration} if self.calibration else {}),
            **({"skipped": self.skipped} if self.skipped else {}),
        }


def prediction_line(
    i: int,
    row: Scenario,
    answers: dict[str, Sequence[str]],
    order: Sequence[str],
    probabilities: dict[str, dict[str, float]] | None = None,
) -> str:
    """One event of a predictions file: its number (from 1), time, truth and every method's
    answer, services in the home's order, and with ``probabilities`` each method's calibrated
    probability of every service of 0.01 or more.

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
    if probabilities is not None:
        data["probabilities"] = {
            name: {s: p[s] for s in sorted(p, key=rank.__getitem__)} for name, p in probabilities.items()
        }
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
        raise EvaluationError(f"predictions file {path}: cannot write there: {e.strerror}") from None
    with f:
        yield f


class ReplayOptions(TypedDict, total=False):
    """The options of :func:`replay` and :func:`replay_rows`."""

    methods: Sequence[str]
    seed: int
    points: int
    joint: bool
    progress: Progress | None
    predictions: Path | None


def replay(home: Home, events: Path, **options: Unpack[ReplayOptions]) -> ReplayResult:
    """Predict, then learn, every event in order; figures per method and their running course
    (and with ``predictions``, every answer into that file)."""
    check_size(home, joint=options.get("joint", False))  # before anything that takes time
    rows = load_scenarios(events, home, home, events=True)
    return replay_rows(home, rows, **options)


def _start(
    home: Home, methods: Sequence[str], *, seed: int, joint: bool, progress: Progress | None
) -> tuple[dict[str, Method], dict[str, str]]:
    """Every method named, ready for the first event: those of the home's rules learned from its
    policy's samples, the others knowing nothing; and those left out, with why."""
    check_methods(methods)
    from_rules = [m for m in methods if REGISTRY[m].from_rules]
    learning = Learned(methods={})
    if from_rules:
        policy = ensure_policy(home, joint=joint, progress=progress)
        learning = learn_methods(home, policy, from_rules, seed=seed, user=USER, progress=progress)
    setting = Setting(home, seed=seed, user=USER)
    started = {
        name: learning.methods[name] if REGISTRY[name].from_rules else REGISTRY[name].make(setting)
        for name in methods
        if name not in learning.skipped
    }
    return started, learning.skipped


@dataclass
class _Tally:
    """One method's figures as a replay goes: totals, the running course, every event's counts,
    its calibrated probabilities."""

    calibrated: Calibrated
    totals: list[int] = field(default_factory=lambda: [0, 0, 0])  # hits, predicted, true
    running: list[tuple[int, float, float, float]] = field(default_factory=list)
    counts: array = field(default_factory=lambda: array("i"))  # hits, predicted, true per event, flat

    def add(self, predicted: set[str], truth: frozenset[str] | set[str]) -> None:
        event = (len(predicted & truth), len(predicted), len(truth))
        self.counts.extend(event)
        for k in range(3):
            self.totals[k] += event[k]

    def figures(self) -> dict[str, float]:
        p, r, f = prf(*self.totals)
        return {"precision": round(p, 6), "recall": round(r, 6), "f1": round(f, 6)}


def _event(
    started: dict[str, Method], tallies: dict[str, _Tally], point: Point, row: Scenario
) -> tuple[dict[str, list[str]], dict[str, dict[str, float]]]:
    """Every method predicts one event, is judged, then learns it; the answers and their
    calibrated probabilities."""
    answers, probabilities = {}, {}
    for name, method in started.items():
        answer = answers[name] = method.predict_one(point)
        truth = row.truth_for(answer)
        tally = tallies[name]
        tally.add(set(answer), truth)
        probabilities[name] = tally.calibrated.step(scores_of(method, point, answer), truth)
        method.learn_one(point, sorted(truth))
    return answers, probabilities


def replay_rows(
    home: Home,
    rows: Sequence[Scenario],
    *,
    methods: Sequence[str] = METHOD_NAMES,
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
    started, skipped = _start(home, methods, seed=seed, joint=joint, progress=progress)
    every = max(1, len(rows) // points)
    tallies = {name: _Tally(Calibrated(home.service_names)) for name in started}
    past = RecentPast(home)
    said = time.perf_counter()  # when progress was last reported
    with _predictions_file(predictions) as sink:
        for i, row in enumerate(rows, start=1):
            point = replace(row.point, recent=past.at(row.timestamp, row.context))
            answers, probabilities = _event(started, tallies, point, row)
            if i % every == 0 or i == len(rows):
                for tally in tallies.values():
                    tally.running.append((i, *prf(*tally.totals)))
            past.learn(row.timestamp, row.context, row.truth)
            if sink is not None:
                sink.write(prediction_line(i, row, answers, home.service_names, probabilities))
            if progress and (i % 1000 == 0 or time.perf_counter() - said >= PROGRESS_SECONDS):
                progress(Counted.of("events", i, len(rows)))
                said = time.perf_counter()
    for name, method in started.items():  # a method that could not run on this stream says why
        if why := not_run(method):
            skipped[name] = why
            del tallies[name]
    return ReplayResult(
        events=len(rows),
        methods={name: t.figures() for name, t in tallies.items()},
        running={name: t.running for name, t in tallies.items()},
        seconds=time.perf_counter() - start,
        skipped=skipped,
        calibration={name: t.calibrated.figures() for name, t in tallies.items()},
        counts={name: np.frombuffer(t.counts, dtype=np.int32).reshape(-1, 3) for name, t in tallies.items()},
    )
