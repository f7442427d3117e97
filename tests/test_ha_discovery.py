"""homecog in Home Assistant by MQTT discovery, against the real Home Assistant
2024.3.3 with its MQTT integration on the real Mosquitto broker: the entities appear there with
the robot's state (its services, what it did last), the home's devices as switches, pressing
undo there undoes the robot's last action (learned as a rejection), a switch from the app is a
person's switch, and the entities leave when the robot stops cleanly.

The robot follows the studio (a context set by hand, mirrored on the broker as ``homecog up
--publish`` mirrors the simulated home) under a topic prefix of the module's own. The times
from the robot's decision to Home Assistant's state, and from a press of undo to the rejection
learned, are measured and printed (``bin/bench discovery`` for the figures).
"""

from __future__ import annotations

import dataclasses
import json
import os
import secrets
import statistics
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import paho.mqtt.client as mqtt
import pytest
from brokers import mqtt_broker
from home_assistant import HomeAssistant, StateChanges, enable_mqtt, running_home_assistant
from paho.mqtt.enums import CallbackAPIVersion

from homecog.context.ha_discovery import HomeAssistantDiscovery
from homecog.context.manual import ManualSource
from homecog.context.mqtt_broker import parse_url
from homecog.context.mqtt_publisher import MqttPublisher
from homecog.home import Home, load_home
from homecog.knowledge.history import correction_history
from homecog.knowledge.pipeline import build
from homecog.knowledge.store import Store
from homecog.robot.announce import announce
from homecog.robot.runtime import Runtime

HOMES = Path(__file__).parent / "homes"
TIMEOUT = 10.0
PRESSES = int(os.environ.get("HOMECOG_TEST_PRESSES", "6"))  # undos timed (more for the figures)
WORK = {
    "time": "10:00",
    "light": "300",
    "activity": "work",
    "blind": "on",
    "desk_lamp": "off",
    "radio": "off",
}
pytestmark = pytest.mark.xdist_group("ha_discovery")  # one Home Assistant for the module


def wait(condition: Callable[[], object], what: str, timeout: float = TIMEOUT) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.002)


def percentile95(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]


@dataclass
class Instance:
    server: HomeAssistant
    broker: str
    changes: StateChanges


@pytest.fixture(scope="module")
def ha(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Instance]:
    with mqtt_broker(tmp_path_factory) as url, running_home_assistant(tmp_path_factory) as server:
        enable_mqtt(server, url)
        with StateChanges(server, server.owner_token) as changes:
            yield Instance(server, url, changes)


@dataclass
class Robot:
    home: Home
    runtime: Runtime
    store: Store
    source: ManualSource
    discovery: HomeAssistantDiscovery
    mirror: MqttPublisher
    prefix: str
    decided: list[tuple[float, list[str]]]

    def entity(self, component: str, key: str) -> str:
        return f"{component}.{self.prefix}_{self.home.name}_{key}"


@pytest.fixture
def robot(ha: Instance, tmp_path: Path) -> Iterator[Robot]:
    """The robot of the studio, announced to Home Assistant (as ``homecog up --publish`` does),
    under a prefix of its own; every decision's moment recorded before it is announced."""
    home = load_home(HOMES / "studio.yaml")
    prefix = f"homecog_t{secrets.token_hex(4)}"
    store = Store.open(f"sqlite:///{tmp_path / 'k.sqlite'}", home)
    source = ManualSource(home)
    source.set_context(WORK)
    household = dataclasses.replace(home.household, hold=0.0)  # the person's hold ends with the situation
    runtime = Runtime(
        home=home, store=store, tree=build(home, store).tree, source=source, household=household
    )
    decided: list[tuple[float, list[str]]] = []
    runtime.announcers.append(
        lambda kind, data: (
            decided.append((time.perf_counter(), data["services"])) if kind == "decision" else None
        )
    )
    mirror = MqttPublisher(home, ha.broker, prefix=prefix, on_command=runtime.switch).start()
    mirror.publish(source.snapshot(), everything=True)
    runtime.watchers.append(mirror.publish)
    discovery = announce(runtime, ha.broker, prefix=prefix).start()
    made = Robot(home, runtime, store, source, discovery, mirror, prefix, decided)
    try:
        yield made
    finally:
        discovery.stop()
        mirror.stop()
        clear(ha.broker, [f"{prefix}/{home.name}/state/{n}" for n in home.feature_names + home.device_names])
        store.close()


def available(ha: Instance, entity: str) -> bool:
    """Whether Home Assistant has the entity, available: it carries out no call on one that is not."""
    return (state(ha, entity) or {}).get("state", "unavailable") != "unavailable"


