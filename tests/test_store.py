"""The knowledge store against SQLite, PostgreSQL and MariaDB.

Every test runs once per database (the ``db_url`` fixture: a fresh database per test, dropped
afterwards; a server that cannot be reached skips its tests, saying why).
"""

from __future__ import annotations

import json
import multiprocessing
import os
import random
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from servers import (
    correction_worker,
    databases_left,
    fresh_database,
    varied_want,
)
from sqlalchemy import func, insert, select, update

from homecog.errors import ContextError, NameProblemError, StoreError
from homecog.home import Home, load_home_text
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import build
from homecog.knowledge.schema import ExperienceRow, HomeRow, UserRow
from homecog.knowledge.store import Store

STUDIO_TEXT = (Path(__file__).parent / "homes" / "studio.yaml").read_text()
WORK = {"time": "10:00", "light": 100, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "off"}
EVENING = {
    "time": "21:00",
    "light": 100,
    "activity": "relax",
    "blind": "on",
    "desk_lamp": "off",
    "radio": "off",
}
NIGHT = {
    "time": "23:00",
    "light": 10,
    "activity": "sleep",
    "blind": "off",
    "desk_lamp": "off",
    "radio": "off",
}


@pytest.fixture
def built(db_url: str, studio: Home, studio_build: Path):
    """A store of the studio home with a freshly built tree: (store, live tree)."""
    store = Store.open(db_url, studio)
    tree = build(studio, store, q_path=studio_build).tree
    yield store, tree
    store.close()


def _reopen(url: str, home: Home) -> IHDRTree:
    """The tree as another client sees it: a new Store object, loaded from the database."""
    store = Store.open(url, home)
    try:
        return store.load_tree()
    finally:
        store.close()


def _last_correction(store: Store) -> dict:
    with store.engine.connect() as conn:
        payload = conn.execute(
            select(ExperienceRow.payload)
            .where(ExperienceRow.kind == "correction")
            .order_by(ExperienceRow.id.desc())
            .limit(1)
        ).scalar_one()
    return json.loads(payload)


def _user_corrections(store: Store) -> tuple[dict[str, int], dict[str, int]]:
    """(users.corrections per user, correction rows in the log per user)."""
    with store.engine.connect() as conn:
        users = dict(conn.execute(select(UserRow.name, UserRow.corrections)).all())
        logged = dict(
            conn.execute(
                select(ExperienceRow.user, func.count())
                .where(ExperienceRow.kind == "correction")
                .group_by(ExperienceRow.user)
            ).all()
        )
    return users, logged


def _assert_consistent(url: str, home: Home) -> IHDRTree:
    """The database answers as its log says: loads, rebuilds to the same tree, counts agree."""
    store = Store.open(url, home)
    try:
        loaded = store.load_tree()
        assert core.rebuild(store).signature() == loaded.signature()
        users, logged = _user_corrections(store)
        assert users == logged
        assert store.counts()["corrections"] == sum(logged.values())
        return loaded
    finally:
        store.close()


# -- building and loading ---------------------------------------------------------------------------
def test_build_then_load(built: tuple[Store, IHDRTree], db_url: str, studio: Home) -> None:
    store, tree = built
    loaded = _reopen(db_url, studio)
    assert loaded.signature() == tree.signature()
    counts = store.counts()
    n_categories = len({s.category for s in studio.services}) + 1  # + the idle category
    assert counts["nodes"] == 1 + n_categories + len(studio.services) + 1  # root, categories, services, Idle
    assert counts["nodes"] == tree.root.n_nodes == 14
    assert counts["clusters"] == tree.n_clusters() > 0
    assert counts["user_clusters"] == counts["corrections"] == counts["users"] == 0
    assert store.experience_count() == tree.n_experiences > 0
    for context in (WORK, EVENING, NIGHT):
        assert loaded.predict_one(context) == tree.predict_one(context)
    assert loaded.predict_one(WORK) == ["RaiseBlind", "LampOn", "BringTea"]
    assert core.rebuild(store).signature() == tree.signature()


