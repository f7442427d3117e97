"""homecog announced to Home Assistant by MQTT discovery: the robot and the home's
devices appear in Home Assistant's app without any configuration there, as Zigbee2MQTT's or
ESPHome's devices do.

Retained discovery configs go under ``homeassistant/<component>/<node>/<object>/config``
(``<node>`` is ``<prefix>_<home>``, e.g. ``homecog_paper``), each with a ``unique_id``, a
``device`` and the availability topic ``PREFIX/HOME/robot/availability`` (``online`` while
homecog runs; the broker's last will sets it ``offline`` if homecog dies):

================================  ============================================================
entity                            topics
================================  ============================================================
sensor ``Services``               ``PREFIX/HOME/robot/services``: the services the robot
                                  proposes now, comma-separated (``none``); attributes on
                                  ``…/services/attributes``: the list, the user, the
                                  explanations and when it decided
sensor ``Last action``            ``PREFIX/HOME/robot/action``: the services it carried out
                                  last; attributes on ``…/action/attributes``: the action as
                                  ``GET /api/actions`` has it (id, switches, why, undone)
button ``Undo last action``       pressed, Home Assistant publishes ``undo`` to
                                  ``PREFIX/HOME/robot/undo``: the robot's last action is
                                  undone, as from the HMI (switched back, learned as a rejection)
switch per device of the home     the home's own topics: state ``PREFIX/HOME/state/<device>``,
                                  commands ``PREFIX/HOME/command/<device>`` (``on``/``off``);
                                  a switch from the app is a person's switch
================================  ============================================================

The robot's entities belong to the Home Assistant device "homecog robot (HOME)", the home's
switches to the device "HOME (homecog)". When homecog stops cleanly every config and state it
published is removed (empty retained payloads), so the entities leave Home Assistant with it.

The payloads need no broker:

>>> from homecog.home import load_home
>>> configs = discovery_configs(load_home("paper"))
>>> topic, config = next(iter(configs.items()))
>>> topic, config["unique_id"], config["state_topic"], config["device"]["name"]
('homeassistant/sensor/homecog_paper/services/config', 'homecog_paper_services', \
'homecog/paper/robot/services', 'homecog robot (paper)')
>>> sorted({t.split("/")[1] for t in configs}), len(configs)      # 3 of the robot, 8 devices
(['button', 'sensor', 'switch'], 11)
"""

from __future__ import annotations

import concurrent.futures
import json
import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import paho.mqtt.client as mqtt

from homecog.context.limited_log import LimitedWarnings
from homecog.context.mqtt_broker import DEFAULT_PREFIX, BrokerClient, command_topic, state_topic
from homecog.home.model import Home

log = logging.getLogger(__name__)

DISCOVERY_PREFIX = "homeassistant"
STATE_LIMIT = 255  # Home Assistant keeps no longer state; the whole list is an attribute
ONLINE, OFFLINE, PRESS = "online", "offline", "undo"


def robot_topic(home: Home, name: str, *, prefix: str = DEFAULT_PREFIX) -> str:
    """A topic of the robot's own: ``PREFIX/HOME/robot/<name>``."""
    return f"{prefix}/{home.name}/robot/{name}"