def state(ha: Instance, entity: str) -> dict[str, Any] | None:
    try:
        return ha.server.state(ha.server.owner_token, entity)
    except Exception:  # 404: no such entity (yet)
        return None


def clear(url: str, topics: list[str]) -> None:
    """No retained message left on ``topics``."""
    client = mqtt.Client(CallbackAPIVersion.VERSION2)
    address = parse_url(url)
    client.connect(address.host, address.port)
    client.loop_start()
    for sent in [client.publish(t, b"", qos=1, retain=True) for t in topics]:
        sent.wait_for_publish(TIMEOUT)
    client.disconnect()
    client.loop_stop()


def retained_configs(url: str, node: str) -> dict[str, dict[str, Any]]:
    """The discovery configs the broker keeps for ``node``, by topic."""
    found: dict[str, dict[str, Any]] = {}
    subscribed = threading.Event()
    client = mqtt.Client(CallbackAPIVersion.VERSION2)
    client.on_connect = lambda c, *a: c.subscribe(f"homeassistant/+/{node}/+/config", qos=1)
    client.on_subscribe = lambda *a: subscribed.set()
    client.on_message = lambda c, u, m: (
        found.__setitem__(m.topic, json.loads(m.payload)) if m.payload else None
    )
    address = parse_url(url)
    client.connect(address.host, address.port)
    client.loop_start()
    subscribed.wait(TIMEOUT)
    time.sleep(0.3)  # retained messages arrive right after the subscription
    client.disconnect()
    client.loop_stop()
    return found


def test_every_entity_appears_with_a_unique_id_and_a_device(ha: Instance, robot: Robot) -> None:
    node = f"{robot.prefix}_studio"
    configs = retained_configs(ha.broker, node)
    keys = ["services", "last_action", "undo", "blind", "desk_lamp", "radio"]
    assert sorted(c["unique_id"] for c in configs.values()) == sorted(f"{node}_{k}" for k in keys)
    for config in configs.values():
        assert config["device"]["identifiers"] and config["availability_topic"].endswith(
            "/robot/availability"
        )
    switch = configs[f"homeassistant/switch/{node}/radio/config"]
    assert (switch["state_topic"], switch["command_topic"]) == (
        f"{robot.prefix}/studio/state/radio",
        f"{robot.prefix}/studio/command/radio",
    )
    # Home Assistant made every one an entity of the robot's or the home's device
    wait(lambda: state(ha, robot.entity("switch", "radio")) is not None, "the entities in Home Assistant")
    entities = ha.server.ws(ha.server.owner_token, "config/entity_registry/list")
    ours = {
        e["unique_id"]: e for e in entities if e["platform"] == "mqtt" and e["unique_id"].startswith(node)
    }
    assert sorted(ours) == sorted(f"{node}_{k}" for k in keys)
    devices = {d["id"]: d for d in ha.server.ws(ha.server.owner_token, "config/device_registry/list")}
    owners = {k: devices[e["device_id"]]["name"] for k, e in ours.items()}
    assert owners == {
        **{f"{node}_{k}": "homecog robot (studio)" for k in ("services", "last_action", "undo")},
        **{f"{node}_{d}": "studio (homecog)" for d in ("blind", "desk_lamp", "radio")},
    }
    home_device = devices[ours[f"{node}_radio"]["device_id"]]
    assert home_device["via_device_id"] == ours[f"{node}_undo"]["device_id"]
    # available, the home's devices as the mirrored home has them
    switches = [robot.entity("switch", d) for d in ("blind", "desk_lamp", "radio")]
    wait(
        lambda: [(state(ha, e) or {}).get("state") for e in switches] == ["on", "off", "off"],
        "the switches' states",
    )


