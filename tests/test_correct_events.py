"""``homecog correct --events FILE``: an event file learned as corrections, in batches of
transactions; a file that is refused teaches nothing."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from knowledge_fixtures import sample_count

from homecog.cli.main import main
from homecog.errors import ContextError
from homecog.home import load_home
from homecog.home.codec import Space
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.event_file import read_corrections
from homecog.knowledge.store import Store

HOMES = Path(__file__).parent / "homes"
STUDIO = str(HOMES / "studio.yaml")
HEADER = "timestamp,time,light,activity,blind,desk_lamp,radio,services,user"
ROWS = [
    "2026-03-01T08:00,08:00,150,work,off,off,on,LampOn;RaiseBlind;RadioOff,kim",
    "2026-03-01T09:00,09:00,150,work,off,off,on,LampOn;RaiseBlind;RadioOff,",
    "2026-03-01T22:00,22:00,20,sleep,on,on,on,LowerBlind;LampOff;RadioOff,kim",
    "2026-03-02T07:00,07:00,300,relax,on,off,off,RadioOn,",
    "2026-03-02T20:30,20:30,5,relax,off,off,off,,kim",
]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A studio database built once (copied for every test)."""
    tmp = tmp_path_factory.mktemp("events")
    q = tmp / "q.npz"
    assert main(["train", "--home", STUDIO, "--episodes", "30000", "--out", str(q), "--json"]) == 0
    assert main(["build", "--home", STUDIO, "--q", str(q), "--db", f"sqlite:///{tmp / 'db.sqlite'}"]) == 0
    return tmp / "db.sqlite"


@pytest.fixture
def db(built, tmp_path):
    shutil.copy(built, tmp_path / "db.sqlite")
    return f"sqlite:///{tmp_path / 'db.sqlite'}"


def write(path: Path, rows: list[str], header: str = HEADER) -> Path:
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


def snapshot(db: str) -> tuple:
    store = Store.open(db, load_home(STUDIO))
    try:
        return store.counts(), store.load_tree().signature()
    finally:
        store.close()


def test_events_are_learned_in_batches(db, tmp_path, capsys):
    events = write(tmp_path / "e.csv", ROWS)
    args = ["correct", "--home", STUDIO, "--db", db, "--events", str(events), "--user", "ann", "--batch", "2"]
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) >= {"events", "added", "rejected", "experiences", "seconds"}
    assert data["events"] == 5 and data["batches"] == 3
    assert data["users"] == {"kim": 3, "ann": 2}  # the user column, else --user
    assert data["experiences"] == sample_count("studio") + 5
    assert data["added"] >= 1 and data["changed"] >= 1
    ctx = "time=08:00,light=150,activity=work,blind=off,desk_lamp=off,radio=on"
    assert main(["cognize", "--home", STUDIO, "--db", db, "--context", ctx, "--user", "kim", "--json"]) == 0
    assert sorted(json.loads(capsys.readouterr().out)["services"]) == ["LampOn", "RadioOff", "RaiseBlind"]


def test_batches_store_what_single_corrections_store(built, db, tmp_path, capsys):
    """The same corrections one transaction each give the same tree and log."""
    events = write(tmp_path / "e.csv", ROWS)
    assert main(["correct", "--home", STUDIO, "--db", db, "--events", str(events), "--batch", "3"]) == 0
    out = capsys.readouterr().out
    assert "learned 5 events of e.csv as corrections in 2 transaction(s)" in out
    assert "kim: 3 corrections" in out
    shutil.copy(built, tmp_path / "one.sqlite")
    one = f"sqlite:///{tmp_path / 'one.sqlite'}"
    home = load_home(STUDIO)
    store = Store.open(one, home)
    tree = store.load_tree()
    for c in read_corrections(events, home, "default"):
        core.correct(store, tree, c)
    store.close()
    assert snapshot(one) == snapshot(db)
    store = Store.open(db, home)
    try:
        assert core.rebuild(store).signature() == store.load_tree().signature()
    finally:
        store.close()