def test_rebuild_after_corrections_by_two_users(built: tuple[Store, IHDRTree]) -> None:
    store, tree = built
    plan = [
        ("alice", WORK, ["RaiseBlind", "LampOn", "BringTea", "RadioOn"]),  # adds
        ("bob", WORK, ["RaiseBlind", "LampOn"]),  # rejects
        ("alice", EVENING, ["LowerBlind", "SayGoodnight"]),  # rejects
        ("bob", NIGHT, ["SayGoodnight"]),  # adds where nothing was needed
        ("alice", NIGHT, ["LampOn", "RadioOn"]),  # adds two
        ("bob", EVENING, ["LowerBlind", "RadioOn", "SayGoodnight", "BringTea"]),  # adds
        ("alice", WORK, ["LampOn", "BringTea", "RadioOn"]),  # rejects one of her additions' kin
        ("bob", {**WORK, "activity": "relax"}, []),  # rejects everything
    ]
    kinds = set()
    for user, context, want in plan:
        added, rejected = _correct(store, tree, tree.point(context), want, user)
        kinds |= {"add"} if added else set()
        kinds |= {"reject"} if rejected else set()
        assert set(tree.predict_one(context, user)) == set(want)
    assert kinds == {"add", "reject"}
    assert tree.n_clusters("alice") > 0
    assert tree.n_clusters("bob") > 0
    rebuilt = core.rebuild(store)
    assert rebuilt.signature() == tree.signature()
    assert store.load_tree().signature() == tree.signature()
    user, context, want = plan[-1]
    assert rebuilt.predict_one(context, user) == want == []
    for user, context, _ in plan:
        assert rebuilt.predict_one(context, user) == tree.predict_one(context, user)


# -- building again ------------------------------------------------------------------------------------
STUDIO_SAMPLES = 96  # the studio's start states, from its joint Q table (studio_build)
STUDIO_GROUP_SAMPLES = 40  # its groups' classes of contexts, from the Q tables learned group by group


def _sample_batches(store: Store) -> list[dict]:
    with store.engine.connect() as conn:
        rows = conn.execute(select(ExperienceRow.payload).where(ExperienceRow.kind == "samples"))
        return [json.loads(p) for (p,) in rows]


def _correct_three(store: Store, tree: IHDRTree) -> dict[str, list[list[str]]]:
    """Two users' corrections (three in all); what each user is answered in the three contexts."""
    _correct(store, tree, tree.point(WORK), ["RaiseBlind", "LampOn", "BringTea", "RadioOn"], "alice")
    _correct(store, tree, tree.point(EVENING), ["LowerBlind", "SayGoodnight"], "alice")
    _correct(store, tree, tree.point(NIGHT), ["SayGoodnight"], "bob")
    return {u: [tree.predict_one(c, u) for c in (WORK, EVENING, NIGHT)] for u in ("alice", "bob")}


def test_building_again_changes_nothing(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home, studio_build: Path
) -> None:
    """A second build from the same Q table and seed leaves the log, its counts and the tree
    as the first left them: the build's samples replace the previous build's."""
    store, tree = built
    assert store.experience_count() == tree.n_experiences == STUDIO_SAMPLES
    counts, signature = store.counts(), tree.signature()
    assert counts["experiences"] == len(_sample_batches(store)) == 1
    again = build(studio, store, q_path=studio_build)
    assert again.samples == STUDIO_SAMPLES
    assert store.experience_count() == again.tree.n_experiences == STUDIO_SAMPLES
    assert store.counts() == counts
    assert again.tree.signature() == signature
    assert _reopen(db_url, studio).signature() == signature
    assert core.rebuild(store).signature() == signature


def test_corrections_survive_building_again(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home, studio_build: Path
) -> None:
    store, tree = built
    answers = _correct_three(store, tree)
    assert store.experience_count() == STUDIO_SAMPLES + 3
    counts, signature = store.counts(), tree.signature()
    users = _user_corrections(store)
    assert users == ({"alice": 2, "bob": 1}, {"alice": 2, "bob": 1})
    build(studio, store, q_path=studio_build)
    assert store.experience_count() == STUDIO_SAMPLES + 3
    assert store.counts() == counts
    assert _user_corrections(store) == users
    loaded = _assert_consistent(db_url, studio)
    assert loaded.signature() == signature
    assert loaded.n_experiences == STUDIO_SAMPLES + 3
    for user, wanted in answers.items():
        assert [loaded.predict_one(c, user) for c in (WORK, EVENING, NIGHT)] == wanted


