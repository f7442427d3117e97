"""A home's context published to an MQTT broker as a real home would (:class:`MqttPublisher`,
retained state topics), the robot's commands from it handed on; and one context published once
(:func:`publish_context`).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as mqtt

from homecog.context.limited_log import LimitedWarnings
from homecog.context.mqtt_broker import (
    CONNECT_TIMEOUT,
    DEFAULT_PREFIX,
    BrokerClient,
    command_topic,
    state_topic,
)
from homecog.errors import ContextError, one_line
from homecog.home.codec import normalize
from homecog.home.model import Home
from homecog.home.states import parse_state

log = logging.getLogger(__name__)


@dataclass(eq=False, repr=False, kw_only=True)
class MqttPublisher(BrokerClient):
    """Publishes a home's context to a broker (retained state topics), as a real home would;
    the simulated home uses it. Commands the robot publishes are handed to ``on_command``; the
    other parameters are :class:`~homecog.context.mqtt_broker.BrokerClient`'s.

    Against a broker (not run as a doctest)::

        sim = SimulatedHome(load_home("paper"))
        pub = MqttPublisher(sim.home, "mqtt://127.0.0.1:1883", on_command=sim.switch).start()
        pub.publish(sim.snapshot())     # only values that changed since the last call go out
        pub.stop()
    """

    on_command: Callable[[str, bool], None] | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self.warnings = LimitedWarnings(log)  # at most so many a minute, whatever the broker sends
        self._published: dict[str, str] = {}
        self._pending: list[mqtt.MQTTMessageInfo] = []
        self._lock = threading.Lock()  # publish is called from the simulation and paho threads

    def flush(self, timeout: float = CONNECT_TIMEOUT) -> bool:
        """Wait (at most ``timeout`` s) until the broker has every published value."""
        deadline = time.monotonic() + timeout
        while self._pending:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            try:
                self._pending[0].wait_for_publish(left)
            except (RuntimeError, ValueError):  # not queued: the broker is away; it goes out later
                return False
            if not self._pending[0].is_published():
                return False
            self._pending.pop(0)
        return True

    def stop(self) -> None:
        """Send what is still queued, then disconnect (retained states stay on the broker)."""
        if self._client is not None and self._connected.is_set():
            self.flush()
        self._close()

    def publish(self, snapshot: Mapping[str, object], *, everything: bool = False) -> int:
        """Publish the values of ``snapshot`` that changed since the last call (all of them with
        ``everything``) to their retained state topics; returns how many went out."""
        if self._client is None:
            raise ContextError("MQTT publisher not started; call start() first")
        sent = 0
        with self._lock:
            self._pending = [m for m in self._pending if not m.is_published()]
            for name, value in snapshot.items():
                text = normalize(self.home, name, value)
                if everything or self._published.get(name) != text:
                    topic = state_topic(self.home, name, prefix=self.prefix)
                    self._pending.append(self._client.publish(topic, text, qos=1, retain=True))
                    self._published[name] = text
                    sent += 1
        return sent

    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any) -> None:
        if self._refused(reason):
            return
        if self.on_command is None:
            self._connected.set()
        else:  # connected once subscribed to the commands (see _on_subscribe)
            client.subscribe(command_topic(self.home, "+", prefix=self.prefix), qos=1)

    def _on_message(self, client: mqtt.Client, userdata: Any, message: mqtt.MQTTMessage) -> None:
        device = message.topic.rsplit("/", 1)[1]
        try:
            on = parse_state(message.payload.decode("utf-8", "replace"), device)
            if device not in self.home.device_names:
                raise ContextError(f"unknown device {device!r}")
            if self.on_command is not None:
                self.on_command(device, on)
        except Exception as e:
            self.warnings.warning("MQTT command on %s ignored: %s", message.topic, one_line(str(e), 200))


def publish_context(
    url: str, home: Home, snapshot: Mapping[str, object], *, prefix: str = DEFAULT_PREFIX
) -> None:
    """Publish a whole context once (retained state topics) and disconnect."""
    with MqttPublisher(home, url, prefix=prefix) as publisher:
        publisher.publish(snapshot, everything=True)
