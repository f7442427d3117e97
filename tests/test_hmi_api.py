"""The API the household's page uses: the home's default user and rooms, a yes or no per
proposal (only for what is pending), and the household's switches per day."""

from __future__ import annotations

from datetime import date
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from webserver import LAYOUT

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.history import correction_history, switches_per_day
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
WORK = {"time": "10:00", "light": 50, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "off"}
# the studio of a household of two, kim first; its radio in no room of the file, at a place of
# its name in the bath
HOUSEHOLD = """
household:
  default_user: kim
  users: {p-kim: kim, p-lee: lee}
"""


def studio_text() -> str:
    text = STUDIO.read_text().replace("radio: {room: studio}", "radio: {}")
    return text + HOUSEHOLD + LAYOUT.replace("kettle: [5, 3]}", "kettle: [5, 3], radio: [5, 1]}")


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    home = load_home_text(studio_text(), "studio.yaml")
    store = Store.open(f"sqlite:///{tmp_path_factory.mktemp('hmi') / 'k.sqlite'}", home)
    build(home, store)
    yield home, store
    store.close()


@pytest.fixture
def runtime(built):
    home, store = built
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=ManualSource(home))
    runtime.set_context(WORK)
    return runtime


@pytest.fixture
def client(runtime):
    return TestClient(create_app(runtime))


def test_the_home_says_its_default_user_its_users_and_every_devices_room(client):
    home = client.get("/api/home").json()
    assert home["household"] == {"default_user": "kim", "users": ["kim", "lee"]}
    rooms = {d["name"]: d["room"] for d in home["devices"]}
    assert rooms == {"blind": "studio", "desk_lamp": "studio", "radio": "bath"}  # the radio: its place
    assert {f["name"]: f["unit"] for f in home["features"]} == {"time": None, "light": "lx", "activity": None}


def test_a_body_that_names_no_user_speaks_for_the_homes_default_user(client, runtime):
    assert client.post("/api/cognize", json={"context": WORK}).json()["services"]
    r = client.post("/api/corrections", json={"context": WORK, "change": {"RadioOn": "add"}})
    assert r.status_code == 200 and r.json()["user"] == "kim"  # not "default", whom the home lacks
    r = client.post(
        "/api/corrections", json={"context": WORK, "change": {"RadioOn": "add"}, "user": "default"}
    )
    assert r.status_code == 422 and "not one of the household (kim, lee)" in r.json()["detail"]


def answer(client, service: str, said: str, context: dict | None = None, user: str = "lee"):
    body = {"context": context or WORK, "service": service, "answer": said, "user": user}
    return client.post("/api/answers", json=body)


def test_each_proposal_gets_its_own_yes_or_no(client, runtime):
    """A yes adds that service alone, a no rejects it alone; an answered proposal is no longer
    pending, even when the next cognition proposes it again."""
    kims = client.post("/api/cognize", json={"context": WORK, "user": "kim"}).json()["services"]
    proposed = client.post("/api/cognize", json={"context": WORK, "user": "lee"}).json()["services"]
    assert set(proposed) == {"RaiseBlind", "LampOn", "BringTea"}
    r = answer(client, "LampOn", "yes")
    assert r.status_code == 200, r.text
    assert r.json()["stored"] == {"kind": "explicit", "want": ["LampOn"], "concerns": ["LampOn"]}
    assert r.json()["user"] == "lee" and r.json()["added"] == [] and r.json()["rejected"] == []
    r = answer(client, "BringTea", "no")
    assert r.status_code == 200 and r.json()["stored"]["concerns"] == ["BringTea"]
    assert r.json()["stored"]["want"] == [] and r.json()["rejected"] == ["BringTea"]
    again = client.post("/api/cognize", json={"context": WORK, "user": "lee"}).json()["services"]
    assert "LampOn" in again and "BringTea" not in again and "RaiseBlind" in again
    assert runtime.pending.pending("lee", runtime.space.point(WORK)) == ["RaiseBlind"]
    # kim's answers are as they were
    assert client.post("/api/cognize", json={"context": WORK, "user": "kim"}).json()["services"] == kims


@pytest.mark.parametrize(
    ("service", "context", "user", "status", "message"),
    [
        ("LampOn", None, "lee", 409, "LampOn is answered already for lee here; still pending: "),
        ("RadioOn", None, "lee", 409, "RadioOn is not among the robot's proposals to lee here: "),
        ("LampOn", {**WORK, "activity": "relax"}, "lee", 409, "the context changed since"),
        ("LampOn", {**WORK, "light": 150}, "lee", 409, "answered already"),  # the same bins: here
        ("LampOn", None, "kim", 409, "nothing is pending for kim"),
        ("LampOn", None, "ann", 422, "user 'ann': not one of the household (kim, lee)"),
        ("Fly", None, "lee", 422, "service: input should be 'RaiseBlind', "),
    ],
)
def test_an_answer_for_what_is_not_pending_is_refused_and_stores_nothing(
    client, runtime, service, context, user, status, message
):
    client.post("/api/cognize", json={"context": WORK, "user": "lee"})
    assert answer(client, "LampOn", "yes").status_code == 200
    count = runtime.store.experience_count()
    r = answer(client, service, "no", context, user)
    assert r.status_code == status and message in r.json()["detail"], r.text
    assert runtime.store.experience_count() == count
    r = client.post("/api/answers", json={"context": WORK, "service": "RaiseBlind", "answer": "maybe"})
    assert r.status_code == 422 and runtime.store.experience_count() == count


def test_the_households_switches_per_day(client, runtime):
    """A person's switch and an undo by hand count as switches; an undo from the page as an
    undo; a correction told here as neither."""
    before = client.get("/api/switches", params={"days": 3}).json()["days"]
    assert [d["day"] for d in before][-1] == date.today().isoformat() and len(before) == 3
    assert runtime.act(runtime.context(), ["RaiseBlind"]) is not None
    (acted,) = runtime.journal.recent()
    assert client.post(f"/api/actions/{acted.id}/undo", json={}).status_code == 200  # from the page
    assert runtime.act(runtime.context(), ["RadioOn"]) is not None
    runtime.switch("radio", False)  # the robot's switch undone by hand
    runtime.switch("desk_lamp", True)  # nobody commanded it: a person's switch
    after = client.get("/api/switches", params={"days": 3}).json()["days"]
    assert after[:2] == before[:2]
    assert after[-1]["switches"] - before[-1]["switches"] == 2
    assert after[-1]["undos"] - before[-1]["undos"] == 2
    kinds = [c.kind for c in correction_history(runtime.store).corrections[-3:]]
    assert kinds == ["undo", "undo", "observed"]
    assert [d.switches for d in switches_per_day(runtime.store, days=1)] == [after[-1]["switches"]]
    for days in (0, 93, "x"):
        assert client.get("/api/switches", params={"days": days}).status_code == 422