def test_another_build_replaces_the_samples(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home, studio_build: Path
) -> None:
    """Another seed, mode or Q table: the log keeps the new build's samples and the
    corrections, which are replayed on the new tree."""
    store, tree = built
    answers = _correct_three(store, tree)
    for how, samples in (
        ({"q_path": studio_build, "seed": 1}, STUDIO_SAMPLES),
        ({"q_path": studio_build, "mode": "paper"}, STUDIO_SAMPLES),
        ({}, STUDIO_GROUP_SAMPLES),  # the Q tables learned group by group: fewer samples
        ({"q_path": studio_build}, STUDIO_SAMPLES),
    ):
        result = build(studio, store, **how)
        assert result.samples == samples, how
        assert store.experience_count() == samples + 3, how
        assert result.tree.n_experiences == samples + 3, how
        batches = _sample_batches(store)
        assert sum(b["count"] for b in batches) == samples, how
        assert len({b["build"] for b in batches}) == 1, how
        assert store.counts()["corrections"] == 3
        assert _user_corrections(store) == ({"alice": 2, "bob": 1}, {"alice": 2, "bob": 1})
        loaded = _assert_consistent(db_url, studio)
        assert loaded.signature() == result.tree.signature()
        for user, wanted in answers.items():  # the services corrected, in the new tree's order
            assert [set(loaded.predict_one(c, user)) for c in (WORK, EVENING, NIGHT)] == [
                set(w) for w in wanted
            ], how
    assert _reopen(db_url, studio).signature() == tree.signature()  # the first build's again


def test_a_log_of_older_builds_counts_the_last(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home, studio_build: Path
) -> None:
    """A database whose log kept every build's samples and counted them all (``samples_logged``)
    counts those of the last build, and the next build removes the earlier ones."""
    store, tree = built
    _correct_three(store, tree)
    with store.engine.begin() as conn:
        rows = conn.execute(select(ExperienceRow).where(ExperienceRow.kind == "samples")).mappings().all()
        older = [  # an earlier build's batches, as older databases kept them
            {**r, "payload": json.dumps(json.loads(r["payload"]) | {"build": 0})} for r in rows
        ]
        for row in older:
            del row["id"]
        conn.execute(insert(ExperienceRow), older)
        state = json.loads(conn.execute(select(HomeRow.state)).scalar_one())
        del state["build_samples"]
        state["samples_logged"] = 2 * STUDIO_SAMPLES  # what such a database counted: every build's
        conn.execute(update(HomeRow).values(state=json.dumps(state)))
    assert len(_sample_batches(store)) == 2
    assert store.experience_count() == STUDIO_SAMPLES + 3
    assert core.rebuild(store).signature() == tree.signature()
    build(studio, store, q_path=studio_build)
    assert len(_sample_batches(store)) == 1
    assert store.experience_count() == STUDIO_SAMPLES + 3
    assert _assert_consistent(db_url, studio).signature() == tree.signature()


# -- corrections ----------------------------------------------------------------------------------------
def test_correction_is_per_user_and_persisted(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home
) -> None:
    store, tree = built
    shared = tree.predict_one(WORK)
    assert shared == ["RaiseBlind", "LampOn", "BringTea"]
    experiences = store.experience_count()

    # alice adds the radio
    added, rejected = _correct(store, tree, tree.point(WORK), [*shared, "RadioOn"], "alice")
    assert (added, rejected) == (["RadioOn"], [])
    assert _last_correction(store)["added"] == ["RadioOn"]
    assert _last_correction(store)["rejected"] == []
    assert _last_correction(store)["want"] == [*shared, "RadioOn"]
    assert store.experience_count() == experiences + 1
    assert set(tree.predict_one(WORK, "alice")) == {*shared, "RadioOn"}
    other = _reopen(db_url, studio)
    assert set(other.predict_one(WORK, "alice")) == {*shared, "RadioOn"}
    assert other.predict_one(WORK, "bob") == shared
    assert other.predict_one(WORK) == shared

    # alice rejects the tea
    added, rejected = _correct(store, tree, tree.point(WORK), ["RaiseBlind", "LampOn", "RadioOn"], "alice")
    assert (added, rejected) == ([], ["BringTea"])
    assert _last_correction(store)["added"] == []
    assert _last_correction(store)["rejected"] == ["BringTea"]
    assert store.experience_count() == experiences + 2
    other = _reopen(db_url, studio)
    assert set(other.predict_one(WORK, "alice")) == {"RaiseBlind", "LampOn", "RadioOn"}
    assert other.predict_one(WORK, "bob") == shared

    # bob's own correction does not touch alice's
    added, rejected = _correct(store, tree, tree.point(WORK), ["LampOn"], "bob")
    assert (added, rejected) == ([], ["RaiseBlind", "BringTea"])
    assert _last_correction(store)["rejected"] == ["RaiseBlind", "BringTea"]
    assert store.experience_count() == experiences + 3
    other = _reopen(db_url, studio)
    assert other.predict_one(WORK, "bob") == ["LampOn"]
    assert set(other.predict_one(WORK, "alice")) == {"RaiseBlind", "LampOn", "RadioOn"}
    assert other.predict_one(WORK) == shared
    counts = store.counts()
    assert (counts["corrections"], counts["users"]) == (3, 2)
    assert (other.n_clusters("alice"), other.n_clusters("bob")) == (2, 1)  # their corrections
    assert _user_corrections(store) == ({"alice": 2, "bob": 1}, {"alice": 2, "bob": 1})

    # a correction that changes nothing is still an experience
    added, rejected = _correct(store, tree, tree.point(WORK), ["LampOn"], "bob")
    assert (added, rejected) == ([], [])
    assert store.experience_count() == experiences + 4


