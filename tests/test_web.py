"""The HTTP API: answers, corrections per user, the token, bad input as 4xx."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from webserver import LAYOUT

from homecog.context.manual import ManualSource
from homecog.errors import ContextError
from homecog.home import load_home_text
from homecog.home.codec import json_context
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.planning.acting import Failure
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.settings import MAX_BODY, Settings

STUDIO = Path(__file__).parent / "homes" / "studio.yaml"
WORK = {
    "time": "10:00",
    "light": 50,
    "activity": "work",
    "blind": "off",
    "desk_lamp": "off",
    "radio": "off",
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    home = load_home_text(STUDIO.read_text() + LAYOUT, "studio.yaml")
    url = f"sqlite:///{tmp_path_factory.mktemp('web') / 'knowledge.sqlite'}"
    store = Store.open(url, home)
    tree = build(home, store).tree
    yield home, store, tree
    store.close()


@pytest.fixture
def runtime(built):
    home, store, _ = built
    # a fresh copy of the stored tree per test; corrections of earlier tests are in the store
    return Runtime(home=home, store=store, tree=store.load_tree(), source=ManualSource(home))


@pytest.fixture
def client(runtime):
    return TestClient(create_app(runtime))


def test_home_and_context(client, runtime):
    home = client.get("/api/home").json()
    assert [f["name"] for f in home["features"]] == ["time", "light", "activity"]
    assert [s["name"] for s in home["services"]] == list(runtime.home.service_names)
    assert home["layout"]["rooms"] == {"studio": [0, 0, 4, 4], "bath": [4, 0, 6, 4]}
    assert home["layout"]["places"]["kettle"] == [5, 3] and home["layout"]["doors"] == [[4, 1, 4, 2]]
    context = client.get("/api/context").json()
    assert context == json_context(runtime.home, runtime.source.snapshot())
    assert context["time"] == "06:30" and context["light"] == 0 and context["radio"] == "off"
    r = client.put("/api/context", json={"values": {"activity": "relax", "radio": "on", "time": 7.5}})
    assert r.status_code == 200 and r.json()["activity"] == "relax" and r.json()["radio"] == "on"
    assert client.get("/api/context").json() == {
        **context,
        "activity": "relax",
        "radio": "on",
        "time": "07:30",
    }
    # what GET gives, POST takes: the context round-trips
    assert client.post("/api/cognize", json={"context": client.get("/api/context").json()}).status_code == 200
    assert client.get("/api/source").json() == {"kind": "manual", "connected": True}


def test_cognize_answers_as_the_tree(client, runtime):
    r = client.post("/api/cognize", json={"context": WORK, "user": "kim"})
    assert r.status_code == 200
    data = r.json()
    assert data["services"] == runtime.tree.predict_one(runtime.space.point(WORK))
    assert set(data["services"]) == {"RaiseBlind", "LampOn", "BringTea"}
    assert data["unknown"] is False
    assert [e["service"] for e in data["explanations"]] == data["services"]


def test_a_correction_changes_that_users_answers_only(client):
    before = client.post("/api/cognize", json={"context": WORK, "user": "kim"}).json()["services"]
    want = ["LampOn", "RadioOn"]
    r = client.post("/api/corrections", json={"context": WORK, "want": want, "user": "kim"})
    assert r.status_code == 200
    assert set(r.json()["added"]) == {"RadioOn"} and set(r.json()["rejected"]) == set(before) - set(want)
    assert set(client.post("/api/cognize", json={"context": WORK, "user": "kim"}).json()["services"]) == set(
        want
    )
    assert client.post("/api/cognize", json={"context": WORK, "user": "lee"}).json()["services"] == before
    history = client.get("/api/history", params={"user": "kim"}).json()
    assert history["corrections"][-1]["want"] == want and history["corrections"][-1]["agreed"] is False
    client.post("/api/corrections", json={"context": WORK, "want": want, "user": "kim"})
    agreement = client.get("/api/history", params={"user": "kim"}).json()["agreement"]
    assert [a["agreed"] for a in agreement][-2:] == [False, True]
    assert agreement[-1]["rate"] == pytest.approx(sum(a["agreed"] for a in agreement) / len(agreement))


def test_history_comes_a_bounded_page_at_a_time(client):
    for light in range(0, 250, 50):  # five corrections of pam's
        context = {**WORK, "light": light}
        client.post("/api/corrections", json={"context": context, "want": [], "user": "pam"})
    pages, before = [], None
    while True:
        params = {"user": "pam", "limit": 2, **({"before": before} if before else {})}
        page = client.get("/api/history", params=params).json()
        assert page["total"] == 5 and len(page["corrections"]) <= 2
        pages.append([c["id"] for c in page["corrections"]])
        before = page["before"]
        if before is None:
            break
    ids = [i for p in reversed(pages) for i in p]
    assert [len(p) for p in pages] == [2, 2, 1] and ids == sorted(ids) and len(set(ids)) == 5
    whole = client.get("/api/history", params={"user": "pam"}).json()
    assert [c["id"] for c in whole["corrections"]] == ids and whole["before"] is None
    r = client.get("/api/history", params={"limit": 100_000})
    assert r.status_code == 422 and "limit" in r.json()["detail"]


def test_plan(client):
    r = client.post("/api/plan", json={"services": ["BringTea"], "context": WORK})
    assert r.status_code == 200
    # no errand: speak, where the user is; the robot is at the desk already, so no move desk desk
    assert r.json()["actions"] == [["speak", "bring tea"]]
    sim = r.json()["simulation"]
    assert [row["action"] for row in sim["timeline"]] == r.json()["actions"]
    assert sim["distance_m"] == 0 and sim["seconds"] == 1.8  # "bring tea": 1 s and 0.4 s a word
    assert sim["trajectory"][-1][1:] == [1.0, 1.0]  # at the desk
    # the desk lamp has no IoT switch: the robot drives to it, and the trajectory shows the way
    r = client.post("/api/plan", json={"services": ["LampOn"], "context": WORK})
    sim = r.json()["simulation"]
    assert r.json()["actions"] == [["move", "desk", "studio"], ["switch_by_hand", "desk_lamp", "on"]]
    assert 1.41 <= sim["distance_m"] < 1.6 and 2 < len(sim["trajectory"]) <= 400
    xs, ys = zip(*((x, y) for _, x, y in sim["trajectory"]), strict=True)
    assert (xs[0], ys[0]) == (1.0, 1.0) and abs(xs[-1] - 2) < 0.05 and abs(ys[-1] - 2) < 0.05
    assert sim["devices"]["desk_lamp"] == "on"
    times = [t for t, _, _ in sim["trajectory"]]
    assert times == sorted(times) and times[-1] <= sim["seconds"]
    assert client.post("/api/plan", json={"services": ["Fly"]}).status_code == 422


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ({"context": {**WORK, "mood": "good"}}, "mood"),
        ({"context": {**WORK, "activity": "dance"}}, "dance"),
        ({"context": {k: v for k, v in WORK.items() if k != "radio"}}, "radio"),
        ({"context": {**WORK, "time": "25:00"}}, "25:00"),
        ({"context": {**WORK, "light": "bright"}}, "bright"),
        ({"context": WORK, "user": ""}, "user"),
        ({"context": WORK, "extra": 1}, "extra"),
        ({}, "context"),
    ],
)
def test_bad_cognize_input_is_a_422_naming_it(client, body, message):
    r = client.post("/api/cognize", json=body)
    assert r.status_code == 422
    assert message in str(r.json()["detail"])


def test_the_route_answers_as_fastapis_own_handler_of_it(client, runtime, monkeypatch):
    """Every context of the studio's grid, for a user with corrections and one without: the
    route's own answer to a valid request and FastAPI's handler of the same route (its body
    model, dependencies and response model) give the same answers; a bad request gets FastAPI's
    error, word for word."""
    from homecog.evaluation.scenarios import random_scenarios
    from homecog.web.routes import cognize

    client.post("/api/corrections", json={"context": WORK, "want": ["RadioOn"], "user": "kim"})
    contexts = [
        json_context(runtime.home, runtime.space.context(s.point))
        for s in random_scenarios(runtime.home, 300, seed=3)
    ]
    bodies = [{"context": c, "user": user} for c in contexts for user in ("kim", "default")]
    bad = [{"context": {**WORK, "light": "bright"}}, {"context": WORK, "user": ""}, {"context": 3}]
    broken = {"content": b'{"context": ', "headers": {"content-type": "application/json"}}
    answered = []

    async def spied(request, model):  # the route's own answer, counted
        answered.append(await answer(request, model))
        return answered[-1]

    answer = cognize.answer
    monkeypatch.setattr(cognize, "answer", spied)
    fast = [client.post("/api/cognize", json=body) for body in bodies + bad]
    fast.append(client.post("/api/cognize", **broken))
    assert sum(a is not None for a in answered) == len(bodies)  # the valid ones, and only they

    async def never(request, model):
        return None

    monkeypatch.setattr(cognize, "answer", never)  # FastAPI's handler answers everything
    slow = [client.post("/api/cognize", json=body) for body in bodies + bad]
    slow.append(client.post("/api/cognize", **broken))
    services = set()
    for body, f, s in zip(bodies, fast, slow, strict=False):
        assert f.status_code == s.status_code == 200
        assert f.json() == s.json() == runtime.cognize(body["context"], body["user"])
        services.update(f.json()["services"])
    assert services >= {"RaiseBlind", "LampOn", "BringTea", "RadioOn"}  # not 600 empty answers
    for f, s in zip(fast[len(bodies) :], slow[len(bodies) :], strict=True):
        assert f.status_code == s.status_code == 422 and f.json() == s.json()


def test_cognize_waits_while_a_correction_holds_the_tree(client, runtime):
    import threading
    import time

    runtime.lock.acquire()
    threading.Timer(0.3, runtime.lock.release).start()
    t0 = time.perf_counter()
    r = client.post("/api/cognize", json={"context": WORK})
    assert r.status_code == 200 and time.perf_counter() - t0 >= 0.25
    assert r.json()["services"] == runtime.tree.predict_one(runtime.space.point(WORK))


def test_chunked_bodies_are_limited_too(client):
    def chunks(n: int):
        for _ in range(n):
            yield b" " * 1024

    headers = {"content-type": "application/json"}
    r = client.post("/api/cognize", content=chunks(MAX_BODY // 1024 + 1), headers=headers)
    assert r.status_code == 413 and "64 KiB" in r.json()["detail"]
    body = b" " * (MAX_BODY - 200) + b'{"context": %s}' % json.dumps(WORK).encode()
    r = client.post("/api/cognize", content=iter([body[:1000], body[1000:]]), headers=headers)
    assert r.status_code == 200 and "LampOn" in r.json()["services"]


def test_bad_input_stores_nothing(client, runtime):
    count = runtime.store.experience_count()
    r = client.post("/api/corrections", json={"context": WORK, "want": ["Fly"], "user": "kim"})
    assert r.status_code == 422 and "unknown service 'Fly'" in r.json()["detail"]
    r = client.post("/api/corrections", content=b"{not json", headers={"content-type": "application/json"})
    assert r.status_code == 422
    r = client.post(
        "/api/corrections", content=b"x" * (MAX_BODY + 1), headers={"content-type": "application/json"}
    )
    assert r.status_code == 413 and "64 KiB" in r.json()["detail"]
    r = client.put("/api/context", json={"values": {"activity": "dance"}})
    assert r.status_code == 422 and "dance" in r.json()["detail"]
    assert client.get("/api/context").json()["activity"] != "dance"
    assert runtime.store.experience_count() == count


TOKEN = "s3cret-token"


@pytest.mark.parametrize(
    ("method", "path", "body"),
    [
        ("GET", "/api/home", None),
        ("GET", "/api/context", None),
        ("PUT", "/api/context", {"values": {"radio": "on"}}),
        ("GET", "/api/source", None),
        ("POST", "/api/cognize", {"context": WORK}),
        ("POST", "/api/corrections", {"context": WORK, "want": ["LampOn"], "user": "kim"}),
        ("POST", "/api/plan", {"services": ["BringTea"], "context": WORK}),
        ("GET", "/api/history", None),
        ("GET", "/api/events", None),
    ],
)
def test_every_endpoint_needs_the_token_when_one_is_set(runtime, method, path, body):
    client = TestClient(create_app(runtime, Settings(token=TOKEN)))
    count = runtime.store.experience_count()
    for headers in ({}, {"Authorization": "Bearer wrong-token"}, {"Authorization": f"Basic {TOKEN}"}):
        r = client.request(method, path, json=body, headers=headers)
        assert r.status_code == 401, (path, headers)
        assert r.json()["detail"].startswith("this server needs its token: Authorization: Bearer <token>")
        assert r.headers["www-authenticate"] == "Bearer"
    assert runtime.store.experience_count() == count
    if path != "/api/events":  # an endless stream: tests/test_web_live.py opens it with the token
        r = client.request(method, path + "?access_token=" + TOKEN, json=body)
        assert r.status_code == 401  # the query parameter opens only the event stream
        r = client.request(method, path, json=body, headers={"Authorization": f"bearer {TOKEN}"})
        assert r.status_code == 200
    assert client.get("/").status_code == 200  # the page itself asks for the token
    assert client.get("/openapi.json").json()["components"]["securitySchemes"]["token"]["scheme"] == "bearer"


def test_the_simulated_home_lives_and_the_robot_acts(built):
    from homecog.context.simulated import SimulatedHome

    home, store, _ = built
    source = SimulatedHome(home, speed=60, start="2021-06-21 09:00")
    rt = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    assert rt.tick(600, act=False) is True  # ten simulated minutes pass
    assert rt.context()["time"] == "09:10"
    proposed = rt.tree.predict_one(rt.space.point(rt.context()))
    switched = {d: on for s in proposed for d, on in home.services[home.service_index(s)].sets}
    assert set(switched) & {d.name for d in home.devices if d.iot}, "nothing to switch by IoT at 09:10"
    rt.tick(0)  # no time passes; the robot carries out its IoT switches
    iot = {d.name for d in home.devices if d.iot}
    for device, on in switched.items():
        assert rt.context()[device] == ("on" if on else "off") or device not in iot


class BrokerGone:
    """A context source's switch behind a broker that is gone for ``device``: for the first
    ``failures`` commands, or for good (None)."""

    device = "radio"
    failures: int | None = None

    def switch(self, device: str, on: bool) -> None:
        if device == self.device and (self.failures is None or self.failures > 0):
            self.failures = None if self.failures is None else self.failures - 1
            raise ContextError("the broker is gone")
        super().switch(device, on)  # type: ignore[misc]


def test_the_robot_acts_through_the_planner_and_replans_a_failed_switch(built, caplog):
    from homecog.context.simulated import SimulatedHome

    class FlakyHome(BrokerGone, SimulatedHome):
        failures = 1

    home, store, _ = built
    source = FlakyHome(home, start="2021-06-21 09:00")
    rt = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    now = source.snapshot()
    with caplog.at_level(logging.INFO):
        result = rt.act(now, ["LampOn", "RadioOn", "BringTea"])
    assert result is rt.acted and result.achieved and result.replans == 1
    assert result.failures == [Failure(("switch_iot", "radio", "on"), "ContextError: the broker is gone", 1)]
    assert result.done == [
        ("move", "desk", "studio"),  # the desk lamp has no IoT switch: the robot's body does it
        ("switch_by_hand", "desk_lamp", "on"),
        ("switch_iot", "radio", "on"),
        ("move", "studio", "desk"),  # to the user, who is at the first place
        ("speak", "bring tea"),
    ]
    assert source.snapshot()["desk_lamp"] == "on" and source.snapshot()["radio"] == "on"
    assert rt.actor.body.world.robot == "desk" and rt.actor.body.simulation.result().actions == result.done
    assert "plan 1: ('switch_iot', 'radio', 'on') failed: ContextError: the broker is gone" in caplog.messages
    # once per change of the home, and an errand once while it stays proposed
    assert rt.act(now, ["LampOn", "RadioOn", "BringTea"]) is None
    assert rt.act(source.snapshot(), ["LampOn", "RadioOn", "BringTea"]) is None
    # nor does it switch its own switch back while the user's situation is the same
    assert rt.act(source.snapshot(), ["LampOff"]) is None and rt.actor.skipped_settling
    source.set_context({"activity": "sleep" if source.snapshot()["activity"] != "sleep" else "relax"})
    assert rt.act(source.snapshot(), ["LampOff"]).done == [
        ("move", "desk", "studio"),
        ("switch_by_hand", "desk_lamp", "off"),
    ]


def test_a_switch_that_keeps_failing_is_logged_not_raised(built, caplog):
    class BrokenBroker(BrokerGone, ManualSource):
        pass

    home, store, _ = built
    source = BrokenBroker(home)
    source.set_context({"time": "10:00", "light": "50", "activity": "relax"})
    rt = Runtime(home=home, store=store, tree=store.load_tree(), source=source)
    assert rt.actor.body is None  # no simulated robot: IoT switches only
    result = rt.act(source.snapshot(), ["RaiseBlind", "RadioOn", "LampOn", "BringTea"])
    assert result.tasks == [("RaiseBlind",), ("RadioOn",)]  # the lamp and the tea need a body
    assert result.done == [("switch_iot", "blind", "on")] and not result.achieved
    assert [f.plan for f in result.failures] == [1, 2, 3] and result.replans == 2
    assert result.reason.startswith("gave up after 3 plans; the last: plan 3: ('switch_iot', 'radio', 'on')")
    assert source.snapshot()["blind"] == "on" and source.snapshot()["radio"] == "off"
    proposed = rt.tree.predict_one(rt.space.point(source.snapshot()))
    assert "RadioOn" in proposed
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="homecog.planning.acting"):
        rt.tick(0)  # the home changed (the blind): the robot tries the radio again; the tick goes on
    assert rt.acted.tasks == [("RadioOn",)] and rt.acted.done == [] and not rt.acted.achieved
    failed = "('switch_iot', 'radio', 'on') failed: ContextError: the broker is gone"
    assert caplog.messages == [
        *(f"plan {n}: {failed}" for n in (1, 2, 3)),
        f"acting: gave up after 3 plans; the last: plan 3: {failed}",
    ]


def test_event_streams_are_capped_and_a_stream_past_the_cap_is_a_503(runtime, client):
    import asyncio

    from homecog.robot.events import EventBus, TooManyStreamsError

    async def open_three() -> tuple[int, str]:
        bus = EventBus(limit=2)
        queues = [bus.subscribe(), bus.subscribe()]
        try:
            bus.subscribe()
        except TooManyStreamsError as e:
            message = str(e)
        bus.unsubscribe(queues[0])
        bus.subscribe()  # one closed: one more may open
        return len(bus._subscribers), message

    assert asyncio.run(open_three()) == (2, "2 event streams are open, the most there may be; close one")
    runtime.bus.limit = 0
    r = client.get("/api/events")
    assert (r.status_code, r.headers["retry-after"]) == (503, "10")
    assert r.json()["detail"] == "0 event streams are open, the most there may be; close one"
