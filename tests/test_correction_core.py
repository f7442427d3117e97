"""A correction as one value from its edge to the knowledge core: its round trip through the
log, what it says it stored, the core's one unit of work, and bad input at every edge (an
unknown service or user, nothing stored)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from homecog.cli.main import main
from homecog.context.manual import ManualSource
from homecog.errors import ContextError, NameProblemError
from homecog.home import load_home, load_home_text
from homecog.home.codec import Point
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app

HOMES = Path(__file__).parent / "homes"
STUDIO = (HOMES / "studio.yaml").read_text()
#: the studio with its household named: kim (a person id p-kim) and the default user ann
NAMED = STUDIO + "household: {users: {p-kim: kim}, default_user: ann}\n"
WORK = {"time": "08:00", "light": 150, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "on"}
CTX = "time=08:00,light=150,activity=work,blind=off,desk_lamp=off,radio=on"
AT = Point(codes=(0, 1, 0), readings=(8.0, 150.0, None))


@pytest.mark.parametrize(
    ("c", "says"),
    [
        (Correction.whole("ann", AT, ["LampOn", "RadioOff"]), "wants exactly LampOn, RadioOff"),
        (Correction.whole("ann", AT, []), "wants no service there"),
        (Correction.change("ann", AT, add=["LampOn"]), "wants LampOn"),
        (Correction.change("ann", AT, reject=["BringTea", "LampOn"]), "does not want BringTea, LampOn"),
        (
            Correction.change("ann", AT, add=["RadioOn"], reject=["BringTea"]),
            "wants RadioOn; does not want BringTea",
        ),
        (Correction.observed("ann", AT, "LampOn", weight=5, device="desk_lamp", state="on"), "wants LampOn"),
        (Correction.undo("ann", AT, "RaiseBlind", weight=5, action=3, by="hmi"), "does not want RaiseBlind"),
        (Correction.lived("ann", AT, ["LampOn", "RadioOn"]), "does not want LampOn, RadioOn"),
    ],
)
def test_a_correction_says_what_it_is_and_reads_back_from_its_row_unchanged(c, says):
    assert c.says() == says
    row = json.loads(json.dumps(c.row({"time": "08:00"}, ["X"], [])))
    back = Correction.from_row("ann", row)
    assert back == c and back.note == c.note
    assert (row["added"], row["rejected"]) == (["X"], [])
    plain = c.kind == "explicit" and c.concerns is None
    assert ("kind" in row) is not plain  # a plain whole set reads as the oldest rows do


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: Correction("ann", AT, ("A",), ("B",)),
            "a correction of some services wants A, which it does not concern",
        ),
        (lambda: Correction("ann", AT, (), ()), "a correction of some services names no service"),
        (
            lambda: Correction.change("ann", AT, add=["A"], reject=["A"]),
            "a correction both adds and rejects A",
        ),
        (lambda: Correction("ann", AT, ("A",), weight=0), "weight: 0; expected a whole number from 1 to 100"),
        (lambda: Correction("ann", AT, ("A",), weight=True), "weight: True; expected a whole number"),
        (lambda: Correction("ann", AT, ("A",), kind="told"), "kind: 'told'; expected one of explicit"),
        (lambda: Correction("ann", AT, ("A", "A")), "a correction wants A twice"),
    ],
)
def test_a_correction_that_is_not_one_is_refused_where_it_is_made(make, message):
    with pytest.raises(ContextError) as e:
        make()
    assert str(e.value).startswith(message)


def test_a_bad_user_name_is_refused_where_the_correction_is_made():
    with pytest.raises(NameProblemError, match="the user name is empty"):
        Correction.whole("", AT, [])


@pytest.fixture(scope="module")
def stored(tmp_path_factory, studio_build):
    """The named studio built into SQLite once: (home, url)."""
    home = load_home_text(NAMED, "studio.yaml")
    url = f"sqlite:///{tmp_path_factory.mktemp('core') / 'k.sqlite'}"
    store = Store.open(url, home)
    build(home, store, q_path=studio_build)
    store.close()
    return home, url


def _copy(stored, tmp_path) -> str:
    _, url = stored
    copy = tmp_path / "k.sqlite"
    copy.write_bytes(Path(url.removeprefix("sqlite:///")).read_bytes())
    return f"sqlite:///{copy}"


def _state(url, home):
    store = Store.open(url, home)
    try:
        return store.counts(), store.experience_count(), store.load_tree().signature()
    finally:
        store.close()


def test_the_core_commits_then_learns_and_a_refused_correction_leaves_both_as_they_were(stored, tmp_path):
    home, _ = stored
    url = _copy(stored, tmp_path)
    store = Store.open(url, home)
    tree = store.load_tree()
    point = tree.space.point(WORK)
    first = core.correct(store, tree, Correction.change("kim", point, reject=["RadioOff"]))
    assert (first.number, first.added, first.rejected) == (1, (), ())  # not proposed: stored all the same
    assert store.read_user("kim")[1] == tree.user_examples("kim")
    before = _state(url, home)
    for bad in (["LampOn", "Fly"], ["Fly"]):
        with pytest.raises(ContextError, match="unknown service 'Fly'"):
            core.correct(store, tree, Correction.whole("kim", point, bad))
    assert _state(url, home) == before and tree.n_clusters("kim") == 1
    second = core.correct(store, tree, Correction.whole("kim", point, tree.predict_one(point, "kim")))
    assert (second.number, second.added, second.rejected) == (2, (), ())
    assert core.rebuild(store).signature() == store.load_tree().signature() == tree.signature()
    store.close()


def test_unknown_users_and_services_are_one_line_and_store_nothing(stored, tmp_path, capsys):
    home, _ = stored
    url = _copy(stored, tmp_path)
    before = _state(url, home)
    path = tmp_path / "named.yaml"
    path.write_text(NAMED)
    for args, message in [
        (["--user", "zed", "--want", "LampOn"], "--user zed: not one of the household (ann, kim)"),
        (["--user", "kim", "--want", "LampOn,Fly"], "unknown service 'Fly'"),
        (["--user", "kim", "--reject", "Fly"], "unknown service 'Fly'"),
    ]:
        code = main(["correct", "--home", str(path), "--db", url, "--context", CTX, *args])
        out, err = capsys.readouterr()
        assert (code, out) == (2, "")
        assert err.count("\n") == 1 and err.startswith(f"homecog: error: {message}"), err
    assert _state(url, home) == before


def test_correct_always_says_what_it_stored(stored, tmp_path, capsys):
    url = _copy(stored, tmp_path)
    path = tmp_path / "named.yaml"
    path.write_text(NAMED)

    def correct(*args: str) -> str:
        assert main(["correct", "--home", str(path), "--db", url, "--context", CTX, *args]) == 0
        return capsys.readouterr().out.replace("\n", " ")

    said = correct("--reject", "RadioOff")  # the default user: ann; RadioOff was not proposed
    assert said.startswith(
        "stored ann's correction #1: does not want RadioOff; the robot already answered so"
    )
    said = correct("--user", "kim", "--add", "RadioOff")
    assert said.startswith("stored kim's correction #1: wants RadioOff; the robot now adds RadioOff")
    assert "no longer proposes" not in said
    assert (
        main(["correct", "--home", str(path), "--db", url, "--context", CTX, "--reject", "LampOn", "--json"])
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert data["stored"] == {"kind": "explicit", "want": [], "concerns": ["LampOn"]}
    assert (data["user"], data["number"], data["says"]) == ("ann", 2, "does not want LampOn")
    assert data["rejected"] == ["LampOn"]


def test_the_api_refuses_an_unknown_user_or_service_with_422_and_stores_nothing(stored, tmp_path):
    home, _ = stored
    url = _copy(stored, tmp_path)
    store = Store.open(url, home)
    source = ManualSource(home)
    source.set_context({k: str(v) for k, v in WORK.items()})
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    client = TestClient(create_app(runtime))
    before = store.counts()
    for body, message in [
        ({"want": ["LampOn"], "user": "zed"}, "user 'zed': not one of the household (ann, kim)"),
        ({"want": ["Fly"], "user": "kim"}, "Fly"),
        ({"change": {"Fly": "reject"}, "user": "kim"}, "Fly"),
    ]:
        r = client.post("/api/corrections", json={"context": WORK, **body})
        assert r.status_code == 422 and message in r.json()["detail"], r.json()
    assert store.counts() == before and runtime.tree.users == []
    r = client.post(
        "/api/corrections", json={"context": WORK, "change": {"RadioOff": "reject"}, "user": "kim"}
    )
    assert r.status_code == 200
    assert (r.json()["number"], r.json()["says"], r.json()["rejected"]) == (1, "does not want RadioOff", [])
    store.close()


def test_the_store_keeps_no_learner_and_the_tree_no_sql():
    """The store persists rows and reads them; the tree learns; only the core meets both."""
    root = Path(__file__).parent.parent / "homecog" / "knowledge"
    for name in ("store.py", "store_log.py"):
        text = (root / name).read_text()
        for call in (".apply(", ".correct_one(", ".learn_one(", ".learn_many(", "set_user_examples("):
            assert call not in text, f"{name} calls {call}"
    for name in ("ihdr.py", "tree.py", "search.py", "lookup.py", "update.py", "corrections.py"):
        assert "sqlalchemy" not in (root / name).read_text()
    assert load_home("paper")  # the package imports whole


def test_a_cognition_never_waits_on_a_correction_s_commit(stored, tmp_path, monkeypatch):
    """The robot's lock is held while the tree is read or changed, not while the database
    writes: a correction stuck in its transaction holds up no cognition, and lands whole."""
    import threading

    home, _ = stored
    store = Store.open(_copy(stored, tmp_path), home)
    source = ManualSource(home)
    source.set_context({k: str(v) for k, v in WORK.items()})
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    entered, release = threading.Event(), threading.Event()
    real = store.log_correction

    def slow(conn, user, payload):
        entered.set()
        assert release.wait(10)
        return real(conn, user, payload)

    monkeypatch.setattr(store, "log_correction", slow)
    point = runtime.space.point({k: str(v) for k, v in WORK.items()})
    worker = threading.Thread(
        target=runtime.correct, args=(Correction.change("kim", point, add=["RadioOff"]),)
    )
    worker.start()
    assert entered.wait(10)
    assert not runtime.lock.locked()
    assert "RadioOff" not in runtime.cognize(WORK, "kim")["services"]  # not committed: not learned
    release.set()
    worker.join(10)
    assert "RadioOff" in runtime.cognize(WORK, "kim")["services"] and store.read_user("kim")[0] == 1
    store.close()


def test_two_robots_on_one_database_agree_within_their_freshness(stored, tmp_path):
    """Two servers (``homecog up`` twice) on one database: a correction through one is what the
    other answers once its next look at the database comes (at most ``fresh`` seconds)."""
    import time

    home, _ = stored
    url = _copy(stored, tmp_path)
    robots = []
    for _ in range(2):
        store = Store.open(url, home)
        source = ManualSource(home)
        source.set_context({k: str(v) for k, v in WORK.items()})
        robots.append(Runtime(home=home, store=store, tree=store.load_tree(), source=source, fresh=0.05))
    one, other = robots
    assert "RadioOff" not in other.cognize(WORK, "kim")["services"]
    one.correct(
        Correction.change("kim", one.space.point({k: str(v) for k, v in WORK.items()}), add=["RadioOff"])
    )
    time.sleep(0.06)
    assert "RadioOff" in other.cognize(WORK, "kim")["services"]
    lonely = Runtime(home=home, store=other.store, tree=other.store.load_tree(), source=other.source)
    one.correct(
        Correction.change("kim", one.space.point({k: str(v) for k, v in WORK.items()}), reject=["RadioOff"])
    )
    time.sleep(0.06)
    assert "RadioOff" not in other.cognize(WORK, "kim")["services"]
    assert "RadioOff" in lonely.cognize(WORK, "kim")["services"]  # fresh None: it alone writes
    for robot in robots:
        robot.store.close()


def test_another_process_s_corrections_are_learned_on_top_not_from_the_start(stored, tmp_path):
    """A tree that held a user's first corrections takes another process's later ones by
    learning those alone (the learners it made stay), and answers as a tree loaded afresh."""
    home, _ = stored
    url = _copy(stored, tmp_path)
    here, there = Store.open(url, home), Store.open(url, home)
    mine, theirs = here.load_tree(), there.load_tree()
    contexts = [
        {**WORK, "light": light, "activity": a} for light in (20, 150, 400) for a in ("work", "relax")
    ]
    points = [mine.space.point({k: str(v) for k, v in c.items()}) for c in contexts]
    for p in points[:3]:
        core.correct(here, mine, Correction.whole("kim", p, ["RadioOff"]))
    mine.predict_one(points[0], "kim")  # the learners are made
    made = mine.layers.learners("kim")
    theirs = core.refresh(there, theirs)
    for p in points[3:]:
        core.correct(there, theirs, Correction.change("kim", p, add=["LampOn"]))
    assert core.refresh(here, mine) is mine and mine.n_clusters("kim") == 6
    assert mine.layers.learners("kim") is made  # not made again from the start
    fresh = here.load_tree()
    assert mine.signature() == fresh.signature()
    assert [mine.predict_one(p, "kim") for p in points] == [fresh.predict_one(p, "kim") for p in points]
    here.close()
    there.close()


def test_corrections_and_cognitions_looking_at_the_database_never_deadlock(stored, tmp_path):
    """SQLite locks its readers too: a cognition that looks at the database (freshness) while a
    correction holds the database and waits for the tree must not hold the tree meanwhile (the
    bench's mixed clients on homecog serve once stopped it for good); and what another server
    corrected meanwhile is learned on top."""
    import threading

    home, _ = stored
    store = Store.open(_copy(stored, tmp_path), home)
    source = ManualSource(home)
    source.set_context({k: str(v) for k, v in WORK.items()})
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=source, fresh=0.0)
    other = Store.open(store.url, home)  # a second server's corrections, for refresh to read
    theirs = other.load_tree()
    lights = [str(x) for x in range(0, 400, 20)]

    def correct() -> None:
        for i, light in enumerate(lights):
            point = runtime.space.point({**{k: str(v) for k, v in WORK.items()}, "light": light})
            runtime.correct(
                Correction.change("kim", point, add=["RadioOff"] if i % 2 else [], reject=["BringTea"])
            )
            core.correct(other, theirs, Correction.change("ann", point, add=["LampOn"]))

    def cognize() -> None:
        for light in lights * 3:
            runtime.cognize({**WORK, "light": int(light)}, "ann")

    workers = [threading.Thread(target=correct), threading.Thread(target=cognize)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(20)
    assert not any(w.is_alive() for w in workers), "deadlocked"
    runtime.cognize(WORK, "ann")  # the other's last corrections too
    assert runtime.tree.n_clusters("kim") == len(lights)
    assert runtime.tree.n_clusters("ann") == len(lights)  # the other's, learned on top
    other.close()
    store.close()


def _kim_corrected(stored, tmp_path, wants: list[list[str]]):
    """A copy of the studio's database where kim made these whole corrections at WORK: its
    url, the store, the tree and the point."""
    home, _ = stored
    url = _copy(stored, tmp_path)
    store = Store.open(url, home)
    tree = store.load_tree()
    point = tree.space.point({k: str(v) for k, v in WORK.items()})
    for want in wants:
        core.correct(store, tree, Correction.whole("kim", point, want))
    return url, store, tree, point


def test_a_user_s_layer_is_learned_off_the_robot_s_lock_and_other_users_never_wait(stored, tmp_path):
    """After a restart a user's first answer learns their layer from every correction: under
    that user's lock alone, so that while it learns the robot's lock is free and another
    user's cognition is answered; the user's own waits, then answers as before the restart."""
    import threading

    home, _ = stored
    url, store, tree, point = _kim_corrected(
        stored, tmp_path, [["RadioOff"], ["RadioOff", "LampOn"], ["RadioOff"]]
    )
    before = tree.predict_one(point, "kim")
    store.close()
    store = Store.open(url, home)  # the restart: kim's corrections read, her layer not learned
    source = ManualSource(home)
    source.set_context({k: str(v) for k, v in WORK.items()})
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    assert not runtime.tree.ready("kim") and runtime.tree.ready("ann")
    answers: dict[str, list[str]] = {}

    def ask(user: str) -> None:
        answers[user] = runtime.cognize(WORK, user)["services"]

    with runtime.tree.user_lock("kim"):  # kim's layer being learned
        kim = threading.Thread(target=ask, args=("kim",))
        kim.start()
        kim.join(0.3)
        assert kim.is_alive() and not runtime.lock.locked()  # she waits, the robot's lock free
        ann = threading.Thread(target=ask, args=("ann",))
        ann.start()
        ann.join(10)
        assert not ann.is_alive() and "ann" in answers  # another user is answered meanwhile
    kim.join(10)
    assert runtime.tree.ready("kim") and answers["kim"] == before
    store.close()


def _learned_again(tree) -> list[int]:
    """The numbers of the corrections a tree's layers learn from now on (watched, not changed)."""
    learned: list[int] = []
    real = tree.layers._learn
    tree.layers._learn = lambda user, example, ident: (learned.append(ident), real(user, example, ident))
    return learned


def test_a_user_s_layer_is_kept_and_a_restart_learns_only_the_corrections_after_it(stored, tmp_path, caplog):
    """What a user's layer learned is kept on disk: after a restart it starts from there and
    learns the corrections made since; it answers as a layer learned from the first would.
    Another build's snapshot, or a damaged one, is not used."""
    home, _ = stored
    url, store, tree, point = _kim_corrected(
        stored, tmp_path, [["RadioOff"], ["RadioOff", "LampOn"], ["LampOn"]]
    )
    tree.layers.keep("kim")
    (kept,) = tree.layers.snapshots.folder.iterdir()
    assert kept.stat().st_mode & 0o777 == 0o600
    core.correct(store, tree, Correction.change("kim", point, reject=["LampOn"]))
    expected = tree.predict_one(point, "kim")
    store.close()

    store = Store.open(url, home)  # a restart
    tree = store.load_tree()
    learned = _learned_again(tree)
    assert tree.predict_one(point, "kim") == expected and learned == [4]  # the 4th alone

    without = store.load_tree()
    without.layers.snapshots = None
    assert without.predict_one(point, "kim") == expected  # as learned from the first

    kept.write_bytes(b"not a snapshot")
    tree = store.load_tree()
    learned = _learned_again(tree)
    assert tree.predict_one(point, "kim") == expected and learned == [1, 2, 3, 4]
    assert "is not used" in caplog.text
    store.close()