def test_bad_correction_leaves_the_store_unchanged(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home
) -> None:
    store, tree = built
    _correct(store, tree, tree.point(WORK), ["LampOn"], "alice")
    counts, experiences = store.counts(), store.experience_count()
    signature = _reopen(db_url, studio).signature()
    with pytest.raises(ContextError, match="NoSuchService"):
        tree.correct_one(tree.point(WORK), ["LampOn", "NoSuchService"], "alice")
    with pytest.raises(ContextError, match="NoSuchService"):
        _correct(store, tree, tree.point(WORK), ["LampOn", "NoSuchService"], "alice")
    with pytest.raises(ContextError, match="NoSuchService"):
        _correct(store, tree, tree.point(WORK), ["NoSuchService"], "carol")  # a new user
    with pytest.raises(NameProblemError, match="the user name is empty"):
        _correct(store, tree, tree.point(WORK), ["LampOn"], "")
    assert store.counts() == counts
    assert store.experience_count() == experiences
    assert _reopen(db_url, studio).signature() == signature
    core.refresh(store, tree)
    assert tree.predict_one(WORK, "alice") == ["LampOn"]
    assert tree.signature() == signature


# -- the wrong database -------------------------------------------------------------------------------------
def test_many_homes_and_a_changed_home_file(
    built: tuple[Store, IHDRTree], db_url: str, paper: Home, studio: Home
) -> None:
    """One database holds many homes by name; a home file of a stored name and other
    content is refused, naming both hashes."""
    other = Store.open(db_url, paper)
    try:
        assert not other.has_tree() and other.counts()["nodes"] == 0
    finally:
        other.close()
    changed = load_home_text(STUDIO_TEXT + "\nrewards: {magnitude: 5}\n", "studio.yaml")
    with pytest.raises(StoreError) as info:
        Store.open(db_url, changed)
    message = str(info.value)
    assert "home 'studio'" in message and studio.content_hash[:12] in message
    assert changed.content_hash[:12] in message
    assert "\n" not in message


@contextmanager
def no_hang(seconds: int) -> Iterator[None]:
    """Fail, rather than wait for ever, where the block is still running after ``seconds``
    (a connection that hangs instead of being refused)."""
    fired = []

    def stop(signum: int, frame: object) -> None:
        fired.append(signum)
        raise TimeoutError(f"still running after {seconds} s")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert not fired, f"still running after {seconds} s"


@pytest.mark.parametrize(
    "url",
    [
        "nosuchdb://x",
        "not a url",
        "postgresql+psycopg://postgres@127.0.0.1:1/x",
        "mysql+pymysql://root@127.0.0.1:1/x",
    ],
)
def test_bad_url_is_a_one_line_store_error(url: str, studio: Home) -> None:
    with no_hang(60), pytest.raises(StoreError) as info:  # refused, not waited on
        Store.open(url, studio)
    message = str(info.value)
    assert message.startswith("database ")
    assert "\n" not in message
    assert "Traceback" not in message


def test_another_applications_database_is_refused_and_left_as_it_was(tmp_path: Path, studio: Home) -> None:
    import sqlite3

    path = tmp_path / "shop.sqlite"
    with sqlite3.connect(path) as conn:
        conn.executescript("CREATE TABLE orders (id INTEGER); CREATE TABLE invoices (id INTEGER);")
        conn.execute("INSERT INTO orders VALUES (7)")
    with pytest.raises(StoreError) as info:
        Store.open(f"sqlite:///{path}", studio)
    assert str(info.value) == (
        f"database sqlite:///{path}: holds another application's tables (invoices, orders), "
        "not homecog's; give homecog a database of its own"
    )
    with sqlite3.connect(path) as conn:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        assert tables == {"orders", "invoices"}
        assert conn.execute("SELECT id FROM orders").fetchall() == [(7,)]


