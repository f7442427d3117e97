"""The MQTT context source against a real Mosquitto broker.

The broker is ``$HOMECOG_TEST_MQTT_URL`` or 127.0.0.1:1883 (``.ci/servers.sh`` starts one on CI);
when nothing answers there and ``mosquitto`` is installed, one is started for the session;
otherwise the tests skip, saying why. Each test uses its own random topic prefix.
"""

from __future__ import annotations

import os
import secrets
import socket
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import paho.mqtt.client as mqtt
import pytest
from brokers import mosquitto, mqtt_broker, start_mosquitto
from paho.mqtt.enums import CallbackAPIVersion

from homecog.context.mqtt_broker import command_topic, context_topic, parse_url, state_topic
from homecog.context.mqtt_publisher import MqttPublisher, publish_context
from homecog.context.mqtt_source import MqttSource
from homecog.errors import ContextError, HomecogError, MqttError
from homecog.home import load_home
from homecog.home.codec import Space
from homecog.home.model import Home

TIMEOUT = 10.0  # seconds to wait for anything to arrive

CONTEXT = {
    "time": "21:30",
    "temperature": "25.5",
    "illumination": "300",
    "location": "sofa",
    "posture": "sit",
    "behavior": "read",
    "window": "on",
    "curtain": "off",
    "tv_living": "off",
    "tv_bedroom": "off",
    "ac_living": "off",
    "ac_bedroom": "off",
    "lamp": "off",
    "ceiling_light": "on",
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(condition: Callable[[], object], what: str, timeout: float = TIMEOUT) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.02)


@pytest.fixture(scope="session")
def broker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with mqtt_broker(tmp_path_factory) as url:
        yield url


@pytest.fixture
def home() -> Home:
    return load_home("paper")


@pytest.fixture
def prefix() -> str:
    return f"homecog_test_{secrets.token_hex(6)}"


class Listener:
    """A plain paho client that records what arrives on some topics."""

    def __init__(self, url: str, topic: str) -> None:
        address = parse_url(url)
        self.messages: list[tuple[str, str]] = []
        self._subscribed = threading.Event()
        self.client = mqtt.Client(CallbackAPIVersion.VERSION2)
        self.client.on_connect = lambda c, *a: c.subscribe(topic, qos=1)
        self.client.on_subscribe = lambda *a: self._subscribed.set()
        self.client.on_message = lambda c, u, m: self.messages.append((m.topic, m.payload.decode()))
        self.client.connect(address.host, address.port)
        self.client.loop_start()
        assert self._subscribed.wait(TIMEOUT)

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


def _publish(url: str, topic: str, payload: str, *, retain: bool = True) -> None:
    address = parse_url(url)
    client = mqtt.Client(CallbackAPIVersion.VERSION2)
    client.connect(address.host, address.port)
    client.loop_start()
    try:
        client.publish(topic, payload, qos=1, retain=retain).wait_for_publish(TIMEOUT)
    finally:
        client.disconnect()
        client.loop_stop()


def _clear(url: str, home: Home, prefix: str) -> None:
    """Remove the retained states a test left on the shared broker."""
    address = parse_url(url)
    client = mqtt.Client(CallbackAPIVersion.VERSION2)
    client.connect(address.host, address.port)
    client.loop_start()
    try:
        for name in home.feature_names + home.device_names:
            client.publish(state_topic(home, name, prefix=prefix), b"", qos=1, retain=True).wait_for_publish(
                5
            )
    finally:
        client.disconnect()
        client.loop_stop()


@pytest.fixture
def published(broker: str, home: Home, prefix: str) -> Iterator[str]:
    """Every state of the paper home on the broker, retained, under the test's prefix."""
    publish_context(broker, home, CONTEXT, prefix=prefix)
    yield broker
    _clear(broker, home, prefix)


def test_snapshot_is_what_was_published(published: str, home: Home, prefix: str) -> None:
    with MqttSource(home, published, prefix=prefix) as source:
        snapshot = source.wait_ready(TIMEOUT)
        assert snapshot == CONTEXT
        assert source.ready and source.missing() == [] and source.rejected == 0
        Space(home).point(snapshot)  # a full, valid context


def test_missing_states_are_named(broker: str, home: Home, prefix: str) -> None:
    with MqttSource(home, broker, prefix=prefix) as source:
        assert not source.ready
        with pytest.raises(ContextError, match="no state received yet for time, temperature"):
            source.snapshot()
        _publish(broker, state_topic(home, "time", prefix=prefix), "7:05", retain=False)
        _wait(lambda: "time" not in source.missing(), "the time")
        assert source.missing()[0] == "temperature"


