"""The running server against what goes wrong around it (issue 12): a database that goes away, a
restart (SIGKILL), a broker whose retained states come at once, the event stream behind a token,
and methods a path does not take."""

from __future__ import annotations

import json
import os
import shutil
import signal
import urllib.error
import urllib.request

import pytest
from fastapi.testclient import TestClient
from servers import fresh_database, server_url
from webserver import build_studio, copy_database, get, homecog_up, send, serve

from homecog.context.manual import ManualSource
from homecog.errors import ContextError
from homecog.home import load_home
from homecog.home.codec import json_context
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.settings import Settings

WORK = {"time": "10:00", "light": 50, "activity": "work", "blind": "off", "desk_lamp": "off", "radio": "off"}


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    """(home file, built database file), once for the module; tests copy the database."""
    return build_studio(tmp_path_factory.mktemp("live"))


def _client(home_path, url, **settings):
    home = load_home(home_path)
    store = Store.open(url, home)
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=ManualSource(home))
    return TestClient(create_app(runtime, Settings(**settings))), runtime


def _outage_is_a_503(client, runtime, reason: str) -> None:
    """While the database cannot be used: corrections and the history say so with 503 and change
    nothing; cognition (the tree is in memory) goes on."""
    r = client.post("/api/corrections", json={"context": WORK, "want": ["RadioOn"], "user": "kim"})
    assert r.status_code == 503, r.text
    detail = r.json()["detail"]
    assert detail.startswith("the knowledge database cannot be used: database ") and reason in detail
    assert "Traceback" not in detail
    r = client.get("/api/history")
    assert r.status_code == 503 and r.json()["detail"].startswith("the knowledge database cannot be used")
    r = client.post("/api/cognize", json={"context": WORK, "user": "lee"})
    assert r.status_code == 200 and "LampOn" in r.json()["services"]


def test_a_sqlite_file_that_cannot_be_opened_is_a_503(studio, tmp_path):
    home_path, db = studio
    folder = tmp_path / "db"
    url = copy_database(db, folder / "knowledge.sqlite")
    client, runtime = _client(home_path, url)
    assert client.post(
        "/api/corrections", json={"context": WORK, "want": ["LampOn"], "user": "kim"}
    ).is_success
    shutil.move(folder, tmp_path / "gone")  # the disk it was on is unmounted, say
    runtime.store.engine.dispose()  # the open connections go with it
    _outage_is_a_503(client, runtime, "unable to open database file")
    shutil.move(tmp_path / "gone", folder)  # back: the server carries on, nothing lost
    assert client.post(
        "/api/corrections", json={"context": WORK, "want": ["LampOn"], "user": "kim"}
    ).is_success
    assert client.get("/api/history", params={"user": "kim"}).json()["total"] == 2
    runtime.store.close()


def test_a_postgresql_database_dropped_under_the_server_is_a_503(studio):
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url
    from sqlalchemy.pool import NullPool

    home_path, _ = studio
    with fresh_database("postgresql") as url:
        home = load_home(home_path)
        store = Store.open(url, home)
        build(home, store)
        store.close()
        client, runtime = _client(home_path, url)
        assert client.post("/api/corrections", json={"context": WORK, "want": ["LampOn"]}).is_success
        admin = create_engine(server_url("postgresql"), isolation_level="AUTOCOMMIT", poolclass=NullPool)
        with admin.connect() as conn:
            conn.execute(text(f"DROP DATABASE {make_url(url).database} WITH (FORCE)"))
        admin.dispose()
        _outage_is_a_503(client, runtime, "does not exist")
        runtime.store.close()


def test_the_history_outlives_a_killed_server(studio, tmp_path):
    """Corrections through one server, SIGKILL, a new server on the same database: the history
    and the agreement curve are still there (they are read from the experience log)."""
    home_path, db = studio
    url = copy_database(db, tmp_path / "knowledge.sqlite")
    wants = [["LampOn", "RadioOn"], ["LampOn", "RadioOn"], ["LampOn"]]
    with homecog_up(home_path, url, tmp_path / "data") as (base, proc):
        for want in wants:
            status, answer = send(f"{base}/api/corrections", {"context": WORK, "want": want, "user": "kim"})
            assert status == 200, answer
        before = get(f"{base}/api/history?user=kim")
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
    with homecog_up(home_path, url, tmp_path / "data") as (base, _):
        after = get(f"{base}/api/history?user=kim")
        everyone = get(f"{base}/api/history?limit=2")
    assert after == before
    assert after["total"] == 3 and [c["want"] for c in after["corrections"]] == wants
    assert [a["agreed"] for a in after["agreement"]] == [False, True, False]
    assert [round(a["rate"], 3) for a in after["agreement"]] == [0, 0.5, 0.333]
    assert after["corrections"][1]["predicted"] == ["LampOn", "RadioOn"]  # what the robot had proposed
    assert everyone["total"] == 3 and [c["want"] for c in everyone["corrections"]] == wants[1:]


def test_off_loopback_homecog_up_makes_a_token_that_every_endpoint_needs(studio, tmp_path):
    home_path, db = studio
    url = copy_database(db, tmp_path / "knowledge.sqlite")
    with homecog_up(home_path, url, tmp_path / "data", host="127.0.0.2") as (base, _):
        log = next((tmp_path / "data").glob("up-*.log")).read_text()
        token = log.split("token for every /api request (shown once):")[1].split()[0]
        assert len(token) >= 30
        for path in ("/api/context", "/api/history", "/api/home"):
            with pytest.raises(urllib.error.HTTPError) as refused:
                get(base + path)
            assert refused.value.code == 401
            assert get(base + path, token=token) is not None
        status, answer = send(f"{base}/api/cognize", {"context": WORK})
        assert status == 401 and answer["detail"].startswith("this server needs its token")
        status, answer = send(f"{base}/api/cognize", {"context": WORK}, token=token)
        assert status == 200 and "LampOn" in answer["services"]  # the route's own answer, with the token


