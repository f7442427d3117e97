"""The gradient-boosted trees beside multi: they learn a rule exactly, never see the future, say
why they did not run, and their fast answers are scikit-learn's."""

from __future__ import annotations

import json
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

from homecog.cli.main import main
from homecog.evaluation.boosted import FIRST_FIT, BoostedMethod
from homecog.evaluation.columns import Columns
from homecog.evaluation.forest import Forest
from homecog.evaluation.replay import replay_rows
from homecog.home import load_home
from homecog.home.codec import Point, Space
from homecog.home.recent import RecentPast
from homecog.home.scenario_file import Scenario

HOMES = Path(__file__).parent / "homes"
STUDIO = load_home(HOMES / "studio.yaml")
START = datetime(2026, 3, 2, 0, 0)


def contexts(n: int, seed: int = 0) -> list[dict[str, str]]:
    """``n`` random studio contexts."""
    rng = np.random.default_rng(seed)
    return [
        {
            "time": f"{(20 * i // 60) % 24:02d}:{20 * i % 60:02d}",
            "light": str(int(rng.choice([40, 120, 400, 900]))),
            "activity": str(rng.choice(["work", "relax", "sleep"])),
            "blind": str(rng.choice(["on", "off"])),
            "desk_lamp": str(rng.choice(["on", "off"])),
            "radio": "off",
        }
        for i in range(n)
    ]


def rule(context: dict[str, str], previous: set[str]) -> set[str]:
    """The household: the lamp on to work in the dim, tea right after the lamp went on."""
    wanted = set()
    if context["activity"] == "work" and int(context["light"]) < 200 and context["desk_lamp"] == "off":
        wanted.add("LampOn")
    if "LampOn" in previous:
        wanted.add("BringTea")
    return wanted


def stream(n: int, seed: int = 0) -> list[Scenario]:
    """``n`` events, one every 20 minutes (72 a day), wanting what :func:`rule` says."""
    space, rows, previous = Space(STUDIO), [], set()
    for i, context in enumerate(contexts(n, seed)):
        wanted = rule(context, previous)
        at = START + timedelta(minutes=20 * i)
        rows.append(
            Scenario(context=context, point=space.point(context), truth=frozenset(wanted), timestamp=at)
        )
        previous = wanted
    return rows


def test_it_learns_a_deterministic_rule_exactly():
    """From the third day on, every answer is the household's: a rule over the context and one
    over the recent past (tea after the lamp), neither of which one key of counts can hold."""
    past, method, misses = RecentPast(STUDIO), BoostedMethod(STUDIO), []
    for i, row in enumerate(stream(72 * 4)):
        point = Point(row.point.codes, row.point.readings, past.at(row.timestamp, row.context))
        answer = set(method.predict_one(point))
        if i >= 72 * 2:
            misses += [] if answer == row.truth else [i]
        method.learn_one(point, sorted(row.truth))
        past.learn(row.timestamp, row.context, row.truth)
    assert misses == []
    assert method.fits == 4  # after the first 50 events, then at the start of days 2, 3 and 4
    assert method.not_run() is None


def test_a_stream_without_times_is_fitted_as_it_grows_by_half():
    """No day boundary to wait for: fitted at 50 events, then at 75, 113 and 170."""
    method, fitted = BoostedMethod(STUDIO), []
    for row in stream(200):
        method.predict_one(row.point)  # a snapshot: no recent past, no time
        fitted.append(method.fits)
        method.learn_one(row.point, sorted(row.truth))
    assert [i for i in range(1, 200) if fitted[i] > fitted[i - 1]] == [50, 75, 113, 170]
    # the lamp's rule needs no past: learned from the snapshots alone
    assert all(
        ("LampOn" in method.predict_one(r.point)) == ("LampOn" in r.truth) for r in stream(100, seed=1)
    )


def answers(rows: list[Scenario], tmp_path: Path, name: str) -> list[dict]:
    out = tmp_path / f"{name}.jsonl"
    replay_rows(STUDIO, rows, methods=["boosted"], predictions=out)
    return [json.loads(line) for line in out.read_text().splitlines()]


def test_it_never_sees_the_future(tmp_path):
    """Its answer at every event is the same whatever the events after it are."""
    rows = stream(72 * 3)
    t = 72 * 2 + 10  # within the third day: fitted at its start on the first two
    flipped = [
        Scenario(context=r.context, point=r.point, truth=frozenset({"RadioOn"}), timestamp=r.timestamp)
        for r in rows[t:]
    ]
    before, after = answers(rows, tmp_path, "a"), answers(rows[:t] + flipped, tmp_path, "b")
    assert [a["boosted"] for a in before[:t]] == [b["boosted"] for b in after[:t]]
    assert any(a["boosted"] for a in before[:t])  # it answered, not only agreed on nothing
    assert [a["boosted"] for a in before] != [b["boosted"] for b in after]  # the change is seen later