def test_a_change_shows_up_and_the_cognition_changes(published: str, home: Home, prefix: str) -> None:
    changes: list[dict[str, str]] = []
    with MqttSource(home, published, prefix=prefix, on_change=changes.append) as source:
        before = source.wait_ready(TIMEOUT)
        wanted_reading = home.services_to_optimum(*home.discretize(before))

        _publish(published, state_topic(home, "behavior", prefix=prefix), "sleep")
        _wait(lambda: source.snapshot()["behavior"] == "sleep", "behavior sleep")
        after = source.snapshot()
        assert after == {**CONTEXT, "behavior": "sleep"}
        assert changes and changes[-1] == after
        wanted_sleeping = home.services_to_optimum(*home.discretize(after))
        assert wanted_sleeping != wanted_reading

        _publish(published, context_topic(home, prefix=prefix), '{"location": "bed", "posture": "lie"}')
        _wait(lambda: source.snapshot()["location"] == "bed", "location bed")
        assert source.snapshot()["posture"] == "lie"


def test_invalid_payloads_are_rejected_and_counted(published: str, home: Home, prefix: str) -> None:
    with MqttSource(home, published, prefix=prefix) as source:
        source.wait_ready(TIMEOUT)
        bad = [
            ("behavior", "dance"),
            ("temperature", "warm"),
            ("time", "25:99"),
            ("window", "ajar"),
            ("no_such_feature", "1"),
        ]
        for name, payload in bad:
            _publish(published, state_topic(home, name, prefix=prefix), payload, retain=False)
        _publish(published, context_topic(home, prefix=prefix), "not json", retain=False)
        _wait(lambda: source.rejected == len(bad) + 1, "the rejections")
        # the loop still runs: a good value after the bad ones arrives
        _publish(published, state_topic(home, "lamp", prefix=prefix), "on", retain=False)
        _wait(lambda: source.snapshot()["lamp"] == "on", "lamp on")
        assert source.snapshot() == {**CONTEXT, "lamp": "on"}
        assert source.rejected == len(bad) + 1


def test_switch_publishes_a_command(broker: str, home: Home, prefix: str) -> None:
    listener = Listener(broker, command_topic(home, "+", prefix=prefix))
    try:
        with MqttSource(home, broker, prefix=prefix) as source:
            source.switch("window", False)
            source.switch("lamp", True)
            with pytest.raises(ContextError, match="unknown device 'door'"):
                source.switch("door", True)
            _wait(lambda: len(listener.messages) == 2, "the commands")
    finally:
        listener.close()
    assert listener.messages == [
        (f"{prefix}/paper/command/window", "off"),
        (f"{prefix}/paper/command/lamp", "on"),
    ]


def test_the_publisher_carries_commands_to_the_home(broker: str, home: Home, prefix: str) -> None:
    received: list[tuple[str, bool]] = []
    try:
        with MqttPublisher(
            home, broker, prefix=prefix, on_command=lambda d, on: received.append((d, on))
        ) as pub:
            assert pub.publish(CONTEXT) == len(CONTEXT)
            assert pub.publish({**CONTEXT, "lamp": "on"}) == 1  # only what changed
            with MqttSource(home, broker, prefix=prefix) as source:
                source.wait_ready(TIMEOUT)
                # the retained "on" may still be on its way when the source subscribes
                _wait(lambda: source.snapshot()["lamp"] == "on", "the lamp's retained state")
                source.switch("curtain", True)
                _wait(lambda: received, "the command at the publisher")
        assert received == [("curtain", True)]
    finally:
        _clear(broker, home, prefix)


def test_bad_urls_and_unreachable_brokers_are_clear_errors(home: Home) -> None:
    for url, message in [
        ("http://127.0.0.1", "unknown scheme 'http'"),
        ("127.0.0.1:1883", "expected"),
        ("mqtt://", "no host"),
        ("mqtt://127.0.0.1:99999", "MQTT URL"),
        ("mqtt://127.0.0.1/x", "unexpected path"),
    ]:
        with pytest.raises(MqttError, match=message) as e:
            MqttSource(home, url)
        assert isinstance(e.value, HomecogError)
        assert "\n" not in str(e.value)
    assert parse_url("mqtt://u%40x:p@h:1884") == parse_url("mqtt://u%40x:p@h:1884")
    assert parse_url("mqtt://u%40x:p@h:1884").username == "u@x"
    source = MqttSource(home, f"mqtt://127.0.0.1:{_free_port()}", connect_timeout=2)
    started = time.monotonic()
    with pytest.raises(MqttError, match="cannot be reached") as e:
        source.start()
    assert time.monotonic() - started < 5
    assert "\n" not in str(e.value)


def test_reconnects_after_the_broker_comes_back(home: Home, prefix: str, tmp_path: Path) -> None:
    if mosquitto() is None:
        reason = "no mosquitto binary to run a broker that goes away"
        print(reason)
        pytest.skip(reason)
    port = _free_port()
    url = f"mqtt://127.0.0.1:{port}"
    proc = start_mosquitto(port, tmp_path)
    source = MqttSource(home, url, prefix=prefix)
    try:
        source.start()
        publish_context(url, home, CONTEXT, prefix=prefix)
        source.wait_ready(TIMEOUT)
        proc.kill()
        proc.wait(10)
        _wait(lambda: not source.connected, "the source to notice the broker has gone")
        proc = start_mosquitto(port, tmp_path)  # a fresh broker: no retained states
        _wait(lambda: source.connected, "the source to reconnect", timeout=20)
        _publish(url, state_topic(home, "behavior", prefix=prefix), "sleep")
        _wait(lambda: source.snapshot()["behavior"] == "sleep", "a state after the reconnect")
    finally:
        source.stop()
        proc.kill()
        proc.wait(10)


