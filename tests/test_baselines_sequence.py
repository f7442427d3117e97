"""The baselines that read the stream (ha_usage, markov), baselines on any home's names, K-means
learning a replay, and replay's predictions file: exact behaviour on hand-built streams."""

from __future__ import annotations

import json
import re
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

import homecog.home
from homecog.cli.main import main
from homecog.evaluation.baselines import OnlineMethod
from homecog.evaluation.scenarios import random_scenarios
from homecog.evaluation.sequence_baselines import (
    AT,
    HOUR,
    PREVIOUS,
    HAUsage,
    ServiceMarkov,
)
from homecog.home import load_home, load_home_text
from homecog.home.codec import Space

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
SETS = {"LightOn": [("light", True)], "LightOff": [("light", False)], "Tea": []}
# (time, the light's state, services wanted): three mornings, an evening, a night
DAYS = [
    (datetime(2026, 3, 1, 8), "off", {"LightOn"}),
    (datetime(2026, 3, 1, 9), "on", set()),
    (datetime(2026, 3, 1, 19), "on", {"Tea"}),
    (datetime(2026, 3, 2, 8, 30), "off", {"LightOn"}),
    (datetime(2026, 3, 2, 23), "on", {"LightOff"}),
]


def learned_usage() -> tuple[HAUsage, list[float]]:
    u = HAUsage(SETS)
    thresholds = []
    for at, light, y in DAYS:
        u.learn_one({AT: at, "light": light}, y)
        thresholds.append(u.threshold)
    return u, thresholds


def test_ha_usage_counts_per_time_of_day_and_chooses_its_threshold():
    u, thresholds = learned_usage()
    assert u._events == {"morning": 3, "evening": 1, "night": 1}
    assert [u.count("morning", s) for s in SETS] == [2, 0, 0]
    assert u.count("evening", "Tea") == 1 and u.count("night", "LightOff") == 1
    # event 2: LightOn's share 1.0, but the light was on: nothing proposed, nothing judged;
    # event 4: share 1/2, wanted: every threshold below 0.5 hits (F1 2·1/(1+3)), 0.4 the nearest
    assert thresholds == [0.5, 0.5, 0.5, 0.4, 0.4]
    morning = {AT: datetime(2026, 3, 3, 7), "light": "off"}
    assert u.shares(morning) == {"LightOn": pytest.approx(2 / 3)}
    assert u.predict_one(morning) == {"LightOn"}
    assert u.predict_one({**morning, "light": "on"}) == set()  # it would change nothing
    assert u.predict_one({AT: datetime(2026, 3, 3, 20), "light": "on"}) == {"Tea"}
    assert u.predict_one({AT: datetime(2026, 3, 3, 14), "light": "off"}) == set()  # no afternoons


def test_ha_usage_forgets_what_is_older_than_30_days():
    u, _ = learned_usage()
    # exactly 30 days after the first event it still counts (HA: fired at or after now − 30 d)
    assert u.shares({AT: datetime(2026, 3, 31, 8), "light": "off"}) == {"LightOn": pytest.approx(2 / 3)}
    assert u.shares({AT: datetime(2026, 3, 31, 8, 15), "light": "off"}) == {"LightOn": 0.5}
    assert u._events["morning"] == 2 and u.count("morning", "LightOn") == 1
    assert u.shares({AT: datetime(2026, 4, 1, 8, 45), "light": "off"}) == {}  # every morning gone
    assert u.ranked("evening") == [] and u.ranked("night") == ["LightOff"]
    assert u.shares({AT: datetime(2026, 4, 2, 0, 0), "light": "on"}) == {}  # and the last night
    assert u.ranked("night") == [] and len(u._timed) == 0 and sum(u._events.values()) == 0


def test_ha_usage_ranks_and_keeps_the_eight_most_used():
    services = {f"S{k}": [] for k in range(10)}
    u = HAUsage(services)
    at = datetime(2026, 3, 1, 13)
    u.learn_one({AT: at}, set(services))
    u.learn_one({AT: at}, {"S9", "S8"})
    # S8 and S9 twice, then the ties in the home's order, cut at HA's eight
    assert u.ranked("afternoon") == ["S8", "S9", "S0", "S1", "S2", "S3", "S4", "S5"]
    assert set(u.shares({AT: at})) == set(u.ranked("afternoon"))


