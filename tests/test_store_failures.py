"""A store whose memory is what the database holds, whatever fails: a correction the
database refuses leaves the tree as it was, the user's learning included, and cognition goes on
from it; a batch that fails leaves exactly the batches stored before it. On SQLite, PostgreSQL
and MariaDB, the write refused by a trigger as a read-only database refuses it."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import text

from homecog.context.manual import ManualSource
from homecog.errors import StoreError
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.event_file import learn_corrections
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app

WORK = {"time": "10:00", "light": 50, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "off"}
REFUSED = "the log is read-only"


def refuse_writes_past(store: Store, rows: int) -> None:
    """From now on the database refuses a new row of the log once it holds ``rows``."""
    dialect = store.engine.dialect.name
    with store.engine.begin() as conn:
        if dialect == "sqlite":
            conn.execute(
                text(
                    "CREATE TRIGGER refuse BEFORE INSERT ON experiences "
                    f"WHEN (SELECT count(*) FROM experiences) >= {rows} "
                    f"BEGIN SELECT RAISE(ABORT, '{REFUSED}'); END"
                )
            )
        elif dialect == "postgresql":
            conn.execute(
                text(
                    "CREATE FUNCTION refuse() RETURNS trigger AS $$ BEGIN "
                    f"IF (SELECT count(*) FROM experiences) >= {rows} THEN RAISE EXCEPTION '{REFUSED}'; "
                    "END IF; RETURN NEW; END $$ LANGUAGE plpgsql"
                )
            )
            each_row = "BEFORE INSERT ON experiences FOR EACH ROW"
            conn.execute(text(f"CREATE TRIGGER refuse {each_row} EXECUTE FUNCTION refuse()"))
        else:
            conn.execute(
                text(
                    "CREATE TRIGGER refuse BEFORE INSERT ON experiences FOR EACH ROW BEGIN "
                    f"IF (SELECT COUNT(*) FROM experiences) >= {rows} THEN "
                    f"SIGNAL SQLSTATE '45000' SET MESSAGE_TEXT = '{REFUSED}'; END IF; END"
                )
            )


@pytest.fixture
def stored(db_url, studio, studio_build):
    store = Store.open(db_url, studio)
    build(studio, store, q_path=studio_build)
    yield store
    store.close()


def test_a_refused_correction_leaves_the_user_s_learning_in_memory(stored, studio):
    runtime = Runtime(home=studio, store=stored, tree=stored.load_tree(), source=ManualSource(studio))
    client = TestClient(create_app(runtime))
    relax = {**WORK, "activity": "relax"}
    for context, want in ((WORK, ["RadioOn"]), (relax, ["LampOn"])):
        assert (
            client.post(
                "/api/corrections", json={"context": context, "want": want, "user": "kim"}
            ).status_code
            == 200
        )
    before = [client.post("/api/cognize", json={"context": c, "user": "kim"}).json() for c in (WORK, relax)]
    assert [b["services"] for b in before] != [
        client.post("/api/cognize", json={"context": c}).json()["services"] for c in (WORK, relax)
    ]  # kim's learning answers otherwise than the shared knowledge
    examples, experiences = list(runtime.tree.user_examples("kim")), runtime.tree.n_experiences
    refuse_writes_past(stored, 0)

    r = client.post("/api/corrections", json={"context": WORK, "want": ["BringTea"], "user": "kim"})
    assert r.status_code == 503 and REFUSED in r.json()["detail"]
    assert runtime.tree.user_examples("kim") == examples and runtime.tree.n_experiences == experiences
    after = [client.post("/api/cognize", json={"context": c, "user": "kim"}).json() for c in (WORK, relax)]
    assert after == before  # kim's answers, not the shared ones: what the database holds
    again = stored.load_tree()
    assert again.user_examples("kim") == examples
    with pytest.raises(StoreError):
        core.correct(
            stored, runtime.tree, Correction.whole("ann", runtime.space.point(relax), [])
        )  # a user without a layer yet
    assert runtime.tree.user_examples("ann") == [] and "ann" not in runtime.tree.users


def test_a_failed_batch_leaves_exactly_the_batches_stored_before(stored, studio):
    tree = stored.load_tree()
    space, start = tree.space, tree.n_experiences
    contexts = [{**WORK, "light": light} for light in range(0, 300, 12)]  # 25 corrections
    rows = [
        Correction.whole(("kim", "ann")[i % 2], space.point(c), ["RadioOn"] if i % 2 else [])
        for i, c in enumerate(contexts)
    ]
    with stored.engine.connect() as conn:
        logged = conn.execute(text("SELECT count(*) FROM experiences")).scalar_one()
    refuse_writes_past(stored, logged + 20)  # the third batch of ten fails
    with pytest.raises(StoreError, match=REFUSED):
        learn_corrections(stored, tree, rows, batch=10)
    held = stored.load_tree()
    assert [len(tree.user_examples(u)) for u in ("kim", "ann")] == [10, 10]
    for user in ("kim", "ann"):
        assert tree.user_examples(user) == held.user_examples(user)
    assert tree.n_experiences == start + 20  # the two batches stored, not the third
    assert [tree.predict_one(space.point(c), "kim") for c in contexts] == [
        held.predict_one(space.point(c), "kim") for c in contexts
    ]