def test_the_running_robot_follows_the_broker_and_sends_each_command_once(broker, tmp_path):
    """homecog up --mqtt in small: states in, the robot's IoT commands out, once per change."""
    from homecog.knowledge.pipeline import build
    from homecog.knowledge.store import Store
    from homecog.robot.runtime import Runtime

    studio = load_home(Path(__file__).parent / "homes" / "studio.yaml")
    prefix = f"homecog_test_{secrets.token_hex(6)}"
    store = Store.open(f"sqlite:///{tmp_path / 'k.sqlite'}", studio)
    tree = build(studio, store).tree
    received: list[tuple[str, str]] = []
    sub = mqtt.Client(CallbackAPIVersion.VERSION2)
    sub.on_message = lambda c, u, m: received.append((m.topic.rsplit("/", 1)[1], m.payload.decode()))
    address = parse_url(broker)
    sub.connect(address.host, address.port)
    sub.subscribe(f"{prefix}/studio/command/#", qos=1)
    sub.loop_start()
    source = MqttSource(studio, broker, prefix=prefix).start()
    try:
        state = {
            "time": "10:00",
            "light": "50",
            "activity": "relax",
            "blind": "off",
            "desk_lamp": "off",
            "radio": "off",
        }
        publish_context(broker, studio, state, prefix=prefix)
        source.wait_ready(5)
        runtime = Runtime(home=studio, store=store, tree=tree, source=source)
        wanted = tree.predict_one(runtime.space.point(state))
        assert "RadioOn" in wanted and "RaiseBlind" in wanted
        for _ in range(3):
            runtime.tick(1)  # the home does not report back: the commands still go once
        deadline = time.monotonic() + 5
        while len(received) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.3)
        assert sorted(received) == [("blind", "on"), ("radio", "on")]
    finally:
        source.stop()
        sub.loop_stop()
        sub.disconnect()
        store.close()


def test_homecog_up_mirrors_the_simulated_home_on_the_broker(broker, tmp_path):
    """``homecog up --publish``: the simulated home's states go out as it lives, and a command
    from the broker switches its device (the home's name, random here, keeps the topics apart)."""
    import json
    import sys
    import urllib.request

    name = f"studio_{secrets.token_hex(4)}"
    text = (Path(__file__).parent / "homes" / "studio.yaml").read_text()
    (tmp_path / "home.yaml").write_text(text.replace("name: studio", f"name: {name}", 1))
    port = _free_port()
    seen: dict[str, list[str]] = {}
    lock = threading.Lock()

    def on_message(client: object, userdata: object, m: mqtt.MQTTMessage) -> None:
        with lock:
            seen.setdefault(m.topic.rsplit("/", 1)[1], []).append(m.payload.decode())

    sub = mqtt.Client(CallbackAPIVersion.VERSION2)
    sub.on_message = on_message
    address = parse_url(broker)
    sub.connect(address.host, address.port)
    sub.subscribe(f"homecog/{name}/state/#", qos=1)
    sub.loop_start()
    env = {**os.environ, "HOMECOG_DATA": str(tmp_path / "data")}
    args = ["up", "--home", str(tmp_path / "home.yaml"), "--port", str(port), "--speed", "600"]
    up = subprocess.Popen(
        [sys.executable, "-m", "homecog.cli.main", *args, "--publish", broker],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
    )
    try:
        _wait(lambda: len(seen.get("time", [])) >= 3, "the simulated clock on the broker", timeout=90)
        with lock:
            assert set(seen) == {"time", "light", "activity", "blind", "desk_lamp", "radio"}
            assert seen["desk_lamp"] == ["off"]
            times = list(seen["time"])
        assert times[:3] == sorted(times[:3]) and len(set(times)) == len(times)  # ten minutes a second
        _publish(broker, f"homecog/{name}/command/desk_lamp", "on", retain=False)
        _wait(lambda: seen["desk_lamp"][-1] == "on", "the switched desk lamp's state")
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/context", timeout=5) as r:
            assert json.load(r)["desk_lamp"] == "on"
    finally:
        up.terminate()
        out = up.communicate(timeout=20)[0].decode()
        sub.loop_stop()
        sub.disconnect()
        _clear(broker, load_home(tmp_path / "home.yaml"), "homecog")
    assert f"homecog/{name}/state/<name>" in out.replace("\n", "")  # rich folds long lines


def test_publish_needs_the_simulator():
    from homecog.cli.main import main

    assert main(["up", "--publish", "mqtt://127.0.0.1:1883", "--mqtt", "mqtt://127.0.0.1:1883"]) == 2
    assert main(["up", "--publish", "mqtt://127.0.0.1:1883", "--speed", "0"]) == 2
