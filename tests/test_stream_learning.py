"""A household's stream learned as a stream: keys judged by how they predicted each event before
it was counted and averaged by that, an additive model beside them, the recent past kept by a
reload, and readings that are missing."""

from __future__ import annotations

import math
import pickle
import random
from dataclasses import replace
from datetime import datetime, timedelta
from pathlib import Path

import pytest
from knowledge_fixtures import tree

from homecog.errors import EvaluationError
from homecog.evaluation.replay import replay
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import load_home
from homecog.home.codec import Space
from homecog.home.recent import RecentPast
from homecog.home.scenario_file import load_scenarios
from homecog.knowledge import core
from homecog.knowledge.additive import AtomLogistic
from homecog.knowledge.correction import Correction
from homecog.knowledge.cuts import kt_share
from homecog.knowledge.evidence import ServiceLearner
from homecog.knowledge.pipeline import open_tree
from homecog.knowledge.store import Store

T0 = datetime(2026, 11, 30, 18, 0)
PAPER_X = {
    "time": "19:00", "temperature": 30, "illumination": 200, "location": "sofa", "posture": "sit",
    "behavior": "watch_tv", "window": "on", "curtain": "on", "tv_living": "off", "tv_bedroom": "off",
    "ac_living": "off", "ac_bedroom": "off", "lamp": "off", "ceiling_light": "off",
}  # fmt: skip


def posterior(learner: ServiceLearner, *, snapshot: bool = False) -> dict[int, float]:
    """The keys' weights in a stream, each ``exp(−prequential loss)`` normalized (Bayes' rule over
    the keys), per key position; for a ``snapshot`` the keys of the context alone."""
    candidates = learner._ranked(snapshot).tolist()
    least = min(learner._preq[i] for i in candidates)
    weights = {i: math.exp(least - learner._preq[i]) for i in candidates}
    total = sum(weights.values())
    return {i: w / total for i, w in weights.items()}


def _stream_learner(examples: list[tuple[int, str, bool]]) -> ServiceLearner:
    """A learner of one context atom (a code 0–2), one recent atom and the shared answer."""
    learner = ServiceLearner(3, {}, order=2, n_recent=1)
    for code, recent, wanted in examples:
        learner.add([None, None], [code, 0], wanted, shared=False, recent=(recent,))
    return learner


def test_a_whole_stream_is_learned_by_the_posterior_over_keys():
    rng = random.Random(0)
    # wanted exactly where the context atom is 1 and the recent atom says "a": a conjunction
    rows = [(rng.randrange(3), rng.choice("ab"), False) for _ in range(300)]
    learner = _stream_learner([(c, r, c == 1 and r == "a") for c, r, _ in rows])
    assert learner.streaming
    assert learner.best_key() == (0, 1)
    weights = posterior(learner)
    assert weights[learner._index[(0, 1)]] > 0.99
    assert math.isclose(sum(weights.values()), 1.0)
    yes = learner.decide([None, None], [1, 0], shared=False, recent=("a",))
    no = learner.decide([None, None], [1, 0], shared=False, recent=("b",))
    assert (yes.sign, no.sign) == (1, -1)
    assert yes.share > 0.95 and no.share < 0.05
    assert (yes.key, yes.cell) == ((0, 1), (1, "a"))


def test_a_key_that_never_saw_the_moment_sleeps():
    rng = random.Random(2)
    # wanted exactly where the recent atom says "a" (one moment in five): its key takes the weight
    rows = [(rng.randrange(3), "a" if rng.random() < 0.2 else "b") for _ in range(300)]
    learner = _stream_learner([(c, r, r == "a") for c, r in rows])
    assert sum(w for i, w in posterior(learner).items() if 1 in learner.keys[i]) > 0.99
    # a recent atom never seen: the keys holding it sleep, and those that know the moment (the
    # context atom's, the base rate's) answer, about one in five, not the ½ of an empty cell
    new = learner.decide([None, None], [1, 0], shared=False, recent=("c",))
    assert 1 not in new.key and new.wanted + new.unwanted > 0
    assert 0.1 < new.share < 0.3 and new.sign == -1
    known = learner.decide([None, None], [1, 0], shared=False, recent=("a",))
    assert known.share > 0.95 and 1 in known.key
    # one example: only the base rate's key and the keys of its own cells know anything
    one = _stream_learner([(1, "a", True)])
    assert one.decide([None, None], [2, 0], shared=False, recent=("b",)).share == 0.75


