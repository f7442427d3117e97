"""Checks like river's (``river/checks``), over every learner of the knowledge stage: the tree in
both modes, learned from a joint table and group by group. Each must clone untrained, survive
pickling and the store, answer the same whatever the order of a context's features, and learn
a batch as it learns its samples one by one. And the tree's parts on tiny hand-built trees."""

from __future__ import annotations

import pickle
import random

import pytest

from homecog.evaluation.scenarios import random_scenarios
from homecog.home import Home, load_home
from homecog.home.codec import Point
from homecog.knowledge import core
from homecog.knowledge.box_index import BoxIndex
from homecog.knowledge.correction import Correction
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.model import IDLE, Cluster, Node
from homecog.knowledge.pipeline import learn_policy
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet, policy_samples
from homecog.knowledge.store import Store
from homecog.learning.grouped import train_policy
from homecog.learning.sarsa import SarsaConfig

LEARNERS = [
    ("flat", "multi", False),
    ("flat", "paper", False),
    ("flat", "multi", True),
    ("studio", "paper", True),
]


def _name(p: tuple[str, str, bool]) -> str:
    return f"{p[0]}-{p[1]}-{'joint' if p[2] else 'grouped'}"


@pytest.fixture(scope="module", params=LEARNERS, ids=_name)
def learned(request: pytest.FixtureRequest) -> tuple:
    from pathlib import Path

    name, mode, joint = request.param
    home = load_home(Path(__file__).parent / "homes" / f"{name}.yaml")
    config = SarsaConfig(episodes=600_000, seed=0)  # joint; group by group: until stable
    policy = train_policy(home, config, joint=joint).policy
    tree = IHDRTree(home, mode=mode)
    log = SampleLog(seed=0, joint=joint)
    learn_policy(home, policy, tree, log=log)
    return home, policy, tree, log


def _contexts(home: Home, n: int, seed: int) -> list[dict[str, str]]:
    return [s.context for s in random_scenarios(home, n, seed=seed)]


def test_clone_is_untrained_with_the_same_parameters(learned):
    _, _, tree, _ = learned
    clone = tree.clone()
    assert repr(clone) == repr(tree) and clone.mode == tree.mode
    assert clone.n_clusters() == 0 and tree.n_clusters() > 0
    assert clone.clone().signature() == clone.signature()  # clone is idempotent


def test_pickling_round_trip(learned):
    home, _, shared, _ = learned
    tree = pickle.loads(pickle.dumps(shared))  # the fixture is shared: change a copy
    tree.correct_one(_contexts(home, 1, seed=1)[0], [], user="kim")  # with a user layer too
    back = pickle.loads(pickle.dumps(tree))
    assert back.signature() == tree.signature()
    for x in _contexts(home, 200, seed=3):
        for user in (None, "kim"):
            assert back.explain_one(x, user=user).as_dict() == tree.explain_one(x, user=user).as_dict()


def test_the_store_and_a_rebuild_from_its_log_answer_identically(learned, tmp_path):
    home, _, shared, log = learned
    tree = pickle.loads(pickle.dumps(shared))
    store = Store.open(f"sqlite:///{tmp_path / 'k.sqlite'}", home)
    core.save_build(store, tree, log)
    for x in _contexts(home, 20, seed=9):
        core.correct(store, tree, Correction.whole("ann", tree.point(x), []))
    loaded, rebuilt = store.load_tree(), core.rebuild(store)
    assert loaded.signature() == rebuilt.signature() == tree.signature()
    for x in _contexts(home, 200, seed=5):
        expected = tree.explain_one(x, user="ann").as_dict()
        assert loaded.explain_one(x, user="ann").as_dict() == expected
        assert rebuilt.explain_one(x, user="ann").as_dict() == expected


def test_feature_order_is_irrelevant(learned):
    home, _, tree, _ = learned
    rng = random.Random(0)
    for x in _contexts(home, 200, seed=4):
        items = list(x.items())
        rng.shuffle(items)
        assert tree.predict_one(dict(items)) == tree.predict_one(x)