def discovery_configs(
    home: Home, *, prefix: str = DEFAULT_PREFIX, discovery_prefix: str = DISCOVERY_PREFIX
) -> dict[str, dict[str, Any]]:
    """Every discovery config by its topic: the robot's services, last action and undo button,
    and a switch for each device of the home."""
    node = f"{prefix}_{home.name}"
    from homecog import __version__

    robot = {
        "identifiers": [f"{node}_robot"],
        "name": f"homecog robot ({home.name})",
        "manufacturer": "homecog",
        "model": "home service robot",
        "sw_version": __version__,
    }
    house = {
        "identifiers": [f"{node}_home"],
        "name": f"{home.name} (homecog)",
        "manufacturer": "homecog",
        "model": "home",
        "via_device": f"{node}_robot",
    }
    available = {
        "availability_topic": robot_topic(home, "availability", prefix=prefix),
        "payload_available": ONLINE,
        "payload_not_available": OFFLINE,
    }

    def entity(component: str, key: str, device: dict[str, Any], **fields: Any) -> tuple[str, dict[str, Any]]:
        uid = f"{node}_{key}"
        config = {"unique_id": uid, "object_id": uid, "device": device, **available, **fields}
        return f"{discovery_prefix}/{component}/{node}/{key}/config", config

    sensors = (  # key, name, icon, the topic of its state (and of its attributes below it)
        ("services", "Services", "mdi:robot", "services"),
        ("last_action", "Last action", "mdi:robot-happy", "action"),
    )
    out = dict(
        entity(
            "sensor",
            key,
            robot,
            name=name,
            icon=icon,
            state_topic=robot_topic(home, topic, prefix=prefix),
            json_attributes_topic=robot_topic(home, f"{topic}/attributes", prefix=prefix),
        )
        for key, name, icon, topic in sensors
    )
    undo = robot_topic(home, "undo", prefix=prefix)
    topic, config = entity(
        "button",
        "undo",
        robot,
        name="Undo last action",
        icon="mdi:undo",
        command_topic=undo,
        payload_press=PRESS,
    )
    out[topic] = config
    for device in home.devices:
        topic, config = entity(
            "switch",
            device.name,
            house,
            name=device.name.replace("_", " "),
            state_topic=state_topic(home, device.name, prefix=prefix),
            command_topic=command_topic(home, device.name, prefix=prefix),
            payload_on="on",
            payload_off="off",
            state_on="on",
            state_off="off",
        )
        out[topic] = config
    return out


def services_state(services: list[str]) -> str:
    """The services sensor's state: the names, comma-separated, within Home Assistant's limit.

    >>> services_state([]), services_state(["TurnOnLamp", "CloseWindow"])
    ('none', 'TurnOnLamp, CloseWindow')
    >>> len(services_state([f"Service{i}" for i in range(100)]))
    255
    """
    text = ", ".join(services) or "none"
    return text if len(text) <= STATE_LIMIT else text[: STATE_LIMIT - 1] + "…"