def test_a_partial_example_ends_the_stream_and_snapshots_never_start_one():
    learner = _stream_learner([(1, "a", True), (0, "b", False)])
    assert learner.streaming
    learner.add([None, None], [1, 0], True, shared=False, recent=("a",), partial=True)
    assert not learner.streaming  # a person's hands refine the shared answer, as before
    # a snapshot cognition after a stream: only the keys of the context weigh
    stream = _stream_learner([(1, "a", True), (0, "b", False)] * 10)
    recent_keys = {i for i, k in enumerate(stream.keys) if 1 in k}
    assert not recent_keys & set(posterior(stream, snapshot=True))
    assert stream.decide([None, None], [1, 0], shared=False).sign == 1
    snapshots = ServiceLearner(3, {}, order=2, n_recent=1)
    snapshots.add([None, None], [1, 0], True, shared=False)  # no recent past: a snapshot
    assert not snapshots.streaming


def test_a_cell_never_seen_says_one_half():
    assert (kt_share(None), kt_share([1, 1, 0]), kt_share([9, 0, 1])) == (0.5, 0.5, 0.95)


def test_the_additive_model_adds_the_evidence_of_several_atoms():
    rng = random.Random(1)
    model = AtomLogistic()
    for _ in range(600):  # wanted where either atom says so: no one key's cell holds that
        a, b = rng.random() < 0.3, rng.random() < 0.3
        model.learn_one(0, (a, b), a or b)
    p = {(a, b): model.predict_one(0, (a, b)) for a in (False, True) for b in (False, True)}
    assert p[(False, False)] < 0.1
    assert min(p[(True, False)], p[(False, True)], p[(True, True)]) > 0.8
    # a service never learned borrows the shared weights, not its own
    assert model.predict_one(1, (False, False)) < 0.2
    assert pickle.loads(pickle.dumps(model)).predict_one(0, (True, False)) == p[(True, False)]


def test_a_stream_learned_through_the_store_answers_the_same_after_a_reload(tmp_path: Path):
    home = load_home("paper")
    url = f"sqlite:///{tmp_path}/k.sqlite"
    store = Store.open(url, home)
    t = open_tree(home, store)
    past = RecentPast(home)
    space = Space(home)
    when = T0
    for k in range(40):  # the lamp wanted at every other moment: only the recent past tells
        p = replace(space.point(PAPER_X), recent=past.at(when, PAPER_X))
        want = ["TurnOnLamp"] if k % 2 else []
        core.correct(store, t, Correction.whole("ann", p, want))
        past.learn(when, PAPER_X, want)
        when += timedelta(minutes=7)
    probe = replace(space.point(PAPER_X), recent=past.at(when, PAPER_X))
    before = t.predict_one(probe, "ann")
    assert t.layers.learners("ann")[home.service_index("TurnOnLamp")].streaming
    store.close()
    again = Store.open(url, home)
    reloaded = open_tree(home, again)
    assert reloaded.predict_one(probe, "ann") == before
    lamp = reloaded.layers.learners("ann")[home.service_index("TurnOnLamp")]
    assert lamp.streaming  # the recent past came back with the corrections
    again.close()


def test_a_missing_reading_is_unknown_and_round_trips():
    home = load_home("paper")
    space = Space(home)
    for word in ("unknown", "", " Unknown "):
        p = space.point({**PAPER_X, "temperature": word})
        assert p.missing == frozenset({1}) and p.readings[1] is None
        assert space.context(p)["temperature"] == "unknown" == space.word(p, 1)
        assert space.point(space.context(p)) == p
    # a categorical feature that lists `unknown` as a value keeps it as that value
    studio = load_home(Path(__file__).parent / "homes" / "studio_log.yaml")
    studio_space = Space(studio)
    x = dict(zip(studio_space.names, ["07:00", "50", "work", "unknown", "off", "off", "off"], strict=True))
    assert studio_space.point(x).missing == frozenset()