def test_the_robots_services_are_its_state_there(ha: Instance, robot: Robot) -> None:
    runtime, sensor = robot.runtime, robot.entity("sensor", "services")
    wait(lambda: available(ha, sensor), "the services sensor in Home Assistant")
    took = []
    for n in range(3):  # relaxing with the radio off: tea and the radio; once it is on, tea
        # two hours apart: the robot switches a device at most twice an hour
        robot.source.clock = lambda k=n: time.time() + 7200 * k  # type: ignore[method-assign]
        since, decisions = ha.changes.count(), len(robot.decided)
        robot.source.set_context({"activity": "relax", "light": str(300 + n), "radio": "off"})
        runtime.act_now("default")  # it switches the radio on, then decides anew
        made = robot.decided[decisions:]
        assert [s for _, s in made][-2:] == [["BringTea", "RadioOn"], ["BringTea"]]
        for at, services in made:

            def shown(since: int = since, text: str = ", ".join(services)) -> Any:
                return next((t for t, s in ha.changes.of(sensor, since) if s and s["state"] == text), None)

            wait(shown, f"{sensor} = {services}")
            took.append(shown() - at)
    assert [s for _, s in robot.decided[-2:]] == [["BringTea", "RadioOn"], ["BringTea"]]
    wait(lambda: state(ha, sensor)["state"] == "BringTea", "the services after the radio is on")
    now = state(ha, sensor)
    assert now["attributes"]["services"] == ["BringTea"] and now["attributes"]["user"] == "default"
    expected = runtime.cognize(robot.source.snapshot(), "default")["explanations"]
    assert [e["service"] for e in now["attributes"]["explanations"]] == ["BringTea"]
    assert now["attributes"]["explanations"] == [e for e in expected if e["service"] == "BringTea"]
    # the robot switched the radio on: what it did last, and the radio's switch, say so
    last = state(ha, robot.entity("sensor", "last_action"))
    assert last["state"] == "RadioOn" and last["attributes"]["switches"] == [
        {"device": "radio", "state": "on"}
    ]
    wait(
        lambda: state(ha, robot.entity("switch", "radio"))["state"] == "on", "the radio on in Home Assistant"
    )
    ms = [1000 * t for t in took]
    print(
        f"\ndiscovery: the robot's services in Home Assistant {statistics.median(ms):.1f} ms after its "
        f"decision (median of {len(ms)}; max {max(ms):.1f} ms)",
        file=sys.stderr,
    )


def test_undo_pressed_in_home_assistant_undoes_the_last_action_and_is_learned(
    ha: Instance, robot: Robot
) -> None:
    runtime, button = robot.runtime, robot.entity("button", "undo")
    wait(lambda: available(ha, button), "the undo button in Home Assistant")
    took = []
    for n in range(1, PRESSES + 1):
        # a situation other than the last undo's, where the robot switches the radio on, two
        # hours after the last (the robot switches a device at most twice an hour)
        robot.source.clock = lambda k=n: time.time() + 7200 * k  # type: ignore[method-assign]
        robot.source.set_context({"activity": ["relax", "work"][n % 2]})
        acted = runtime.act(robot.source.snapshot(), ["RadioOn"])
        assert acted is not None and robot.source.snapshot()["radio"] == "on"
        runtime.act(robot.source.snapshot(), [])  # the robot looks at the home, as every tick does
        action = runtime.journal.recent(1)[0]
        began = time.perf_counter()
        ha.server.call(ha.server.owner_token, "button.press", button)  # a person, in the app
        wait(lambda n=n: runtime.guidance.counts["undo"] == n, f"undo {n} learned")
        took.append(time.perf_counter() - began)
        assert robot.source.snapshot()["radio"] == "off"  # switched back
        assert action.undone_here and action.undone == {"radio": "hmi"}
    undos = [c for c in correction_history(robot.store).corrections if c.kind == "undo"]
    assert len(undos) == PRESSES and {(c.user, tuple(c.concerns or ())) for c in undos} == {
        ("default", ("RadioOn",))
    }
    # what it did last, as Home Assistant shows it: undone
    wait(
        lambda: state(ha, robot.entity("sensor", "last_action"))["attributes"].get("undone_here") is True,
        "the last action shown undone",
    )
    ms = sorted(1000 * t for t in took)
    print(
        f"\ndiscovery: undo pressed in Home Assistant learned after median {statistics.median(ms):.1f} ms, "
        f"p95 {percentile95(ms):.1f} ms (of {len(ms)})",
        file=sys.stderr,
    )


def test_a_switch_from_the_app_is_a_persons_switch(ha: Instance, robot: Robot) -> None:
    runtime = robot.runtime
    wait(lambda: available(ha, robot.entity("switch", "radio")), "the radio's switch")
    ha.server.call(ha.server.owner_token, "switch.turn_on", robot.entity("switch", "radio"))
    wait(lambda: runtime.guidance.counts["observed"] == 1, "the person's switch learned")
    assert robot.source.snapshot()["radio"] == "on"
    [c] = correction_history(robot.store).corrections
    assert (c.kind, c.want, c.note) == ("observed", ["RadioOn"], {"device": "radio", "state": "on"})


def test_the_entities_leave_when_the_robot_stops(ha: Instance, robot: Robot) -> None:
    node, sensor = f"{robot.prefix}_studio", robot.entity("sensor", "services")
    robot.runtime.act_now("default")
    wait(lambda: (state(ha, sensor) or {}).get("state") == "BringTea", "the services sensor")
    robot.discovery.stop()
    assert retained_configs(ha.broker, node) == {}
    wait(lambda: state(ha, sensor) is None, "the services sensor gone from Home Assistant")
    entities = ha.server.ws(ha.server.owner_token, "config/entity_registry/list")
    assert [e["unique_id"] for e in entities if e["unique_id"].startswith(node)] == []
