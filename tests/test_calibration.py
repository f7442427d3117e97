"""Calibrated probabilities: the calibrator, the calibration error and a replay's probabilities."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from homecog.evaluation.replay import replay_rows
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home
from homecog.knowledge.calibration import Calibrator, expected_calibration_error, reliability

HOMES = Path(__file__).parent / "homes"
STUDIO, KIM = HOMES / "studio.yaml", HOMES / "studio_kim.yaml"


def test_the_calibration_error_and_its_table_are_exact():
    p = np.array([0.05, 0.35, 0.35, 0.95])  # the first below 0.1: left out
    wanted = np.array([1, 0, 1, 1])
    assert reliability(p, wanted) == [
        {"from": 0.3, "to": 0.4, "pairs": 2, "probability": pytest.approx(0.35), "wanted": 0.5},
        {"from": 0.9, "to": 1.0, "pairs": 1, "probability": pytest.approx(0.95), "wanted": 1.0},
    ]
    assert expected_calibration_error(p, wanted) == pytest.approx((2 * 0.15 + 0.05) / 3)
    assert expected_calibration_error(np.array([0.05]), np.array([1])) == 0.0  # no pair counted


def test_a_calibrator_makes_probabilities_of_scores_that_are_none():
    rng = np.random.default_rng(1)
    scores = rng.uniform(size=40_000)
    wanted = rng.uniform(size=40_000) < np.sqrt(scores)  # wanted more often than the score says
    cal = Calibrator()
    assert cal.predict_many(np.array([-1.0, 0.3, 2.0])).tolist() == [0.0, 0.3, 1.0]  # nothing learned
    p = np.concatenate(
        [_prequential(cal, scores[k : k + 400], wanted[k : k + 400]) for k in range(0, 40_000, 400)]
    )
    grid = cal.predict_many(np.linspace(0, 1, 101))
    assert (np.diff(grid) >= 0).all()  # never less likely at a higher score
    assert expected_calibration_error(p[4000:], wanted[4000:]) < 0.02
    assert expected_calibration_error(scores, wanted) > 0.1  # the scores themselves are not


def test_pairs_of_one_kind_leave_the_scores_as_they_are():
    cal = Calibrator()
    cal.learn_many(np.full(200, 0.7), np.zeros(200, dtype=bool))
    assert cal.predict_many(np.array([0.7])).tolist() == [0.7]


def _prequential(cal: Calibrator, scores: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    p = cal.predict_many(scores)
    cal.learn_many(scores, wanted)
    return p


def _probabilities(path: Path) -> list[dict]:
    return [json.loads(line)["probabilities"] for line in path.read_text().splitlines()]


def test_a_replay_gives_probabilities_calibrated_on_the_past_alone(tmp_path):
    """Every method's probabilities, in the predictions file and as a calibration error; a
    probability never depends on the events after it."""
    home, truth = load_home(STUDIO), load_home(KIM)
    rows = random_scenarios(home, 300, seed=3, truth=truth)
    methods = ["multi", "frequency"]
    result = replay_rows(home, rows, methods=methods, predictions=tmp_path / "a.jsonl")
    assert set(result.calibration) == set(methods) == set(result.as_dict()["calibration"])
    assert result.calibration["multi"]["ece"] <= 0.05 and result.calibration["multi"]["pairs"] > 300
    table = result.calibration["multi"]["reliability"]
    assert sum(r["pairs"] for r in table) == result.calibration["multi"]["pairs"]
    first = _probabilities(tmp_path / "a.jsonl")
    assert len(first) == 300 and set(first[0]) == set(methods)
    names = set(home.service_names)
    for line in first:
        for p in line.values():
            assert set(p) <= names and all(0.01 <= v <= 1 for v in p.values())
    other = rows[:200] + random_scenarios(home, 100, seed=4, truth=truth)  # another future
    replay_rows(home, other, methods=methods, predictions=tmp_path / "b.jsonl")
    second = _probabilities(tmp_path / "b.jsonl")
    assert second[:200] == first[:200] and second[200:] != first[200:]


def test_a_cognition_says_how_likely_each_proposal_is_from_the_user_s_own_history(studio, studio_build):
    """The robot's proposals carry the probability that the user wants them, calibrated on the
    user's corrections: on contexts it has not seen it is near the share actually wanted."""
    from homecog.knowledge import core
    from homecog.knowledge.correction import Correction
    from homecog.knowledge.pipeline import build
    from homecog.knowledge.store import Store

    store = Store.open("sqlite://", studio)
    build(studio, store, q_path=studio_build)
    tree = store.load_tree()
    kim = load_home(KIM)
    point = random_scenarios(studio, 1, seed=9, truth=kim)[0].point
    fresh = tree.explain_one(point, user="kim")
    assert set(fresh.probabilities) == set(fresh.services)
    assert all(v == 1.0 for v in fresh.probabilities.values())  # no history: the scores themselves
    for s in random_scenarios(studio, 300, seed=5, truth=kim):
        core.correct(store, tree, Correction.whole("kim", s.point, sorted(s.truth)))
    p, wanted = [], []
    for s in random_scenarios(studio, 300, seed=6, truth=kim):
        answer = tree.explain_one(s.point, user="kim")
        assert set(answer.probabilities) == set(answer.services)
        every = tree.probabilities_one(s.point, user="kim")
        assert answer.probabilities == {k: every[k] for k in answer.services}
        p += list(every.values())
        wanted += [k in s.truth for k in every]
    assert expected_calibration_error(np.array(p), np.array(wanted)) <= 0.1
    store.close()


def test_eval_reports_every_method_s_calibration(capsys):
    """``eval`` makes every method's answers probabilities too, calibrated scenario by scenario."""
    from homecog.cli.main import main

    args = ["--home", str(STUDIO), "--truth", str(KIM), "--scenarios", "300", "--methods", "multi,frequency"]
    code = main(["eval", *args, "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    methods = json.loads(out)["methods"]
    for name in ("multi", "frequency"):
        calibration = methods[name]["calibration"]
        assert 0 <= calibration["ece"] <= 0.1 and calibration["pairs"] > 0
        assert sum(r["pairs"] for r in calibration["reliability"]) == calibration["pairs"]