def test_the_shared_tree_answers_what_it_would_whatever_the_missing_reading():
    t = pickle.loads(pickle.dumps(tree("paper")))
    home = t.home
    rng = random.Random(2)
    for scenario in random_scenarios(home, 40, seed=3):
        j = rng.choice([1, 2])  # temperature or illumination
        f = home.features[j]
        every = []
        for low, high in f.bins:  # one reading inside each bin
            reading = high - 1 if math.isinf(low) else low + 1 if math.isinf(high) else (low + high) / 2
            every.append(set(t.predict_one({**scenario.context, f.name: reading})))
        unknown = t.predict_one({**scenario.context, f.name: "unknown"})
        assert set(unknown) == set.intersection(*every), (scenario.context, f.name)
    # Fig. 9's second case without the thermometer: the AC and the window wait for it
    without = t.predict_one({**PAPER_X, "temperature": "unknown"})
    assert set(without) == {"TurnOnLight", "TurnOnTVL", "SendDrinks"}


def test_event_files_take_missing_readings_scenario_files_need_services_for_them(tmp_path: Path):
    home = load_home("paper")
    header = "timestamp," + ",".join(home.feature_names + home.device_names) + ",services\n"
    row = "2026-11-30T19:00:00,19:00,{t},200,sofa,sit,watch_tv,on,on,off,off,off,off,off,off,{s}\n"
    events = tmp_path / "events.csv"
    events.write_text(header + row.format(t="", s="TurnOnLight") + row.format(t="30", s="TurnOnLight"))
    first, second = load_scenarios(events, home, home, events=True)
    assert (first.point.missing, second.point.missing) == (frozenset({1}), frozenset())
    result = replay(home, events, methods=["multi", "frequency", "markov", "hoeffding"])
    assert result.events == 2
    scenarios = tmp_path / "scenarios.csv"
    scenarios.write_text(
        ",".join(home.feature_names + home.device_names)
        + "\n19:00,unknown,200,sofa,sit,watch_tv,on,on,off,off,off,off,off,off\n"
    )
    with pytest.raises(
        EvaluationError, match=r"line 2, column temperature: a missing reading needs a services"
    ):
        load_scenarios(scenarios, home, home)


def test_a_correction_with_a_missing_reading_keys_on_unknown(tmp_path: Path):
    home = load_home("paper")
    store = Store.open(f"sqlite:///{tmp_path}/k.sqlite", home)
    t = open_tree(home, store)
    space = Space(home)
    missing = space.point({**PAPER_X, "temperature": "unknown"})
    for _ in range(3):  # Kim wants the lamp whenever the thermometer says nothing
        core.correct(
            store, t, Correction.whole("kim", missing, ["TurnOnLamp", *t.predict_one(missing, "kim")])
        )
    assert "TurnOnLamp" in t.predict_one(missing, "kim")
    why = next(e for e in t.explain_one(missing, "kim").explanations if e.service == "TurnOnLamp")
    assert why.evidence["agreed"] == 3
    store.close()
    again = Store.open(f"sqlite:///{tmp_path}/k.sqlite", home)
    assert "TurnOnLamp" in open_tree(home, again).predict_one(missing, "kim")
    again.close()


def test_partial_examples_refine_the_shared_answer_by_the_context_alone():
    """A person's switches, however well the recent past would sort them, are learned over the
    context: a few of them cannot tell which of the recent past's keys matters."""
    learner = ServiceLearner(3, {}, order=2, n_recent=1)
    for k in range(40):
        recent = "a" if k % 2 else "b"
        learner.add([None, None], [k % 3, 0], recent == "a", shared=True, recent=(recent,), partial=True)
    assert not learner.streaming
    assert 1 not in learner.best_key() and 2 in learner.best_key()  # no recent atom; the shared answer