def test_learn_one_equals_learn_many(learned):
    home, policy, tree, _ = learned
    one = tree.clone()
    names, dim_names = home.service_names, tree.space.names
    for ss in (s.expand() for s in policy_samples(home, policy)):
        dims = ss.dims or tuple(range(len(ss.space.dims)))
        where = ss.services or tuple(range(ss.positions.shape[1]))

        def named(mask: int, dims: tuple[int, ...] = dims) -> set[str]:
            return {dim_names[dims[j]] for j in range(len(dims)) if mask >> j & 1}

        for i in range(len(ss)):
            s = ss[i]
            relevant = {names[where[a]]: named(m) for a, m in zip(s.services, s.relevant, strict=True)}
            relevant[IDLE] = named(int(ss.masks[i, -1]))
            one.learn_one(
                _in_home(tree, ss, i, dims), [names[where[a]] for a in s.services], relevant=relevant
            )
    for x in _contexts(home, 300, seed=6):
        a, b = one.explain_one(x), tree.explain_one(x)
        assert (a.services, a.unknown) == (b.services, b.unknown)


def _in_home(tree: IHDRTree, ss: SampleSet, i: int, dims: tuple[int, ...]) -> Point:
    """A group's sample as a point of the whole home (the other devices off: they do not matter)."""
    codes = [0] * len(tree.space.dims)
    readings: list[float | None] = [None] * len(tree.space.dims)
    for j, g in enumerate(dims):
        codes[g] = int(ss.codes[i, j])
        r = float(ss.readings[i, j])
        readings[g] = None if r != r else r
    return Point(tuple(codes), tuple(readings))


# -- tiny hand-built trees -----------------------------------------------------------------------
def test_a_hand_built_tree_walks_depth_first():
    root = Node(0, "root", "root")
    on = Node(1, "on", "category", parent=root)
    off = Node(2, "off", "category", parent=root)
    root.children = [on, off]
    lamp = Node(3, "LampOn", "service", parent=on, service=0)
    on.children = [lamp]
    assert [n.name for n in root.iter_dfs()] == ["root", "on", "LampOn", "off"]
    assert (root.height, root.n_nodes, off.height, lamp.n_nodes) == (3, 4, 1, 1)


def test_box_index_lookup_merge_partners_and_overlaps():
    index = BoxIndex()
    a = Cluster(id=5, conditions={0: frozenset({1}), 2: frozenset({0, 1})})
    b = Cluster(id=3, conditions={2: frozenset({1})})
    index.add(a)
    index.add(b)
    assert index.lookup((1, 9, 0)) is a
    assert index.lookup((1, 9, 1)) is b  # both respond: the lowest id wins
    assert index.lookup((0, 9, 0)) is None
    assert index.covering(a.mask, (1, 0)) is a and index.covering(a.mask, (2, 0)) is None
    c = Cluster(id=8, conditions={0: frozenset({2}), 2: frozenset({0, 1})})
    assert index.partner(c, index.partner_keys(c)) is a  # same on dimension 2, one apart on 0
    d = Cluster(id=9, conditions={0: frozenset({2}), 2: frozenset({0})})
    assert index.partner(d, index.partner_keys(d)) is None  # differs on both


def test_a_tree_learns_and_forgets_nothing_it_was_not_told():
    home = load_home("paper")
    tree = IHDRTree(home)
    x = {
        "time": "19:00",
        "temperature": 30,
        "illumination": 200,
        "location": "sofa",
        "posture": "sit",
        "behavior": "watch_tv",
        **dict.fromkeys(home.device_names, "off"),
    }
    tree.learn_one(x, ["TurnOnTVL"], relevant={"TurnOnTVL": {"behavior", "tv_living"}})
    assert tree.predict_one({**x, "location": "bed"}) == ["TurnOnTVL"]  # location did not matter
    assert tree.predict_one({**x, "tv_living": "on"}) == []
    assert tree.explain_one({**x, "behavior": "read"}).unknown
