"""``POST /api/corrections`` with ``change``: some services added or rejected, every other
service keeping what it had (as ``homecog correct --add/--reject``), and its bad input as 422s."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from jsonschema import Draft202012Validator
from pydantic import ValidationError
from webserver import LAYOUT

from homecog.context.manual import ManualSource
from homecog.home import load_home_text
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.models import HomeModels

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
SERVICES = "RaiseBlind, LowerBlind, LampOn, LampOff, RadioOn, RadioOff, BringTea, SayGoodnight"
WORK = {"time": "10:00", "light": 50, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "off"}
RELAX = {
    "time": "15:00",
    "light": 300,
    "activity": "relax",
    "blind": "on",
    "desk_lamp": "off",
    "radio": "off",
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    home = load_home_text(STUDIO.read_text() + LAYOUT, "studio.yaml")
    store = Store.open(f"sqlite:///{tmp_path_factory.mktemp('corrections') / 'knowledge.sqlite'}", home)
    build(home, store)
    yield home, store
    store.close()


@pytest.fixture
def runtime(built):
    home, store = built  # each test corrects for its own users: the store is shared
    return Runtime(home=home, store=store, tree=store.load_tree(), source=ManualSource(home))


@pytest.fixture
def client(runtime):
    return TestClient(create_app(runtime))


def cognize(client: TestClient, context: dict, user: str) -> list[str]:
    r = client.post("/api/cognize", json={"context": context, "user": user})
    assert r.status_code == 200, r.text
    return r.json()["services"]


def test_an_add_keeps_the_other_services_answers(client, runtime):
    published: list[tuple[str, object]] = []
    runtime.publish = lambda kind, data: published.append((kind, data))
    assert cognize(client, WORK, "kim") == ["RaiseBlind", "LampOn", "BringTea"]
    assert cognize(client, RELAX, "kim") == ["BringTea", "RadioOn"]
    count = runtime.store.experience_count()
    r = client.post("/api/corrections", json={"context": WORK, "change": {"RadioOn": "add"}, "user": "kim"})
    assert r.status_code == 200
    assert r.json() == {
        "added": ["RadioOn"],
        "rejected": [],
        "experiences": count + 1,
        "user": "kim",
        "number": 1,
        "stored": {"kind": "explicit", "want": ["RadioOn"], "concerns": ["RadioOn"]},
        "says": "wants RadioOn",
    }
    # nothing else rejected there (a want of ["RadioOn"] would have rejected the three others)
    assert cognize(client, WORK, "kim") == ["RaiseBlind", "LampOn", "BringTea", "RadioOn"]
    assert cognize(client, RELAX, "kim") == ["BringTea", "RadioOn"]  # another context: as it was
    assert cognize(client, WORK, "lee") == ["RaiseBlind", "LampOn", "BringTea"]  # for that user only
    last = client.get("/api/history", params={"user": "kim"}).json()["corrections"][-1]
    assert (last["kind"], last["want"], last["concerns"]) == ("explicit", ["RadioOn"], ["RadioOn"])
    assert published == [
        (
            "correction",
            {
                "user": "kim",
                "want": ["RadioOn"],
                "added": ["RadioOn"],
                "rejected": [],
                "kind": "explicit",
                "concerns": ["RadioOn"],
            },
        )
    ]


def test_a_reject_keeps_the_other_services_answers(client):
    body = {"context": WORK, "change": {"BringTea": "reject"}, "user": "ria"}
    r = client.post("/api/corrections", json=body)
    assert r.status_code == 200 and (r.json()["added"], r.json()["rejected"]) == ([], ["BringTea"])
    assert cognize(client, WORK, "ria") == ["RaiseBlind", "LampOn"]
    assert cognize(client, RELAX, "ria") == ["BringTea", "RadioOn"]  # BringTea still wanted there
    last = client.get("/api/history", params={"user": "ria"}).json()["corrections"][-1]
    assert (last["want"], last["concerns"]) == ([], ["BringTea"])
    # the same again: the robot agrees now, and nothing changes
    r = client.post("/api/corrections", json=body)
    assert (r.json()["added"], r.json()["rejected"]) == ([], [])


def test_an_add_and_a_reject_in_one_change(client):
    change = {"RadioOn": "add", "BringTea": "reject"}
    r = client.post("/api/corrections", json={"context": WORK, "change": change, "user": "uma"})
    assert r.status_code == 200 and (r.json()["added"], r.json()["rejected"]) == (["RadioOn"], ["BringTea"])
    assert cognize(client, WORK, "uma") == ["RaiseBlind", "LampOn", "RadioOn"]
    last = client.get("/api/history", params={"user": "uma"}).json()["corrections"][-1]
    assert (last["want"], last["concerns"]) == (["RadioOn"], ["RadioOn", "BringTea"])


def test_the_whole_set_works_as_before(client):
    r = client.post("/api/corrections", json={"context": WORK, "want": ["RadioOn"], "user": "vic"})
    assert r.status_code == 200
    assert (r.json()["added"], r.json()["rejected"]) == (["RadioOn"], ["RaiseBlind", "LampOn", "BringTea"])
    assert cognize(client, WORK, "vic") == ["RadioOn"]
    assert client.get("/api/history", params={"user": "vic"}).json()["corrections"][-1]["concerns"] is None


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ({"change": {"Fly": "add"}}, f"unknown service 'Fly'; expected some of {SERVICES}"),
        (
            {"change": {"LampOn": "add", "Fly": "reject"}},
            f"unknown service 'Fly'; expected some of {SERVICES}",
        ),
        ({"change": {"LampOn": "maybe"}}, 'change: LampOn: expected "add" or "reject", not \'maybe\''),
        ({"change": {"LampOn": True}}, 'change: LampOn: expected "add" or "reject", not True'),
        ({"change": {}}, 'change names no service; give some, each "add" or "reject"'),
        ({"change": ["LampOn"]}, 'change: expected an object of services, each "add" or "reject"'),
        (
            {"want": ["LampOn"], "change": {"RadioOn": "add"}},
            "give want (the whole set wanted) or change (some services), not both",
        ),
        (
            {"want": [], "change": {"RadioOn": "add"}},
            "give want (the whole set wanted) or change (some services), not both",
        ),
        ({}, "missing want (the whole set wanted) or change (some services)"),
        ({"add": ["RadioOn"]}, "add: extra inputs are not permitted"),
    ],
)
def test_a_bad_change_is_a_422_naming_it_and_stores_nothing(client, runtime, body, message):
    count = runtime.store.experience_count()
    r = client.post("/api/corrections", json={"context": WORK, "user": "wes", **body})
    assert (r.status_code, r.json()) == (422, {"detail": message})
    assert runtime.store.experience_count() == count


def test_a_service_both_added_and_rejected_is_refused(client, runtime):
    """The only way to write it: a JSON object naming the service twice, which a JSON parser would
    read as the last (a rejection alone)."""
    count = runtime.store.experience_count()
    context = json.dumps(WORK).encode()
    for change, name in [
        (b'{"LampOn": "add", "LampOn": "reject"}', "LampOn"),
        (b'{"RadioOn": "add", "RadioOn": "add"}', "RadioOn"),
    ]:
        body = b'{"context": %s, "user": "wes", "change": %s}' % (context, change)
        r = client.post("/api/corrections", content=body, headers={"content-type": "application/json"})
        detail = f"body: {name!r} is given twice in one object; give each name once"
        assert (r.status_code, r.json()) == (422, {"detail": detail})
    body = b'{"context": %s, "user": "wes", "user": "xan", "want": []}' % context
    r = client.post("/api/corrections", content=body, headers={"content-type": "application/json"})
    assert r.json() == {"detail": "body: 'user' is given twice in one object; give each name once"}
    assert runtime.store.experience_count() == count
    r = client.post("/api/corrections", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422 and r.json()["detail"].startswith("body: invalid JSON at character 1")


# -- the schema says exactly what the model takes -------------------------------------------------
NAMES = ["LampOn", "RadioOn", "BringTea", "Fly"]
VERDICTS = st.sampled_from(["add", "reject", "maybe", True, None])
BODIES = st.fixed_dictionaries(
    {"context": st.just(WORK)},
    optional={
        "want": st.lists(st.sampled_from(NAMES), max_size=3),
        "change": st.dictionaries(st.sampled_from(NAMES), VERDICTS, max_size=3),
        "add": st.lists(st.sampled_from(NAMES), max_size=2),
    },
)


@pytest.fixture(scope="module")
def contract(built):
    model = HomeModels.of(built[0]).correction_in
    return model, Draft202012Validator(model.model_json_schema())


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(body=BODIES)
def test_the_schema_takes_a_correction_exactly_when_the_model_does(contract, body):
    model, schema = contract
    try:
        model.model_validate(body)
        taken = True
    except ValidationError:
        taken = False
    assert taken == schema.is_valid(body), body


@pytest.mark.parametrize(
    ("headers", "detail"),
    [
        (
            {"Origin": "https://evil.example"},
            "a request from https://evil.example may not change anything here",
        ),
        ({"Sec-Fetch-Site": "cross-site"}, "a cross-site request may not change anything here"),
        (
            {"Sec-Fetch-Site": "same-site", "Origin": "http://testserver"},
            "a same-site request may not change",
        ),
        ({"Origin": "null"}, "a request from null may not change anything here"),
    ],
)
def test_another_site_can_change_nothing_through_a_browser(client, runtime, headers, detail):
    """A page elsewhere cannot make the household's browser correct, undo or set the context
    (on 127.0.0.1 no token is asked); reading is not concerned, nor clients that are not browsers."""
    user = f"eve{sorted(headers.values())[0][:9]}"  # the store is shared: a user per case
    before = runtime.store.counts()
    form = {"context": json.dumps(WORK), "want": "RadioOn", "user": user}
    for r in (
        client.post(
            "/api/corrections", json={"context": WORK, "want": ["RadioOn"], "user": user}, headers=headers
        ),
        client.post("/api/corrections", data=form, headers=headers),  # a plain form post
        client.post("/api/actions/1/undo", headers=headers),
        client.post("/api/context", json={"activity": "relax"}, headers=headers),
    ):
        assert r.status_code == 403 and r.json()["detail"].startswith(detail), r.text
    assert runtime.store.counts() == before and user not in runtime.tree.users
    assert client.get("/api/history", headers=headers).status_code == 200
    own = {"Origin": "http://testserver", "Sec-Fetch-Site": "same-origin"}
    body = {"context": WORK, "want": ["RadioOn"], "user": user}
    assert client.post("/api/corrections", json=body, headers=own).status_code == 200
    assert client.post("/api/corrections", json=body).status_code == 200  # a script: no Origin
