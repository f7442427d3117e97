"""A broker's password is never shown; a flood of unknown keys is never a flood of log lines."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from brokers import mosquitto, start_mosquitto

from homecog.cli.up import OUTSIDE
from homecog.context.mqtt_broker import parse_url, redact_url
from homecog.errors import MqttError
from homecog.home import load_home

HOMES = Path(__file__).parent / "homes"
SECRET = "s3cret-Pw"


# -- 7. the broker's password ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("url", "why"),
    [
        (f"mqtt://robot:{SECRET}@host:99999", "a port that is no number from 0 to 65535"),
        ("mqtt://robot:pa/ss@host", "a port that is no number from 0 to 65535"),
        (f"mqtt://robot:{SECRET}@[::1", "not a URL"),
        (f"http://robot:{SECRET}@host", "unknown scheme 'http'"),
        (f"mqtt://robot:{SECRET}@/x", "no host"),
        (f"mqtt://robot:{SECRET}@host/p?q", "unexpected path or query"),
        (f"robot:{SECRET}@host", "unknown scheme 'robot'"),
    ],
)
def test_a_bad_broker_url_is_refused_without_its_password(url, why):
    with pytest.raises(MqttError) as e:
        parse_url(url)
    assert str(e.value).startswith(f"MQTT URL {redact_url(url)!r}: {why}")
    assert SECRET not in str(e.value) and "pa/ss" not in str(e.value) and "***" in str(e.value)


def test_an_address_does_not_show_its_password():
    address = parse_url(f"mqtt://robot:{SECRET}@broker.local")
    assert address.password == SECRET
    assert SECRET not in repr(address) and SECRET not in str(address)


def test_what_up_says_of_a_broker_holds_no_password():
    said = OUTSIDE["mqtt"].said(load_home("paper"), f"mqtt://robot:{SECRET}@broker.local:1883", None)
    assert said.startswith("context from mqtt://robot:***@broker.local:1883: topics homecog/paper/state/")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.skipif(mosquitto() is None, reason="no mosquitto to start a broker")
def test_homecog_up_never_prints_the_broker_password(tmp_path):
    """``homecog up --publish mqtt://robot:PASSWORD@host`` printed the URL whole, twice."""
    port = _free_port()
    broker = start_mosquitto(port, tmp_path)
    url = f"mqtt://robot:{SECRET}@127.0.0.1:{port}"
    env = {**os.environ, "HOMECOG_DATA": str(tmp_path / "data"), "COLUMNS": "300"}
    args = ["up", "--home", str(HOMES / "studio.yaml"), "--port", str(_free_port()), "--publish", url]
    up = subprocess.Popen(
        [sys.executable, "-m", "homecog.cli.main", *args],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        lines = []
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            line = up.stdout.readline()
            if not line:
                break
            lines.append(line)
            if "homecog is up" in line:
                break
    finally:
        up.terminate()
        rest = up.communicate(timeout=30)[0]
        broker.terminate()
        broker.wait(10)
    out = "".join(lines) + rest
    assert "homecog is up" in out, out
    assert SECRET not in out
    assert f"the simulated home on mqtt://robot:***@127.0.0.1:{port}" in out
    assert f"MQTT discovery on mqtt://robot:***@127.0.0.1:{port}" in out


# -- 8. a flood of unknown names ------------------------------------------------------------------------
class Message:
    """What paho hands the source: a topic and a payload."""

    def __init__(self, topic: str, payload: bytes) -> None:
        self.topic, self.payload = topic, payload


@pytest.fixture
def source():
    from homecog.context.mqtt_source import MqttSource

    return MqttSource(load_home("paper"), "mqtt://127.0.0.1:1")  # never started: no broker needed


def records(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == "homecog.context.mqtt_source"]


def test_one_message_of_200000_unknown_names_is_one_warning(source, caplog):
    """It wrote 200,000 lines, one per name."""
    import json

    values = {f"k{i}": 1 for i in range(200_000)} | {"behavior": "sleep", "lamp": "maybe"}
    start = time.perf_counter()
    with caplog.at_level("WARNING"):
        source._on_message(None, None, Message("homecog/paper/context", json.dumps(values).encode()))
    assert time.perf_counter() - start < 2
    assert records(caplog) == [
        "MQTT homecog/paper/context: ignored 200,000 unknown names ('k0', 'k1', 'k2', 'k3', 'k4', … "
        "(199,995 more)); 'maybe' for lamp: lamp: unknown state 'maybe'; expected on or off"
    ]
    assert source.rejected == 200_001
    assert source._values == {"behavior": "sleep"}  # what fits is taken


def test_at_most_ten_warnings_a_minute(source, caplog):
    now = [0.0]
    source.warnings.clock = lambda: now[0]
    with caplog.at_level("WARNING"):
        for i in range(100):
            now[0] = i * 0.5  # 100 messages in 50 s
            source._on_message(None, None, Message(f"homecog/paper/state/nothing{i}", b"1"))
        assert len(records(caplog)) == 10
        now[0] = 61.0
        source._on_message(None, None, Message("homecog/paper/state/lamp", b"maybe"))
    assert records(caplog)[-1] == (
        "MQTT homecog/paper/state/lamp: ignored 'maybe' for lamp: lamp: unknown state 'maybe'; "
        "expected on or off (and 90 more such warnings not logged)"
    )
    assert len(records(caplog)) == 11 and source.rejected == 101


def test_a_message_past_its_size_is_not_read(source, caplog):
    with caplog.at_level("WARNING"):
        source._on_message(None, None, Message("homecog/paper/context", b"{" + b" " * (4 * 1024 * 1024)))
    assert records(caplog) == [
        "MQTT homecog/paper/context: ignored a message of 4,194,305 bytes, over the 4,194,304 a message "
        "may have"
    ]


def test_the_mirror_s_bad_commands_are_limited_alike(caplog):
    from homecog.context.mqtt_publisher import MqttPublisher

    switched = []
    mirror = MqttPublisher(
        load_home("paper"), "mqtt://127.0.0.1:1", on_command=lambda d, on: switched.append(d)
    )
    with caplog.at_level("WARNING"):
        for _ in range(100):
            mirror._on_message(None, None, Message("homecog/paper/command/lamp", b"x" * 100_000))
        mirror._on_message(None, None, Message("homecog/paper/command/lamp", b"on"))
    lines = [r.getMessage() for r in caplog.records if r.name == "homecog.context.mqtt_publisher"]
    assert len(lines) == 10 and all(len(line) < 300 for line in lines), lines[0]
    assert switched == ["lamp"]
