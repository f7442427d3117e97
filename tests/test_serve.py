"""homecog serve: the one-home API of every home of a database under
/api/homes/{home}, with the same answers and errors as ``homecog up``; trees in a bounded
cache, brought up to the database at each request: two servers on one PostgreSQL, a correction
through one seen through the other at the next cognition; Schemathesis finds nothing."""

from __future__ import annotations

import os
import subprocess
import sys
import time
import urllib.error
import urllib.request
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from fleet_homes import home_text, write_homes
from servers import fresh_database
from webserver import copy_database, free_port, get, send

from homecog.context.manual import ManualSource
from homecog.fleet.serve import Fleet, FleetApp
from homecog.fleet.train import learn_home, plan
from homecog.home import Home
from homecog.knowledge.database import make_engine
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.settings import Settings

TOKEN = "fleet-token-1"


def learn(folder: Path, url: str) -> None:
    files = sorted(folder.glob("*.yaml"))
    todo, _ = plan(files, url)  # migrates
    for path in todo:
        assert learn_home(str(path), url).status == "learned"


def context_of(home: Home, **given: object) -> dict[str, object]:
    """A full context of a generated home: evening, reading in room 1, everything off."""
    ctx: dict[str, object] = {"time": "20:00", "temperature": 22, "illumination": 50}
    ctx |= {"location": "room1", "posture": "sit", "behavior": "read"}
    ctx |= dict.fromkeys(home.device_names, "off")
    return {**ctx, **given}


@pytest.fixture(scope="module")
def fleet_db(tmp_path_factory) -> tuple[Path, list[Home]]:
    """Two homes learned into a SQLite file once: (file, homes)."""
    folder = tmp_path_factory.mktemp("fleet")
    homes = write_homes(folder / "homes", 2)
    learn(folder / "homes", f"sqlite:///{folder / 'fleet.sqlite'}")
    return folder / "fleet.sqlite", homes


@pytest.fixture
def fleet_url(fleet_db, tmp_path) -> str:
    return copy_database(fleet_db[0], tmp_path / "fleet.sqlite")


def test_lists_the_homes_and_names_them_for_an_unknown_one(fleet_url, fleet_db):
    client = TestClient(FleetApp(Fleet(fleet_url)))
    assert client.get("/api/homes").json() == {"homes": ["home0", "home1"]}
    home = fleet_db[1][0]
    answer = client.post("/api/homes/nowhere/cognize", json={"context": context_of(home)})
    assert answer.status_code == 404
    assert answer.json() == {"detail": "unknown home 'nowhere'; the database holds 'home0', 'home1'"}
    assert client.get("/elsewhere").status_code == 404


def test_the_same_answers_and_errors_as_the_one_home_api(fleet_url, fleet_db, tmp_path):
    """Every route through the fleet answers as ``homecog up``'s app on the same database."""
    home = fleet_db[1][0]
    fleet = TestClient(FleetApp(Fleet(fleet_url)))
    one_url = copy_database(fleet_db[0], tmp_path / "one.sqlite")
    store = Store.open(one_url, home)
    runtime = Runtime(home=home, store=store, tree=store.load_tree(), source=ManualSource(home))
    one = TestClient(create_app(runtime, Settings()))
    ctx = context_of(home)
    requests = [
        ("GET", "home", None),
        ("POST", "cognize", {"context": ctx, "user": "kim"}),  # the route's own answer
        ("POST", "cognize", {"context": {**ctx, "behavior": "dance"}}),
        ("POST", "cognize", {"context": {**ctx, "time": 25}}),
        ("POST", "cognize", b"{not json"),
        ("POST", "corrections", {"context": ctx, "want": ["Fly"], "user": "kim"}),
        ("POST", "plan", {"services": ["SendDrinks"], "context": ctx}),
        ("POST", "plan", {"services": ["Nothing"]}),
        ("GET", "history", None),
        ("GET", "history?limit=0", None),
        ("PUT", "cognize", None),
    ]
    for method, path, body in requests:
        kwargs = {"content": body} if isinstance(body, bytes) else {"json": body}
        headers = {"content-type": "application/json"}
        a = fleet.request(method, f"/api/homes/{home.name}/{path}", headers=headers, **kwargs)
        b = one.request(method, f"/api/{path}", headers=headers, **kwargs)
        assert (a.status_code, a.json()) == (b.status_code, b.json()), (method, path)
    store.close()


