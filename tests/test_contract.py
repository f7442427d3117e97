"""The HTTP contract (issue 12): the OpenAPI schema made for the served home says exactly what the
server takes, every error is documented with its model, and Schemathesis with every check finds
nothing against ``homecog up``."""

from __future__ import annotations

import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError
from webserver import build_studio, homecog_up

from homecog.context.manual import ManualSource
from homecog.errors import ContextError
from homecog.home import load_home
from homecog.home.clock import parse_clock
from homecog.home.codec import Space
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.robot.runtime import Runtime
from homecog.web.main import create_app
from homecog.web.models import CLOCK_PATTERN, HomeModels
from homecog.web.settings import Settings

TOKEN = "contract-token"
PAPER_CONTEXT = {
    "time": "22:00",
    "temperature": 19,
    "illumination": 200,
    "location": "table",
    "posture": "sit",
    "behavior": "read",
    **dict.fromkeys(("window", "curtain", "lamp", "ceiling_light"), "on"),
    **dict.fromkeys(("tv_living", "tv_bedroom", "ac_living", "ac_bedroom"), "off"),
}


def paper_schema(token: str | None = None) -> dict:
    home = load_home("paper")
    store = Store.open("sqlite://", home)
    runtime = Runtime(home=home, store=store, tree=IHDRTree(home), source=ManualSource(home))
    return TestClient(create_app(runtime, Settings(token=token))).get("/openapi.json").json()


@pytest.fixture(scope="module")
def schema() -> dict:
    return paper_schema()


def test_the_context_is_an_object_of_the_homes_features_and_devices(schema, paper):
    context = schema["components"]["schemas"]["Context"]
    names = [*paper.feature_names, *paper.device_names]
    assert list(context["properties"]) == names and context["required"] == names
    assert context["additionalProperties"] is False
    props = context["properties"]
    assert props["location"]["enum"] == list(paper.feature("location").values)
    assert props["behavior"]["enum"] == ["read", "watch_tv", "sleep", "eat"]
    assert all(props[d]["enum"] == ["on", "off"] for d in paper.device_names)
    assert props["illumination"]["type"] == "number" and props["illumination"]["minimum"] == 0
    assert "maximum" not in props["illumination"] and "exclusiveMaximum" not in props["illumination"]
    assert props["temperature"]["type"] == "number" and "minimum" not in props["temperature"]
    text, hours = props["time"]["anyOf"]
    assert text == {"type": "string", "pattern": CLOCK_PATTERN}
    assert hours == {"type": "number", "minimum": 0, "maximum": 24}
    change = schema["components"]["schemas"]["ContextChange"]
    assert change["properties"] == props and "required" not in change


def test_a_correction_is_the_whole_set_or_a_change_of_some_services(schema, paper):
    correction = schema["components"]["schemas"]["CorrectionIn"]
    assert correction["oneOf"] == [{"required": ["want"]}, {"required": ["change"]}]
    assert correction["required"] == ["context"] and correction["additionalProperties"] is False
    assert list(correction["properties"]) == ["context", "want", "change", "user"]
    want = correction["properties"]["want"]
    assert (want["type"], want["items"]["enum"], want["maxItems"]) == (
        "array",
        list(paper.service_names),
        200,
    )
    assert correction["properties"]["change"]["$ref"] == "#/components/schemas/CorrectionChange"
    change = schema["components"]["schemas"]["CorrectionChange"]
    assert list(change["properties"]) == list(paper.service_names)  # each service once at most
    assert all(p["enum"] == ["add", "reject"] for p in change["properties"].values())
    assert change["additionalProperties"] is False and change["minProperties"] == 1


def test_every_error_is_documented_with_the_one_model(schema):
    operations = {(m.upper(), p): op for p, ops in schema["paths"].items() for m, op in ops.items()}
    assert set(operations) == {
        ("GET", "/api/home"),
        ("GET", "/api/context"),
        ("PUT", "/api/context"),
        ("GET", "/api/source"),
        ("POST", "/api/cognize"),
        ("POST", "/api/corrections"),
        ("POST", "/api/plan"),
        ("GET", "/api/history"),
        ("GET", "/api/actions"),
        ("POST", "/api/actions/{action}/undo"),
        ("GET", "/api/events"),
        ("POST", "/api/session"),
        ("POST", "/api/answers"),
        ("GET", "/api/switches"),
    }
    error = {"$ref": "#/components/schemas/ErrorOut"}
    for key, op in operations.items():
        for status, answer in op["responses"].items():
            if not status.startswith("2"):
                assert answer["content"]["application/json"]["schema"] == error, (key, status)
    assert "HTTPValidationError" not in schema["components"]["schemas"]
    assert set(operations["POST", "/api/corrections"]["responses"]) == {"200", "413", "422", "503"}
    assert set(operations["PUT", "/api/context"]["responses"]) == {"200", "409", "413", "422", "503"}
    assert set(operations["POST", "/api/plan"]["responses"]) == {"200", "409", "413", "422", "429"}
    assert set(operations["POST", "/api/session"]["responses"]) == {"204"}
    assert set(operations["POST", "/api/answers"]["responses"]) == {"200", "409", "413", "422", "503"}
    events = operations["GET", "/api/events"]["responses"]["200"]["content"]
    assert list(events) == ["text/event-stream"]
    assert "security" not in operations["GET", "/api/home"]  # 127.0.0.1 without a token: open


