"""Corrections that generalize the way a person means them: which features matter is
learned from the corrections, evidence is counted, a household's own thresholds are learned on
the readings, nothing that would change nothing is proposed, the answers say which corrections
answered; and still incremental, durable and per user."""

from __future__ import annotations

import pickle

import pytest
from knowledge_fixtures import samples, tree

from homecog.evaluation.households import make_household
from homecog.evaluation.scenarios import random_scenarios
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.store import Store


def fresh(name: str = "paper"):
    return pickle.loads(pickle.dumps(tree(name)))


def lamp_for_reading(point, home) -> list[str]:
    """Ann's wish: the desk lamp whenever she reads, wherever, whenever; nothing else."""
    n_f = len(home.features)
    reading = point.codes[home.feature_index("behavior")] == home.feature("behavior").index("read")
    lamp_off = point.codes[n_f + home.device_index("lamp")] == 0
    return ["TurnOnLamp"] if reading and lamp_off else []


def test_the_features_that_matter_are_learned_from_the_corrections():
    t = fresh()
    home = t.home
    for s in random_scenarios(home, 120, seed=1):
        t.correct_one(s.point, lamp_for_reading(s.point, home), user="ann")
    lamp = home.service_index("TurnOnLamp")
    key = t.layers.learners("ann")[lamp].best_key()
    assert home.feature_index("behavior") in key  # its change flips the wish
    assert home.feature_index("location") not in key  # it varied while the wish stayed
    right = 0
    tests = random_scenarios(home, 300, seed=2)
    for s in tests:
        right += ("TurnOnLamp" in t.predict_one(s.point, user="ann")) == bool(lamp_for_reading(s.point, home))
    assert right / len(tests) >= 0.97
    # and everything else she never wants is rejected for her alone, as far as her corrections
    # reached (a rejection holds near where it was made: 120 of them leave a few percent)
    left = sum(len(set(t.predict_one(s.point, user="ann")) - {"TurnOnLamp"}) for s in tests)
    before = sum(len(set(t.predict_one(s.point)) - {"TurnOnLamp"}) for s in tests)
    assert before > 1000 and left <= 0.05 * before


def test_a_households_own_threshold_inside_a_bin_is_learned_on_the_readings():
    """The AC from 23 °C, where the home's bin is [-inf, 25): the paper's discretization
    adjusted by feedback (§2.1.1)."""
    t = fresh()
    home = t.home
    j = home.feature_index("temperature")
    n_f = len(home.features)
    ac = n_f + home.device_index("ac_living")

    def wish(point) -> list[str]:
        return ["TurnOnACL"] if point.readings[j] >= 23 and point.codes[ac] == 0 else []

    for s in random_scenarios(home, 400, seed=3):
        t.correct_one(s.point, wish(s.point), user="kim")
    base = next(s for s in random_scenarios(home, 200, seed=4) if s.point.codes[ac] == 0)
    context = dict(base.context)
    assert "TurnOnACL" in t.predict_one({**context, "temperature": "23.4"}, user="kim")
    assert "TurnOnACL" not in t.predict_one({**context, "temperature": "22.6"}, user="kim")
    answer = t.explain_one({**context, "temperature": "24"}, user="kim")
    why = next(e for e in answer.explanations if e.service == "TurnOnACL")
    assert why.user == "kim"
    assert why.conditions["temperature"] in ("≥ 23 °C", "[23, 25) °C")
    assert why.evidence["agreed"] > 0 and why.evidence["corrections"]


def test_a_service_that_would_change_nothing_is_never_proposed():
    t = fresh()
    home = t.home
    for s in random_scenarios(home, 60, seed=5):
        t.correct_one(
            s.point, ["TurnOnLamp"] if s.point.codes[len(home.features) + 7] == 0 else [], user="ann"
        )
    for s in random_scenarios(home, 400, seed=6):
        for user in (None, "ann"):
            for name in t.predict_one(s.point, user=user):
                service = home.services[home.service_index(name)]
                states = s.point.codes[len(home.features) :]
                assert not service.sets or any(
                    states[home.device_index(d)] != int(on) for d, on in service.sets
                ), (name, s.context)