def test_a_correction_goes_to_the_database_and_is_seen_at_once(fleet_url, fleet_db):
    home = fleet_db[1][1]
    client = TestClient(FleetApp(Fleet(fleet_url)))
    base = f"/api/homes/{home.name}"
    ctx = context_of(home)
    before = client.post(f"{base}/cognize", json={"context": ctx, "user": "kim"}).json()["services"]
    want = [s for s in before if s != "SendDrinks"] if "SendDrinks" in before else [*before, "SendDrinks"]
    answer = client.post(f"{base}/corrections", json={"context": ctx, "want": want, "user": "kim"})
    assert answer.status_code == 200, answer.text
    assert client.post(f"{base}/cognize", json={"context": ctx, "user": "kim"}).json()["services"] == want
    assert client.get(f"{base}/history").json()["total"] == 1
    store = Store.open(fleet_url, home)  # in the database, for everyone who reads it
    assert store.load_tree().predict_one(ctx, "kim") == want and store.home_version() == (2, 1)
    store.close()


def test_a_home_built_again_is_served_anew(fleet_url, fleet_db, tmp_path):
    """Another build of a cached home (here from a changed home file) moves its build: the
    server reads the home, its models and its tree again."""
    home = fleet_db[1][0]
    client = TestClient(FleetApp(Fleet(fleet_url)))
    base = f"/api/homes/{home.name}"
    asked = {"context": context_of(home), "user": "kim"}
    assert "SendDrinks" in client.post(f"{base}/cognize", json=asked).json()["services"]
    changed = tmp_path / f"{home.name}.yaml"
    changed.write_text(home_text(1, name=home.name).replace("SendDrinks", "BringWater"))
    assert learn_home(str(changed), fleet_url).status == "learned"
    services = client.post(f"{base}/cognize", json=asked).json()["services"]
    assert "BringWater" in services and "SendDrinks" not in services
    assert "BringWater" in [s["name"] for s in client.get(f"{base}/home").json()["services"]]


def test_the_cache_is_bounded_and_answers_alike(fleet_url, fleet_db):
    fleet = Fleet(fleet_url, cache=1)
    client = TestClient(FleetApp(fleet))
    first = {}
    for round_ in range(3):
        for home in fleet_db[1]:
            ctx = {"context": context_of(home), "user": "kim"}
            answer = client.post(f"/api/homes/{home.name}/cognize", json=ctx).json()
            assert first.setdefault(home.name, answer) == answer, round_
            assert len(fleet._entries) == 1


def test_the_token_guards_every_api_path(fleet_url, fleet_db):
    client = TestClient(FleetApp(Fleet(fleet_url, Settings(token=TOKEN))))
    home = fleet_db[1][0]
    body = {"context": context_of(home)}
    for method, path, json_ in [
        ("GET", "/api/homes", None),
        ("POST", f"/api/homes/{home.name}/cognize", body),
        ("POST", "/api/homes/nowhere/cognize", body),  # names no home to a stranger
    ]:
        answer = client.request(method, path, json=json_)
        assert answer.status_code == 401 and "token" in answer.json()["detail"], path
    auth = {"Authorization": f"Bearer {TOKEN}"}
    assert client.post(f"/api/homes/{home.name}/cognize", json=body, headers=auth).status_code == 200


def test_each_home_schema_documents_the_fleets_own_answers(fleet_url, fleet_db):
    """Every operation of a home's schema documents what the fleet layer answers before the
    home's app (an unknown home, the database, the home's stored file; the token where the
    server has one), with the one error model; and those answers fit it."""
    home = fleet_db[1][0]
    for token in (None, TOKEN):
        fleet = Fleet(fleet_url, Settings(token=token))
        client = TestClient(FleetApp(fleet))
        auth = {"Authorization": f"Bearer {token}"} if token else {}
        schema = client.get(f"/api/homes/{home.name}/openapi.json").json()
        operations = [op for ops in schema["paths"].values() for op in ops.values()]
        assert len(operations) == 5
        expected = {"404", "409", "503"} | ({"401"} if token else set())
        for op in operations:
            assert expected <= set(op["responses"]), op["operationId"]
            for code in expected:
                content = op["responses"][code]["content"]["application/json"]["schema"]
                assert content == {"$ref": "#/components/schemas/ErrorOut"}
            assert ("401" in op["responses"]) == bool(token)  # only where it can happen
        assert schema["components"]["schemas"]["ErrorOut"]["required"] == ["detail"]
        gone = client.get("/api/homes/nowhere/history", headers=auth)
        assert gone.status_code == 404 and list(gone.json()) == ["detail"]
        fleet.engine.dispose()  # the database goes away under the server: an empty one now
        fleet.engine = make_engine("sqlite://")
        down = client.get(f"/api/homes/{home.name}/history", headers=auth)
        assert down.status_code == 503 and list(down.json()) == ["detail"], down.text
        assert "cannot be used" in down.json()["detail"]


