"""``homecog eval``: every method on the same scenarios, and the robot's development with use.

Quality is micro precision Σ|p∩t|/Σ|p|, recall Σ|p∩t|/Σ|t|, their F1 and the
exact-match rate, plus the same averaged over scenarios and a per-service table.

Beside every method, multi's F1 minus its own with a 95 % paired bootstrap interval over the
scenarios (:func:`homecog.evaluation.leads.leads`).

Development over time: a simulated user whose wishes are a *truth* home corrects the robot
after each of K scenarios, through the same path as ``homecog correct`` and the HMI (the
store's transaction); precision, recall and F1 on held-out scenarios are measured before any
correction and after every block of them.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from homecog.errors import EvaluationError
from homecog.evaluation import metrics
from homecog.evaluation.calibrated import Calibrated, scores_of
from homecog.evaluation.leads import Difference, event_counts, leads
from homecog.evaluation.learn import learn_methods
from homecog.evaluation.methods import Method, TreeMethod
from homecog.evaluation.registry import METHOD_NAMES
from homecog.evaluation.report import is_paper_experiment, paper_table9
from homecog.evaluation.scenarios import random_scenarios
from homecog.home.content import is_compatible
from homecog.home.model import Home
from homecog.home.scenario_file import Scenario, load_scenarios
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import ensure_policy
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.learning.size import check_size

Progress = Callable[[str], None]

#: the most random scenarios, and the most corrections, one evaluation makes: a larger number is
#: refused at once as a mistyped one, where it would run for days
MAX_SCENARIOS = 1_000_000


def check_truth(home: Home, truth: Home) -> None:
    """Refuse a truth home that is not compatible, naming what differs."""
    problems = is_compatible(truth, home)
    if problems:
        raise EvaluationError(
            f"truth home {truth.source}: not compatible with home '{home.name}': {'; '.join(problems)}"
        )


@dataclass
class MethodResult:
    """The figures of one method on the scenarios."""

    micro: dict[str, float]
    averaged: dict[str, float]
    per_service: dict[str, dict[str, float]]
    seconds: float
    predictions: list[list[str]] = field(default_factory=list, repr=False)
    # the expected calibration error of its probabilities, its pairs, its reliability table
    calibration: dict[str, Any] = field(default_factory=dict)
    # per scenario: (hits, predicted, true), an array of n × 3
    counts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int32), repr=False)

    def as_dict(self) -> dict[str, Any]:
        return {
            **{k: round(v, 6) for k, v in self.micro.items()},
            "averaged": {k: round(v, 6) for k, v in self.averaged.items()},
            "per_service": self.per_service,
            "seconds": round(self.seconds, 3),
            **({"calibration": self.calibration} if self.calibration else {}),
        }


def evaluate(
    method: Method, scenarios: Sequence[Scenario], services: Sequence[str], *, calibrate: bool = True
) -> MethodResult:
    """Micro, scenario-averaged and per-service figures of a method (and with ``calibrate``,
    those of its probabilities)."""
    start = time.perf_counter()
    predicted = [method.predict_one(s.point) for s in scenarios]
    seconds = time.perf_counter() - start
    truths = [sorted(s.truth_for(p)) for s, p in zip(scenarios, predicted, strict=True)]
    micro = metrics.scores(predicted, truths).as_dict()
    averaged = metrics.averaged(predicted, truths)
    per_service = metrics.per_service(predicted, truths, services)
    calibrated = Calibrated(services)  # its probabilities, calibrated scenario by scenario
    for s, answer, truth in zip(scenarios, predicted, truths, strict=True) if calibrate else ():
        calibrated.step(scores_of(method, s.point, answer), set(truth))
    return MethodResult(
        calibration=calibrated.figures() if calibrate else {},
        micro=micro,
        averaged=averaged,
        per_service=per_service,
        seconds=seconds,
        predictions=predicted,
        counts=event_counts(predicted, truths),
    )


def correction_curve(
    home: Home,
    truth: Home,
    tree: IHDRTree,
    samples: SampleSet | SampleLog,
    scenarios: Sequence[Scenario],
    k: int,
    *,
    seed: int = 0,
    db: str | None = None,
    block: int | None = None,
    user: str = "simulated",
    progress: Progress | None = None,
) -> list[dict[str, float]]:
    """Precision, recall and F1 of ``multi`` for a user who corrects it after each of ``k``
    fresh scenarios (never the measured ones), measured at 0 and after every block."""
    from homecog.knowledge import core
    from homecog.knowledge.correction import Correction
    from homecog.knowledge.store import Store

    block = block or max(1, k // 10)
    stream = random_scenarios(home, k, seed=seed + 7919, truth=truth)
    with tempfile.TemporaryDirectory() as tmp:
        store = Store.open(db or f"sqlite:///{tmp}/corrections.sqlite", home)
        try:
            core.save_build(store, tree, samples)
            live = store.load_tree()
            method = TreeMethod(live, user=user)
            names = home.service_names

            def measure(done: int) -> dict[str, float]:
                r = evaluate(method, scenarios, names, calibrate=False).micro
                return {
                    "corrections": done,
                    "precision": round(r["precision"], 6),
                    "recall": round(r["recall"], 6),
                    "f1": round(r["f1"], 6),
                }

            curve = [measure(0)]
            for i, s in enumerate(stream, start=1):
                want = sorted(s.truth_for(live.predict_one(s.point, user)))
                core.correct(store, live, Correction.whole(user, s.point, want))
                if i % block == 0 or i == k:
                    curve.append(measure(i))
                    if progress:
                        progress(f"{i} corrections: F1 {curve[-1]['f1']:.4f}")
        finally:
            if db:
                store.drop_all()
            store.close()
    return curve


@dataclass
class EvalReport:
    scenarios: int
    methods: dict[str, MethodResult]
    curve: list[dict[str, float]] | None
    seconds: float
    home: str
    truth: str
    skipped: dict[str, str] = field(default_factory=dict)
    # whether the paper's Table 9 stands beside these figures (its own home and rules)
    paper: bool = False
    _versus: dict[str, Difference] | None = field(default=None, init=False, compare=False, repr=False)

    def versus(self) -> dict[str, Difference]:
        """Per other method: multi's micro F1 minus its own, with a 95 % paired bootstrap
        interval over the scenarios (empty without multi)."""
        if self._versus is None:
            self._versus = leads({k: m.counts for k, m in self.methods.items()})
        return self._versus

    def as_dict(self) -> dict[str, Any]:
        versus = self.versus()
        out: dict[str, Any] = {
            "scenarios": self.scenarios,
            "home": self.home,
            "truth": self.truth,
            "methods": {k: v.as_dict() for k, v in self.methods.items()},
            "seconds": round(self.seconds, 3),
        }
        if versus:
            out["multi_minus"] = {k: d.as_dict() for k, d in versus.items()}
        if self.skipped:
            out["skipped"] = self.skipped
        if self.curve is not None:
            out["curve"] = self.curve
        if self.paper:
            out["paper_table9"] = paper_table9()
        return out


def _check_counts(scenarios: int | Path, corrections: int) -> None:
    """The number of random scenarios (where not a file) and of corrections, within bounds."""
    if not isinstance(scenarios, Path) and not 1 <= scenarios <= MAX_SCENARIOS:
        raise EvaluationError(f"the number of scenarios must be from 1 to {MAX_SCENARIOS:,}, got {scenarios}")
    if not 0 <= corrections <= MAX_SCENARIOS:
        raise EvaluationError(
            f"the number of corrections must be from 0 to {MAX_SCENARIOS:,}, got {corrections}"
        )


def run(
    home: Home,
    truth: Home,
    *,
    scenarios: int | Path = 2000,
    seed: int = 0,
    methods: Sequence[str] = METHOD_NAMES,
    corrections: int = 0,
    kmeans_k: int = 64,
    db: str | None = None,
    joint: bool = False,
    progress: Progress | None = None,
) -> EvalReport:
    """The whole evaluation."""
    start = time.perf_counter()
    check_truth(home, truth)
    check_size(home, joint=joint)  # before anything that takes time
    _check_counts(scenarios, corrections)
    if isinstance(scenarios, Path):
        cases = load_scenarios(scenarios, home, truth)
    else:
        cases = random_scenarios(home, scenarios, seed=seed, truth=truth)
    policy = ensure_policy(home, joint=joint, progress=progress)
    learned = learn_methods(
        home, policy, methods, seed=seed, kmeans_k=kmeans_k, keep_log=bool(corrections), progress=progress
    )
    results = {}
    for name, method in learned.methods.items():
        if progress:
            progress(f"evaluating {name} on {len(cases):,} scenarios ...")
        results[name] = evaluate(method, cases, home.service_names)
    curve = None
    if corrections:
        assert learned.tree is not None and learned.log is not None
        curve = correction_curve(
            home, truth, learned.tree, learned.log, cases, corrections, seed=seed, db=db, progress=progress
        )
    return EvalReport(
        scenarios=len(cases),
        methods=results,
        skipped=learned.skipped,
        curve=curve,
        seconds=time.perf_counter() - start,
        home=home.name,
        truth=truth.name,
        paper=is_paper_experiment(home, truth),
    )