def test_a_bad_token_from_the_environment_is_one_line(monkeypatch, capsys):
    from homecog.cli.main import main

    monkeypatch.setenv("HOMECOG_TOKEN", "short")
    assert main(["up", "--speed", "0"]) == 2
    err = capsys.readouterr().err
    assert err == "homecog: error: token (or $HOMECOG_TOKEN): string should have at least 8 characters\n"


def test_the_event_stream_takes_the_token_as_a_query_parameter(studio, tmp_path):
    home_path, db = studio
    token = "stream-token"
    client, runtime = _client(home_path, copy_database(db, tmp_path / "k.sqlite"), token=token)
    with serve(client.app) as base:
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"{base}/api/events", timeout=5)
        assert refused.value.code == 401
        with urllib.request.urlopen(f"{base}/api/events?access_token={token}", timeout=5) as stream:
            assert stream.headers["content-type"].startswith("text/event-stream")
            assert stream.readline() == b"event: context\n"
            first = json.loads(stream.readline().decode().removeprefix("data: "))
            assert first == json_context(runtime.home, runtime.source.snapshot())
            assert isinstance(first["light"], float)  # numbers as numbers, as POST /api/cognize takes them
            stream.readline()
            status, _ = send(f"{base}/api/corrections", {"context": WORK, "want": ["LampOn"]}, token=token)
            assert status == 200
            assert stream.readline() == b"event: correction\n"
            event = json.loads(stream.readline().decode().removeprefix("data: "))
            assert event == {
                "user": "default",
                "want": ["LampOn"],
                "added": [],
                "rejected": ["RaiseBlind", "BringTea"],
                "kind": "explicit",
            }
    runtime.store.close()


def test_a_405_lists_every_method_of_the_path(studio, tmp_path):
    home_path, db = studio
    client, runtime = _client(home_path, copy_database(db, tmp_path / "k.sqlite"))
    for method, path, allowed in [
        ("DELETE", "/api/context", "GET, PUT"),
        ("POST", "/api/context", "GET, PUT"),
        ("GET", "/api/cognize", "POST"),
        ("PATCH", "/api/history", "GET"),
    ]:
        r = client.request(method, path)
        assert r.status_code == 405 and r.headers["allow"] == allowed, (method, path)
        assert r.json() == {"detail": f"{method} is not allowed here; allowed: {allowed}"}
    runtime.store.close()


def test_homecog_up_takes_a_brokers_retained_states_that_come_at_once(studio, tmp_path, monkeypatch):
    """``homecog up --mqtt``: a broker's retained states can arrive while the source starts; the
    robot must already be there to take them (they were lost to a NameError)."""
    import uvicorn

    from homecog.cli.main import main
    from homecog.context import mqtt_source
    from homecog.robot.runtime import Runtime as RuntimeClass

    home_path, db = studio
    url = copy_database(db, tmp_path / "k.sqlite")
    published: list[tuple[str, object]] = []
    original = RuntimeClass.publish
    monkeypatch.setattr(
        RuntimeClass,
        "publish",
        lambda self, kind, data: (published.append((kind, data)), original(self, kind, data)),
    )

    def start(self):  # the broker's retained states, delivered during start as a fast broker does
        self.update({k: str(v) for k, v in WORK.items()}, topic="retained")
        return self

    monkeypatch.setattr(mqtt_source.MqttSource, "start", start)
    monkeypatch.setattr(mqtt_source.MqttSource, "stop", lambda self: None)
    monkeypatch.setattr(uvicorn, "run", lambda app, **kw: None)
    failures: list[str] = []
    monkeypatch.setattr(mqtt_source.log, "exception", lambda message, *a: failures.append(message))
    args = ["up", "--home", str(home_path), "--db", url, "--mqtt", "mqtt://127.0.0.1:1", "--port", "8999"]
    assert main(args) == 0
    assert failures == []
    assert ("context", {k: str(v) for k, v in WORK.items()}) in published


def test_a_context_from_a_broker_cannot_be_set_by_hand_and_a_missing_state_is_a_503(studio, tmp_path):
    class Broker:  # what homecog up --mqtt has: a snapshot, switches, no set_context
        values: dict[str, str] | None = None

        def snapshot(self) -> dict[str, str]:
            if self.values is None:
                raise ContextError("MQTT: no state received yet for time, light")
            return dict(self.values)

        def switch(self, device: str, on: bool) -> None:
            pass

    home_path, db = studio
    client, runtime = _client(home_path, copy_database(db, tmp_path / "k.sqlite"))
    runtime.source = Broker()
    r = client.get("/api/context")
    assert r.status_code == 503 and r.json() == {"detail": "MQTT: no state received yet for time, light"}
    runtime.source.values = {k: str(v) for k, v in WORK.items()}
    assert client.get("/api/context").json() == {**WORK, "light": 50.0}
    r = client.put("/api/context", json={"values": {"radio": "on"}})
    assert r.status_code == 409 and r.json() == {
        "detail": "the context comes from a broker; it cannot be set by hand"
    }
    runtime.store.close()