def test_the_fleet_schema_describes_the_list_of_homes(fleet_url):
    """``/api/openapi.json``: ``GET /api/homes`` with its 200 model, 503 and (with a token) 401;
    a path no home's name can take."""
    for token in (None, TOKEN):
        client = TestClient(FleetApp(Fleet(fleet_url, Settings(token=token))))
        schema = client.get("/api/openapi.json").json()
        assert list(schema["paths"]) == ["/api/homes"] and list(schema["paths"]["/api/homes"]) == ["get"]
        op = schema["paths"]["/api/homes"]["get"]
        assert set(op["responses"]) == {"200", "503"} | ({"401"} if token else set())
        model = schema["components"]["schemas"]["HomesOut"]
        assert model["properties"]["homes"]["type"] == "array" and model["required"] == ["homes"]
        assert "/api/homes/{home}/openapi.json" in schema["info"]["description"]
        if token:
            assert op["security"] == [{"token": []}]
            assert schema["components"]["securitySchemes"]["token"]["scheme"] == "bearer"
        assert client.post("/api/openapi.json").status_code == 405


def test_only_get_and_head_on_the_list_and_the_schemas_with_allow(fleet_url):
    client = TestClient(FleetApp(Fleet(fleet_url)))
    for path in ("/api/homes", "/api/openapi.json", "/api/homes/home0/openapi.json"):
        for method in ("POST", "PUT", "DELETE"):
            answer = client.request(method, path)
            assert answer.status_code == 405, (method, path)
            assert answer.headers["allow"] == "GET, HEAD"
            assert answer.json() == {"detail": f"{method} is not allowed here; allowed: GET, HEAD"}
        assert client.head(path).status_code == 200


def test_the_schemas_need_no_token_as_with_homecog_up(fleet_url, fleet_db):
    """As ``homecog up``'s ``/openapi.json``, the schemas need no token; everything else does,
    and an unknown home's schema names no other home to a stranger."""
    home = fleet_db[1][0]
    client = TestClient(FleetApp(Fleet(fleet_url, Settings(token=TOKEN))))
    assert client.get("/api/openapi.json").status_code == 200
    schema = client.get(f"/api/homes/{home.name}/openapi.json")
    assert schema.status_code == 200 and schema.json()["info"]["title"] == f"homecog: {home.name}"
    runtime = Runtime(
        home=home, store=Store.open("sqlite://", home), tree=IHDRTree(home), source=ManualSource(home)
    )
    up = TestClient(create_app(runtime, Settings(token=TOKEN)))
    assert up.get("/openapi.json").status_code == 200  # homecog up's, the same way
    assert up.get("/api/home").status_code == 401
    assert client.get(f"/api/homes/{home.name}/home").status_code == 401
    stranger = client.get("/api/homes/nowhere/openapi.json")
    assert stranger.json() == {"detail": "unknown home 'nowhere'"} and stranger.status_code == 404
    auth = {"Authorization": f"Bearer {TOKEN}"}
    named = client.get("/api/homes/nowhere/openapi.json", headers=auth).json()["detail"]
    assert named == "unknown home 'nowhere'; the database holds 'home0', 'home1'"


# -- serve processes --------------------------------------------------------------------------------
@contextmanager
def homecog_serve(db: str, data: Path, *args: str) -> Iterator[str]:
    """``homecog serve`` on a free port until the block ends: its base URL."""
    port = free_port()
    command = [sys.executable, "-m", "homecog.cli.main", "serve", "--db", db, "--port", str(port), *args]
    data.mkdir(parents=True, exist_ok=True)
    log_path = data / f"serve-{port}.log"
    log = log_path.open("wb")
    proc = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env={**os.environ})
    base = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                urllib.request.urlopen(f"{base}/api/openapi.json", timeout=2).close()  # no token
                break
            except (urllib.error.URLError, OSError):
                assert proc.poll() is None, log_path.read_text()
                assert time.monotonic() < deadline, "homecog serve did not answer within 60 s"
                time.sleep(0.1)
        yield base
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()