def test_a_stream_it_cannot_learn_says_why_and_the_others_go_on():
    few = stream(30)  # one day's 30 events: no day boundary, under the first fit's 50
    result = replay_rows(STUDIO, few, methods=["frequency", "boosted"])
    assert set(result.methods) == {"frequency"} and set(result.counts) == {"frequency"}
    assert result.skipped["boosted"] == (
        f"not run: 30 events, too few to fit: it fits from 20 events on, at a new day or once {FIRST_FIT} "
        "are learned"
    )
    quiet = [
        Scenario(context=r.context, point=r.point, truth=frozenset(), timestamp=r.timestamp)
        for r in stream(120)
    ]
    result = replay_rows(STUDIO, quiet, methods=["frequency", "boosted"])
    assert set(result.methods) == {"frequency"}
    assert result.skipped["boosted"] == (
        "not run: every service had a single class (never wanted, or always) at every fit"
    )


def test_a_fit_that_fails_is_reported_and_the_stream_goes_on():
    method = BoostedMethod(STUDIO, max_iter=0)  # scikit-learn refuses it when the work starts
    past = RecentPast(STUDIO)
    for row in stream(72 * 2):
        point = Point(row.point.codes, row.point.readings, past.at(row.timestamp, row.context))
        assert method.predict_one(point) == []
        method.learn_one(point, sorted(row.truth))
        past.learn(row.timestamp, row.context, row.truth)
    why = method.not_run()
    assert why is not None and why.startswith(
        "not run: fitting its trees on 50 events failed: InvalidParameterError"
    )
    assert method.fits == 0


def test_its_fast_answers_are_scikit_learns():
    from sklearn.ensemble import HistGradientBoostingClassifier
    from threadpoolctl import threadpool_limits

    rng = np.random.default_rng(3)
    x = rng.integers(0, 6, (400, 8)).astype(float)
    x[rng.random(x.shape) < 0.1] = np.nan
    with threadpool_limits(limits=1, user_api="openmp"):
        models: list = [
            HistGradientBoostingClassifier(max_iter=20, max_leaf_nodes=leaves, random_state=0).fit(
                x, np.nan_to_num(x[:, j]) + rng.integers(0, 3, 400) > 4
            )
            for j, leaves in ((0, 3), (3, 8), (5, 31))
        ]
    forest = Forest([models[0], 0.0, models[1], 1.0, models[2]])
    test = rng.integers(0, 7, (200, 8)).astype(float)
    test[rng.random(test.shape) < 0.2] = np.nan
    got = np.array([forest.proba(row) for row in test])
    assert (got[:, 1] == 0.0).all() and (got[:, 3] == 1.0).all()
    for column, model in zip((0, 2, 4), models, strict=True):
        np.testing.assert_allclose(got[:, column], model.predict_proba(test)[:, 1], rtol=0, atol=1e-12)


def test_columns_of_points_and_of_samples_agree():
    columns, space = Columns(STUDIO), Space(STUDIO)
    points = [space.point(c) for c in contexts(20)]
    codes = np.array([p.codes for p in points])
    readings = np.array([[np.nan if r is None else r for r in p.readings] for p in points])
    np.testing.assert_array_equal(columns.rows(codes, readings), np.array([columns.row(p) for p in points]))


def test_eval_learns_it_from_the_samples_within_a_budget(monkeypatch):
    from homecog.evaluation import registry
    from homecog.evaluation.evaluate import run as run_eval

    report = run_eval(STUDIO, STUDIO, scenarios=300, methods=["boosted"])
    # the studio's samples are its own rules: the trees answer most scenarios
    assert report.methods["boosted"].micro["f1"] > 0.8
    monkeypatch.setattr(registry, "BOOSTED_BUDGET", 1_000)
    report = run_eval(STUDIO, STUDIO, scenarios=30, methods=["frequency", "boosted"])
    assert set(report.methods) == {"frequency"}
    assert report.skipped["boosted"].startswith(
        "not run: its 8 gradient-boosted models (one per service) would each be fitted on up to 2,000 rows"
    )


def test_replay_of_almost_nothing(tmp_path, capsys):
    """A file of one event: nothing to fit, said under ``skipped``; of none: an error, one line."""
    path = tmp_path / "events.csv"
    names = [*STUDIO.feature_names, *STUDIO.device_names]
    header = "timestamp," + ",".join(names) + ",services"
    row = "2026-03-02T08:00," + ",".join(contexts(1)[0][k] for k in names) + ",LampOn"
    args = [
        "replay",
        "--home",
        str(HOMES / "studio.yaml"),
        "--events",
        str(path),
        "--methods",
        "boosted,markov",
    ]
    path.write_text(header + "\n" + row + "\n")
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["methods"]) == {"markov"}
    assert data["skipped"]["boosted"].startswith("not run: 1 event, too few to fit")
    path.write_text(header + "\n")
    assert main(args) == 2
    assert capsys.readouterr().err.strip() == f"homecog: error: {path}: no rows after the header"