def test_server_test_databases_are_dropped() -> None:
    for kind in ("postgresql", "mariadb"):
        try:
            with fresh_database(kind) as url:
                name = url.rsplit("/", 1)[1]
                assert name in databases_left(kind)
            assert name not in databases_left(kind)
        except pytest.skip.Exception:
            continue


# -- concurrency ---------------------------------------------------------------------------------------------
PROCESSES = 5
N = 15
USERS = ["alice", "alice", "bob", "bob", "carol"]


@pytest.mark.slow
def test_concurrent_corrections_lose_nothing(
    built: tuple[Store, IHDRTree], db_url: str, studio: Home
) -> None:
    store, _ = built
    before = store.experience_count()
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(PROCESSES) as pool:
        results = pool.starmap_async(
            correction_worker, [(db_url, user, N, 100 + i) for i, user in enumerate(USERS)], chunksize=1
        ).get(timeout=150)
    assert [len(r) for r in results] == [N] * PROCESSES
    changed = sum(1 for r in results for added, rejected in r if added or rejected)
    assert changed >= PROCESSES * N // 2  # the corrections really changed the layers

    assert store.counts()["corrections"] == PROCESSES * N
    assert store.experience_count() == before + PROCESSES * N
    users, logged = _user_corrections(store)
    expected = {u: USERS.count(u) * N for u in USERS}
    assert users == expected
    assert logged == expected
    loaded = _assert_consistent(db_url, studio)
    assert all(loaded.n_clusters(u) > 0 for u in expected)


# -- a client killed in the middle ---------------------------------------------------------------------
@pytest.mark.slow
def test_sigkill_leaves_a_consistent_store(built: tuple[Store, IHDRTree], db_url: str, studio: Home) -> None:
    store, _ = built
    code = (
        "import sys; sys.path.insert(0, sys.argv[1]); import servers; "
        "servers.correct_forever(sys.argv[2], 'alice', 7)"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code, str(Path(__file__).parent), db_url],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    watchdog = threading.Timer(120, proc.kill)  # a client that hangs must not hang the test
    watchdog.start()
    try:
        committed = 0
        deadline = time.monotonic() + 60
        while committed < 5:
            line = proc.stdout.readline()  # type: ignore[union-attr]
            if not line:
                pytest.fail(f"the client died: {proc.stderr.read()}")  # type: ignore[union-attr]
            assert time.monotonic() < deadline, "the client commits too slowly"
            committed = int(line.split()[1])
        time.sleep(random.Random(1).uniform(0, 0.05))  # somewhere inside the next correction
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()  # type: ignore[union-attr]
        proc.stderr.close()  # type: ignore[union-attr]
    assert proc.returncode == -signal.SIGKILL

    loaded = _assert_consistent(db_url, studio)
    users, _ = _user_corrections(store)
    assert users["alice"] >= committed >= 5
    assert store.counts()["corrections"] == users["alice"]

    # the store still takes corrections, from a new client
    after = Store.open(db_url, studio)
    try:
        tree = after.load_tree()
        assert tree.signature() == loaded.signature()
        want = varied_want(random.Random(3), tree.predict_one(WORK, "alice"), list(studio.service_names))
        _correct(after, tree, tree.point(WORK), want, "alice")
        # counted at once (whether it flips an answer depends on her earlier evidence)
        assert tree.user_examples("alice")[-1].want == {studio.service_index(s) for s in want}
        assert after.load_tree().signature() == tree.signature()
        assert _user_corrections(after)[0]["alice"] == users["alice"] + 1
    finally:
        after.close()
    assert _assert_consistent(db_url, studio).predict_one(WORK, "alice") == tree.predict_one(WORK, "alice")


def _correct(
    store: Store, tree: IHDRTree, point: Any, want: list[str], user: str
) -> tuple[list[str], list[str]]:
    """A whole-set correction through the knowledge core: (added, rejected)."""
    outcome = core.correct(store, tree, Correction.whole(user, point, want))
    return list(outcome.added), list(outcome.rejected)