@pytest.mark.slow
def test_two_servers_on_postgresql_a_correction_through_one_seen_through_the_other(tmp_path):
    homes = write_homes(tmp_path / "homes", 2)
    with fresh_database("postgresql") as url:
        learn(tmp_path / "homes", url)
        with homecog_serve(url, tmp_path) as a, homecog_serve(url, tmp_path) as b:
            assert get(f"{a}/api/homes") == get(f"{b}/api/homes") == {"homes": ["home0", "home1"]}
            for home in homes:
                ctx = context_of(home)
                path = f"/api/homes/{home.name}"
                asked = {"context": ctx, "user": "kim"}
                status, before = send(f"{b}{path}/cognize", asked)  # b holds the tree from here on
                assert status == 200
                assert send(f"{a}{path}/cognize", asked)[1] == before
                want = before["services"][1:] if before["services"] else ["SendDrinks"]
                status, _ = send(f"{a}{path}/corrections", {**asked, "want": want})
                assert status == 200
                assert send(f"{b}{path}/cognize", asked)[1]["services"] == want  # the next cognition
                assert send(f"{b}{path}/cognize", {**asked, "user": "lee"})[1] == before  # kim's only
                assert get(f"{b}{path}/history")["total"] == 1


@pytest.mark.slow
@pytest.mark.parametrize("token", [None, TOKEN], ids=["127.0.0.1", "token"])
def test_schemathesis_finds_nothing(fleet_url, tmp_path, token):
    """Schemathesis with every check against a home of a running ``homecog serve``, as against
    ``homecog up`` (tests/test_contract.py), and against the fleet's own schema (the list)."""
    args = ["--token", token] if token else []
    with homecog_serve(fleet_url, tmp_path / "data", *args) as base:
        for schema, operations in (("homes/home0/openapi.json", 5), ("openapi.json", 1)):
            report = tmp_path / "junit.xml"
            command = [sys.executable, "-m", "schemathesis.cli", "run", f"{base}/api/{schema}"]
            command += ["--checks", "all", "--max-examples", "50", "--seed", "12", "--request-timeout", "30"]
            command += ["--report", "junit", "--report-junit-path", str(report), "--no-color"]
            if token:
                command += ["--header", f"Authorization: Bearer {token}"]
            run = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=tmp_path)
            assert run.returncode == 0, run.stdout[-6000:] + run.stderr[-2000:]
            suite = ET.parse(report).getroot()
            names = sorted(c.get("name", "") for c in suite.iter("testcase"))
            assert len(names) == operations, names  # home, cognize, corrections, plan, history; homes
            assert (
                sum(int(s.get("failures", 0)) + int(s.get("errors", 0)) for s in suite.iter("testsuite")) == 0
            )
            assert "No issues found" in run.stdout


def test_versions_are_read_in_batches_each_after_its_request_came():
    """The requests waiting while a read is under way share the next read, never the one that
    started before they came (it may miss a write they must see)."""
    import asyncio
    import threading

    from homecog.fleet.serve import Versions

    class Db:
        def __init__(self) -> None:
            self.reads: list[list[str]] = []
            self.version = 1
            self.gate = threading.Event()

        def versions(self, names: list[str]) -> dict[str, tuple[int, int]]:
            self.reads.append(sorted(names))
            seen = self.version  # what the database holds when the read starts
            self.gate.wait(5)
            return {n: (seen, 1) for n in names if n != "gone"}

    db = Db()
    versions = Versions(db)  # type: ignore[arg-type]

    async def scenario() -> list[tuple[int, int] | None]:
        first = [asyncio.create_task(versions.of(n)) for n in ("a", "b", "a", "gone")]
        await asyncio.sleep(0.05)  # the first read is under way, held at the gate
        db.version = 2  # a write commits; then a request comes
        late = asyncio.create_task(versions.of("a"))
        await asyncio.sleep(0.05)
        db.gate.set()
        return [*(await asyncio.gather(*first)), await late]

    answers = asyncio.run(scenario())
    assert answers == [(1, 1), (1, 1), (1, 1), None, (2, 1)]
    assert db.reads == [["a", "b", "gone"], ["a"]]