def test_with_a_token_every_operation_declares_it():
    schema = paper_schema(TOKEN)
    schemes = schema["components"]["securitySchemes"]
    assert schemes["token"] == {
        "type": "http",
        "scheme": "bearer",
        "description": schemes["token"]["description"],
    }
    assert schemes["token_in_query"]["in"] == "query" and schemes["token_in_query"]["name"] == "access_token"
    cookie = schemes["token_in_cookie"]
    assert (cookie["in"], cookie["name"]) == ("cookie", "homecog_token")
    for path, ops in schema["paths"].items():
        for op in ops.values():
            want = [{"token": []}, {"token_in_cookie": []}]
            if path == "/api/events":
                want.append({"token_in_query": []})
            assert op["security"] == want, path
            assert op["responses"]["401"]["content"]["application/json"]["schema"]["$ref"].endswith(
                "ErrorOut"
            )


# -- one clock parser ---------------------------------------------------------------------------
CLOCKISH = st.one_of(
    st.text(max_size=10),
    st.text(alphabet="0123456789:._-+ e\n", max_size=9),
    st.from_regex(CLOCK_PATTERN),
    st.sampled_from(["7:-5", "7:", "7:3_0", ":30", "7::30", "24:00", "24:01", "07:30:60", "٧:30", "7:30\n"]),
)


def _home_reading(paper, text: str) -> float | None:
    try:
        paper.feature("time").discretize(text)
        return float(paper.feature("time").parse(text))
    except ContextError:
        return None


@settings(max_examples=800, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(text=CLOCKISH)
def test_the_fast_path_reads_every_clock_string_as_the_home_does(paper, text):
    """``Space.point`` (its fast path first) and the home's own parsing (the scenario-file loader's)
    accept and refuse the same clock strings, and read the same time from those they accept."""
    space = Space(paper)
    context = {**PAPER_CONTEXT, "time": text}
    expected = _home_reading(paper, text)
    for read in (space._fast_point, space.point):
        try:
            reading = read(context).readings[0]
        except (ContextError, KeyError, ValueError, TypeError, IndexError):
            reading = None
        assert reading == expected, (read.__name__, text)


@settings(max_examples=300, deadline=None)
@given(text=CLOCKISH)
def test_the_contract_takes_a_clock_string_exactly_when_the_pattern_matches(paper, text):
    """What the schema promises (Python's ``re`` semantics, as the fuzzer's) is what the model
    takes, and the home reads everything the pattern lets through."""
    model = HomeModels.of(paper).cognize_in
    try:
        model.model_validate({"context": {**PAPER_CONTEXT, "time": text}})
        taken = True
    except ValidationError:
        taken = False
    assert taken == bool(re.search(CLOCK_PATTERN, text)), text
    if taken:
        assert _home_reading(paper, text) == parse_clock(text)


@settings(max_examples=300, deadline=None)
@given(hours=st.one_of(st.floats(), st.integers(-5, 30), st.booleans()))
def test_the_contract_takes_decimal_hours_from_0_to_24(paper, hours):
    model = HomeModels.of(paper).cognize_in
    try:
        model.model_validate({"context": {**PAPER_CONTEXT, "time": hours}})
        taken = True
    except ValidationError:
        taken = False
    assert taken == (not isinstance(hours, bool) and 0 <= hours <= 24), hours


@pytest.mark.parametrize("text", ["7:-5", "7:", "7:3_0"])
def test_the_review_s_clock_strings_are_refused_as_the_scenario_loader_refuses_them(paper, text):
    space = Space(paper)
    with pytest.raises(ContextError) as caught:
        space.point({**PAPER_CONTEXT, "time": text})
    assert str(caught.value) == f"time: not a time: {text!r}; expected HH:MM or decimal hours"
    with pytest.raises(ContextError, match=re.escape(str(caught.value))):
        paper.feature("time").discretize(text)


# -- Schemathesis against homecog up ----------------------------------------------------------
@pytest.fixture(scope="module")
def studio_built(tmp_path_factory):
    return build_studio(tmp_path_factory.mktemp("contract"))


@pytest.mark.slow
@pytest.mark.parametrize("token", [None, TOKEN], ids=["127.0.0.1", "token"])
def test_schemathesis_finds_nothing(studio_built, tmp_path, token):
    """Schemathesis (pinned in the test extra) with every check, every phase that applies and
    every operation, the event stream included, against a running ``homecog up``."""
    home, db = studio_built
    url = f"sqlite:///{db}"  # the fuzzer's corrections go into the module's database
    args = ["--token", token] if token else []
    with homecog_up(home, url, tmp_path / "data", *args) as (base, _):
        report = tmp_path / "junit.xml"
        config = Path(__file__).parent / "schemathesis.toml"  # reads one event of the endless stream
        command = [sys.executable, "-m", "schemathesis.cli", "--config-file", str(config), "run"]
        command += [f"{base}/openapi.json"]
        command += ["--checks", "all", "--max-examples", "50", "--seed", "12", "--request-timeout", "30"]
        command += ["--report", "junit", "--report-junit-path", str(report), "--no-color"]
        if token:
            command += ["--header", f"Authorization: Bearer {token}"]
        run = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert run.returncode == 0, run.stdout[-6000:] + run.stderr[-2000:]
    suite = ET.parse(report).getroot()
    cases = suite.iter("testcase")
    names = sorted(c.get("name", "") for c in cases)
    operations = [n for n in names if n != "Stateful tests"]  # and the stateful phase, where it runs
    assert len(operations) == 14, "\n".join(names)  # every operation
    assert sum(int(s.get("failures", 0)) + int(s.get("errors", 0)) for s in suite.iter("testsuite")) == 0
    assert "No issues found" in run.stdout, run.stdout[-3000:]