@dataclass(eq=False, repr=False, kw_only=True)
class HomeAssistantDiscovery(BrokerClient):
    """homecog on a broker for Home Assistant: the discovery configs, the robot's state, and the
    undo button's presses handed to ``on_undo`` (on a worker thread of its own; what it returns,
    the action after the undo, becomes the last action's state); the discovery configs go under
    ``discovery_prefix``, and the other parameters are
    :class:`~homecog.context.mqtt_broker.BrokerClient`'s. Once connected it publishes every
    config and ``online`` (again after every reconnection); ``start(wait=False)`` connects in the
    background, as long as it takes: the robot does not wait for an app.

    Against a broker (not run as a doctest)::

        discovery = HomeAssistantDiscovery(home, "mqtt://127.0.0.1:1883", on_undo=undo).start()
        discovery.services(["CloseWindow"], explanations=[...], user="default")
        discovery.stop()        # the configs removed: the entities leave Home Assistant
    """

    on_undo: Callable[[], Mapping[str, Any] | None] | None = None
    discovery_prefix: str = DISCOVERY_PREFIX

    def __post_init__(self) -> None:
        super().__post_init__()
        self.warnings = LimitedWarnings(log)  # at most so many a minute, whatever the broker sends
        home, prefix = self.home, self.prefix
        self.configs = discovery_configs(home, prefix=prefix, discovery_prefix=self.discovery_prefix)
        self.presses = 0
        self._availability = robot_topic(home, "availability", prefix=prefix)
        self._undo_topic = robot_topic(home, "undo", prefix=prefix)
        self._status_topic = f"{self.discovery_prefix}/status"  # Home Assistant's birth and last will
        self._states: dict[str, str] = {}  # the robot's state topics, as last published
        self._lock = threading.Lock()
        self._worker = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="homecog-undo")

    # -- the connection ---------------------------------------------------------------------------
    def _prepare(self, client: mqtt.Client) -> None:
        """The broker's last will: ``offline`` when homecog goes without stopping."""
        client.will_set(self._availability, OFFLINE, qos=1, retain=True)

    def _closing(self, client: mqtt.Client | None) -> None:
        """Remove every config and state published (empty retained payloads) before saying
        ``offline``: the entities leave Home Assistant."""
        self._worker.shutdown(wait=True)
        if client is None or not self._connected.is_set():
            return
        with self._lock:
            topics = [*self.configs, *self._states]
        sent = [client.publish(t, b"", qos=1, retain=True) for t in topics]
        sent.append(client.publish(self._availability, b"", qos=1, retain=True))
        deadline = time.monotonic() + self.connect_timeout
        for message in sent:
            message.wait_for_publish(max(deadline - time.monotonic(), 0.01))

    # -- the robot's state ----------------------------------------------------------------------
    def services(self, services: list[str], *, explanations: list[Any], user: str) -> None:
        """The services the robot proposes now, and why."""
        attributes = {
            "services": services,
            "user": user,
            "explanations": explanations,
            "decided_at": datetime.now(UTC).isoformat(timespec="milliseconds"),
        }
        self._state("services", services_state(services), attributes)

    def action(self, action: Mapping[str, Any]) -> None:
        """What the robot did last (an action as the journal has it)."""
        self._state("action", services_state(list(action.get("services", []))), dict(action))

    def _state(self, name: str, state: str, attributes: dict[str, Any]) -> None:
        """Publish the attributes first, then the state (retained): whoever sees the new state
        finds its attributes there."""
        client = self._client
        if client is None:
            return
        text = json.dumps(attributes, default=str)
        topics = (
            robot_topic(self.home, f"{name}/attributes", prefix=self.prefix),
            robot_topic(self.home, name, prefix=self.prefix),
        )
        with self._lock:
            for topic, payload in zip(topics, (text, state), strict=True):
                if self._states.get(topic) != payload:
                    client.publish(topic, payload, qos=1, retain=True)
                    self._states[topic] = payload

    # -- paho's callbacks (its network thread) ---------------------------------------------------
    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any) -> None:
        if self._refused(reason):
            return
        self._announce(client)
        with self._lock:  # after a reconnection, the robot's state again
            for topic, payload in self._states.items():
                client.publish(topic, payload, qos=1, retain=True)
        client.subscribe([(self._undo_topic, 1), (self._status_topic, 1)])

    def _announce(self, client: mqtt.Client) -> None:
        for topic, config in self.configs.items():
            client.publish(topic, json.dumps(config), qos=1, retain=True)
        client.publish(self._availability, ONLINE, qos=1, retain=True)

    def _on_message(self, client: mqtt.Client, userdata: Any, message: mqtt.MQTTMessage) -> None:
        payload = message.payload.decode("utf-8", "replace")
        if message.topic == self._status_topic:
            if payload == ONLINE:  # Home Assistant (re)started: its birth message
                self._announce(client)
            return
        if payload != PRESS:
            self.warnings.warning("MQTT: %r on %s ignored; expected %r", payload[:40], message.topic, PRESS)
            return
        self.presses += 1
        if self.on_undo is not None:
            try:
                self._worker.submit(self._undo)
            except RuntimeError:  # stopping: no more undos
                log.info("MQTT: an undo pressed while homecog stops, ignored")

    def _undo(self) -> None:
        try:
            action = self.on_undo() if self.on_undo is not None else None
        except Exception:
            log.exception("the undo from Home Assistant failed")
            return
        if action is not None:
            self.action(action)