BAD = [
    pytest.param(HEADER.replace(",radio", ""), ROWS, "line 1: missing column(s) radio", id="missing-column"),
    pytest.param(HEADER.replace(",services", ""), [], "line 1: missing column(s) services", id="no-services"),
    pytest.param(
        HEADER + ",mood", [r + ",calm" for r in ROWS], "line 1: unknown column(s) mood", id="unknown-column"
    ),
    pytest.param(
        HEADER,
        [*ROWS, "2026-03-03T08:00,08:00,150,work,off,off,on,LampOn;Dance,kim"],
        "line 7, column services: unknown service 'Dance'",
        id="unknown-service",
    ),
    pytest.param(
        HEADER,
        [*ROWS[:3], "2026-03-03T08:00,08:00,150,dance,off,off,on,LampOn,kim"],
        "line 5, column activity: ",
        id="unknown-value",
    ),
    pytest.param(HEADER, [*ROWS, "2026-03-03T08:00,08:00,150"], "line 7: expected 9 fields", id="short-row"),
    pytest.param(
        HEADER, [*ROWS, "yesterday" + ROWS[0][16:]], "line 7, column timestamp: 'yesterday'", id="bad-time"
    ),
]


@pytest.mark.parametrize(("header", "rows", "message"), BAD)
def test_a_refused_file_teaches_nothing(db, tmp_path, capsys, header, rows, message):
    events = write(tmp_path / "bad.csv", rows, header)
    before = snapshot(db)
    code = main(["correct", "--home", STUDIO, "--db", db, "--events", str(events)])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"homecog: error: {events}: ")
    assert message in err
    assert snapshot(db) == before


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--events", "e.csv", "--want", "LampOn"],
            "--events learns a file: give it without a context, --want, --add or --reject",
        ),
        (
            ["--want", "LampOn"],
            "give a context (--context, or --at, --where, --doing, NAME=VALUE) and --want (the whole set) "
            "or --add/--reject, or --events FILE",
        ),
        (["--events", "missing.csv"], "--events missing.csv: no such file"),
    ],
)
def test_usage(db, tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    write(tmp_path / "e.csv", ROWS)
    assert main(["correct", "--home", STUDIO, "--db", db, *args]) == 2
    assert message in capsys.readouterr().err


def test_a_failed_batch_stores_nothing(db):
    home = load_home(STUDIO)
    point = Space(home).point(
        {
            "time": "08:00",
            "light": "150",
            "activity": "work",
            "blind": "off",
            "desk_lamp": "off",
            "radio": "on",
        }
    )
    before = snapshot(db)
    store = Store.open(db, home)
    tree = store.load_tree()
    answer = tree.predict_one(point, "kim")
    batch = [Correction.whole("kim", point, ["LampOn"]), Correction.whole("kim", point, ["NoSuchService"])]
    with pytest.raises(ContextError, match="NoSuchService"):  # the second fails after the first's row
        core.correct_many(store, tree, batch)
    assert (tree.n_clusters("kim"), tree.predict_one(point, "kim")) == (0, answer)  # memory as stored
    assert snapshot(db) == before
    core.correct_many(store, tree, batch[:1])  # and the tree goes on from there
    assert (tree.n_clusters("kim"), tree.predict_one(point, "kim")) == (1, ["LampOn"])
    store.close()


def test_events_learned_keep_the_recent_past_of_the_stream(db, tmp_path):
    """Every row carries what came before it in the file, whoever's it is, through the store."""
    studio = load_home(STUDIO)
    rows = read_corrections(write(tmp_path / "e.csv", ROWS), studio, "ann")
    first, second, fourth = rows[0].point.recent, rows[1].point.recent, rows[3].point.recent
    assert first.previous is None and first.value("weekday") == "sun"  # 2026-03-01
    assert second.previous == frozenset({"LampOn", "RaiseBlind", "RadioOff"})
    assert second.value("minutes since previous") == "1-4h" and second.value("minutes in activity") == "1-4h"
    assert fourth.value("previous activity") == "sleep" and fourth.value("weekday") == "mon"
    assert main(["correct", "--home", STUDIO, "--db", db, "--events", str(tmp_path / "e.csv"), "--json"]) == 0
    store = Store.open(db, studio)
    try:
        stored = core.rebuild(store).user_examples("kim")
    finally:
        store.close()
    assert [e.recent for e in stored] == [rows[i].point.recent for i in (0, 2, 4)]