def test_explanations_say_which_corrections_answered_and_how_many_agreed():
    t = fresh("studio")
    x = {
        "time": "08:00",
        "light": 500,
        "activity": "relax",
        "blind": "on",
        "desk_lamp": "off",
        "radio": "off",
    }
    for want in (["RadioOn"], ["RadioOn"], [], ["RadioOn"]):
        t.correct_one(x, want, user="ann")
    why = next(e for e in t.explain_one(x, user="ann").explanations if e.service == "RadioOn")
    assert why.user == "ann"
    assert why.evidence == {"agreed": 3, "disagreed": 1, "corrections": [1, 2, 4]}
    assert why.as_dict()["evidence"]["agreed"] == 3


def test_one_users_corrections_never_change_anothers_answers():
    t = fresh()
    household = make_household(t.home, "wishes", seed=4)
    contexts = random_scenarios(t.home, 300, seed=8)
    for e in household.stream(40, seed=9):
        t.correct_one(e.point, sorted(e.wanted), user="bob")
    before = [t.predict_one(s.point, user="bob") for s in contexts]
    shared = [t.predict_one(s.point) for s in contexts]
    for e in household.stream(200, seed=10):
        t.correct_one(e.point, sorted(e.wanted), user="ann")
    assert [t.predict_one(s.point, user="bob") for s in contexts] == before
    assert [t.predict_one(s.point) for s in contexts] == shared
    assert [t.predict_one(s.point, user="ann") for s in contexts] != shared


@pytest.mark.parametrize("kind", ["wishes", "thresholds"])
def test_a_household_is_learned_from_its_corrections(kind):
    t = fresh()
    household = make_household(t.home, kind, seed=1)
    for e in household.stream(1000, seed=1, noisy=False):
        t.correct_one(e.point, sorted(e.wanted), user="h")
    hits = predicted = true = 0
    for e in household.stream(500, seed=2, noisy=False):
        p = set(t.predict_one(e.point, user="h"))
        hits, predicted, true = hits + len(p & e.clean), predicted + len(p), true + len(e.clean)
    assert 2 * hits / (predicted + true) >= 0.95


def test_the_log_rebuilds_every_users_answers_exactly(tmp_path):
    t = fresh("studio")
    store = Store.open(f"sqlite:///{tmp_path}/k.sqlite", t.home)
    core.save_build(store, t, samples("studio"))
    live = store.load_tree()
    contexts = random_scenarios(t.home, 200, seed=12)
    for user, seed in (("ann", 1), ("bob", 2)):
        household = make_household(t.home, "thresholds", seed=seed)
        for e in household.stream(60, seed=seed):
            core.correct(store, live, Correction.whole(user, e.point, sorted(e.wanted)))
    rebuilt, loaded = core.rebuild(store), store.load_tree()
    assert rebuilt.signature() == loaded.signature() == live.signature()
    for user in ("ann", "bob", None):
        answers = [live.predict_one(s.point, user=user) for s in contexts]
        assert [rebuilt.predict_one(s.point, user=user) for s in contexts] == answers
        assert [loaded.predict_one(s.point, user=user) for s in contexts] == answers
    store.close()


def test_a_noisy_household_stream_is_the_same_in_every_process():
    """The skips are drawn over the services in order: a set's order changes with the hash seed
    of the process, and the benchmark's figures changed from run to run with it."""
    import hashlib

    from processes import outputs_by_hash_seed

    code = (
        "import hashlib; from homecog.evaluation.households import make_household; "
        "from homecog.home import load_home; "
        "h = make_household(load_home('paper'), 'wishes', seed=0); "
        "print(hashlib.sha256(repr([sorted(e.wanted) for e in h.stream(300, seed=0)]).encode()).hexdigest())"
    )
    digests = outputs_by_hash_seed(code, (1, 2, 3))
    from homecog.home import load_home

    events = make_household(load_home("paper"), "wishes", seed=0).stream(300, seed=0)
    here = hashlib.sha256(repr([sorted(e.wanted) for e in events]).encode()).hexdigest()
    assert digests == {here}