def test_ha_usage_without_timestamps_reads_the_homes_clock():
    studio = load_home(STUDIO)
    m = OnlineMethod("ha_usage", studio)
    assert m.features([0, 0, 0, 1, 0, 0])[HOUR] == 12.75  # the day bin 06:30–19:00: its middle
    codes = np.array([[1, 0, 0, 1, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 0, 1, 0, 0]])
    readings = np.array([[np.nan] * 6, [7.0, *[np.nan] * 5], [np.nan] * 6])
    performed = np.zeros((3, len(studio.services)), dtype=bool)
    performed[:, studio.service_index("LowerBlind")] = True
    m.learn_samples(codes, performed, readings)
    # night's middle is 00:45 (night), the reading 7:00 is a morning, the day's middle 12:45
    assert dict(m.learner._events) == {"night": 1, "morning": 1, "afternoon": 1}
    assert m.learner.count("morning", "LowerBlind") == 1 and not m.learner._timed  # no window


def test_markov_learns_transitions_and_falls_back_to_the_unconditional_share():
    m = ServiceMarkov({"A": [], "B": [], "LampOn": [("lamp", True)]})
    previous, answers, thresholds = None, [], []
    for y in ({"A"}, {"B"}, {"A"}, {"B"}, {"A"}, set()):
        x = {PREVIOUS: previous, "lamp": "off"}
        answers.append(m.predict_one(x))
        m.learn_one(x, y)
        thresholds.append(m.threshold)
        previous = frozenset(y)
    # 2nd: {A} never seen, the unconditional A; then the chain knows A → B and B → A
    assert answers == [set(), {"A"}, set(), {"B"}, {"A"}, {"B"}]
    assert thresholds == [0.5, 0.5, 0.4, 0.4, 0.4, 0.4]
    assert m.transitions(frozenset({"A"})) == {"B": 2} and m.transitions(frozenset({"B"})) == {"A": 2}
    assert m.shares({PREVIOUS: frozenset({"A"})}) == {"B": pytest.approx(2 / 3)}
    assert (
        m.shares({PREVIOUS: None})
        == m.shares({PREVIOUS: frozenset()})
        == {"A": 0.5, "B": pytest.approx(1 / 3)}
    )
    m.learn_one({PREVIOUS: frozenset({"B"}), "lamp": "off"}, {"LampOn"})
    assert m.shares({PREVIOUS: frozenset({"B"})}) == {
        "A": pytest.approx(2 / 3),
        "LampOn": pytest.approx(1 / 3),
    }
    assert "LampOn" not in m.predict_one({PREVIOUS: frozenset({"B"}), "lamp": "on"})


def test_markov_in_eval_counts_the_samples_alone():
    studio = load_home(STUDIO)
    m = OnlineMethod("markov", studio)
    performed = np.zeros((4, len(studio.services)), dtype=bool)
    performed[:3, studio.service_index("BringTea")] = True
    m.learn_samples(np.array([[0, 0, 0, 1, 0, 0]] * 4), performed)
    assert m.learner.shares({PREVIOUS: None}) == {"BringTea": 0.75}
    assert m.predict_one(Space(studio).point(studio_context())) == ["BringTea"]


def studio_context() -> dict[str, str]:
    return {
        "time": "10:00",
        "light": "50",
        "activity": "work",
        "blind": "on",
        "desk_lamp": "off",
        "radio": "off",
    }


def renamed(name: str) -> str:
    return "where" if name == "location" else name


def test_frequency_keys_on_kinds_not_names():
    """The paper's home with ``location`` renamed ``where``: the same answers, event by event."""
    paper = load_home("paper")
    text = (Path(homecog.home.__file__).parent / "homes" / "paper.yaml").read_text()
    other = load_home_text(re.sub(r"\blocation\b", "where", text), "paper_where.yaml")
    assert "where" in other.feature_names and "location" not in other.feature_names
    a, b = OnlineMethod("frequency", paper), OnlineMethod("frequency", other)
    space = Space(other)
    answers = []
    for s in random_scenarios(paper, 400, seed=5):
        point = space.point({renamed(k): v for k, v in s.context.items()})
        answer = a.predict_one(s.point)
        assert b.predict_one(point) == answer
        answers.append(answer)
        a.learn_one(s.point, s.truth)
        b.learn_one(point, s.truth)
    assert sum(map(bool, answers)) > 100  # they answered, not only agreed on nothing


def test_kmeans_learns_the_stream():
    from homecog.evaluation import methods
    from homecog.evaluation.learn import learn_methods
    from homecog.knowledge.pipeline import ensure_policy

    studio = load_home(STUDIO)
    kmeans = learn_methods(studio, ensure_policy(studio), ["kmeans"]).methods["kmeans"]
    point = Space(studio).point(studio_context())
    assert "SayGoodnight" not in kmeans.predict_one(point)  # the studio's rules: not at 10:00
    kmeans.learn_one(point, ["SayGoodnight"])  # the household's whim: its cluster learns it now
    assert kmeans.predict_one(point) == ["SayGoodnight"]
    assert kmeans._stream is None
    for _ in range(methods.REFIT + len(kmeans.centers)):
        kmeans.learn_one(point, ["SayGoodnight"])
    assert kmeans._stream is not None and int(kmeans._members.sum()) == 1 + methods.REFIT + len(
        kmeans.centers
    )
    assert kmeans.predict_one(point) == ["SayGoodnight"]


def write_events(path: Path, n: int) -> list[tuple[str, list[str]]]:
    """``n`` studio events, one every 40 minutes; their timestamps and services."""
    home = load_home(STUDIO)
    names = list(home.feature_names + home.device_names)
    lines, rows = ["timestamp," + ",".join(names) + ",services"], []
    for i, s in enumerate(random_scenarios(home, n, seed=2)):
        stamp = (datetime(2026, 3, 1, 6, 0) + timedelta(minutes=40 * i)).isoformat()
        services = [x for x in home.service_names if x in s.truth]
        lines.append(stamp + "," + ",".join(s.context[k] for k in names) + "," + ";".join(services))
        rows.append((stamp, services))
    path.write_text("\n".join(lines) + "\n")
    return rows


def test_replay_writes_every_answer_to_the_predictions_file(tmp_path, capsys):
    events, out = tmp_path / "events.csv", tmp_path / "p.jsonl"
    rows = write_events(events, 60)
    args = ["replay", "--home", STUDIO, "--events", str(events), "--methods", "frequency,ha_usage,markov"]
    code = main([*args, "--predictions", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    data = json.loads(captured.out)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(lines) == data["events"] == 60
    order = load_home(STUDIO).service_names
    for i, (line, (stamp, services)) in enumerate(zip(lines, rows, strict=True), start=1):
        assert list(line) == [
            "event",
            "timestamp",
            "truth",
            "frequency",
            "ha_usage",
            "markov",
            "probabilities",
        ]
        assert list(line["probabilities"]) == ["frequency", "ha_usage", "markov"]
        assert (line["event"], line["timestamp"], line["truth"]) == (i, stamp, services)
        for name in ("frequency", "ha_usage", "markov"):
            assert line[name] == sorted(line[name], key=order.index)
    assert lines[0]["ha_usage"] == lines[0]["markov"] == []  # nothing learned before the first
    # the file's answers are the figures' answers: the micro F1 again from its lines
    for name in ("frequency", "ha_usage", "markov"):
        hits = sum(len(set(x[name]) & set(x["truth"])) for x in lines)
        total = sum(len(x[name]) + len(x["truth"]) for x in lines)
        assert data["methods"][name]["f1"] == pytest.approx(2 * hits / total, abs=1e-6)


@pytest.mark.parametrize(
    ("where", "message"),
    [
        (".", "--predictions {tmp}: is a directory"),
        ("nodir/p.jsonl", "--predictions {tmp}/nodir/p.jsonl: cannot write there: no directory {tmp}/nodir"),
    ],
)
def test_replay_predictions_bad_path(tmp_path, capsys, where, message):
    events = tmp_path / "events.csv"
    write_events(events, 5)
    target = tmp_path if where == "." else tmp_path / where
    code = main(["replay", "--home", STUDIO, "--events", str(events), "--predictions", str(target)])
    _, err = capsys.readouterr()
    assert code == 2
    assert err.strip().splitlines() == [f"homecog: error: {message.format(tmp=tmp_path)}"]
