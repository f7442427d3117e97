"""The context of a home followed on an MQTT broker (:class:`MqttSource`), and the robot's
switches published to it as commands.

The topic layout is :mod:`homecog.context.mqtt_broker`'s. A value that does not fit the home (an
unknown category, not a number, outside every bin, a name the home does not have) is ignored and
counted in :attr:`MqttSource.rejected`, with one logged warning per message however many it
ignores, and at most :data:`~homecog.context.limited_log.PER_MINUTE` such warnings a minute
(:mod:`homecog.context.limited_log`): one message of 200,000 unknown names wrote 200,000 lines.
A message is at most :data:`MAX_PAYLOAD` bytes. A broker that goes away is reconnected to (with a
growing delay, at most :data:`~homecog.context.mqtt_broker.MAX_RECONNECT_DELAY` seconds) and the
topics are subscribed to again; retained states arrive anew.

Against a broker (not run as a doctest)::

    source = MqttSource(load_home("paper"), "mqtt://127.0.0.1:1883", on_change=print)
    source.start()                      # raises MqttError when the broker cannot be reached
    source.wait_ready(10)               # every feature and device received
    source.snapshot()["behavior"]       # 'read'
    source.switch("window", False)      # publishes 'off' to homecog/paper/command/window
    source.stop()
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import paho.mqtt.client as mqtt

from homecog.context import ConnectedSource, DeviceChange
from homecog.context.limited_log import LimitedWarnings
from homecog.context.mqtt_broker import BrokerClient, command_topic
from homecog.errors import ContextError
from homecog.home.codec import normalize
from homecog.home.states import state_word

log = logging.getLogger(__name__)
MAX_PAYLOAD = 4 * 1024 * 1024  # bytes of one message (a context of 1,002 devices is about 30 kB)
NAMED = 5  # the unknown names a warning names


@dataclass(eq=False, repr=False, kw_only=True)
class MqttSource(BrokerClient, ConnectedSource):
    """The context of a home, followed on an MQTT broker; a :class:`ContextSource`.

    Parameters
    ----------
    home, url, prefix, client_id, connect_timeout
        :class:`~homecog.context.mqtt_broker.BrokerClient`'s.
    on_change
        Called (on the network thread) with the new snapshot whenever a value changes once
        every feature and device has been received. Its errors are logged, never raised.
    """

    on_change: Callable[[dict[str, str]], None] | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self.rejected = 0
        self._names = self.home.feature_names + self.home.device_names
        self._devices = set(self.home.device_names)
        self._values: dict[str, str] = {}
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._base = f"{self.prefix}/{self.home.name}"
        self._known = set(self._names)
        self.warnings = LimitedWarnings(log)

    # -- lifecycle -------------------------------------------------------------------
    def stop(self) -> None:
        """Disconnect and stop the network thread."""
        if self._close() is not None:
            self._connected.clear()

    # -- the context -------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """Whether every feature and device has been received."""
        return not self.missing()

    def missing(self) -> list[str]:
        """The features and devices not received yet, in the home's order."""
        with self._lock:
            return [n for n in self._names if n not in self._values]

    def snapshot(self) -> dict[str, str]:
        """The latest value of every feature and device; :class:`ContextError` naming those not
        received yet."""
        with self._lock:
            missing = [n for n in self._names if n not in self._values]
            if missing:
                raise ContextError(
                    f"MQTT: no state received yet for {', '.join(missing)} "
                    f"(topics {self._base}/state/<name> on {self.address.host}:{self.address.port})"
                )
            return {n: self._values[n] for n in self._names}

    def switch(self, device: str, on: bool) -> None:
        """The robot's IoT command: publish ``on``/``off`` to the device's command topic (QoS 1)."""
        if device not in self.home.device_names:
            raise ContextError(
                f"unknown device {device!r}; expected one of {', '.join(self.home.device_names)}"
            )
        if self._client is None:
            raise ContextError("MQTT source not started; call start() first")
        payload = state_word(on)
        log.info("MQTT command %s -> %s", device, payload)
        # paho queues the message while the broker is away and sends it after reconnecting
        self._client.publish(command_topic(self.home, device, prefix=self.prefix), payload, qos=1)

    # -- network thread callbacks ---------------------------------------------------------
    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any) -> None:
        if self._refused(reason):
            return
        # subscribing here renews the subscriptions after every reconnect
        client.subscribe([(f"{self._base}/state/+", 1), (f"{self._base}/context", 1)])
        log.info("MQTT connected to %s:%d, following %s/", self.address.host, self.address.port, self._base)

    def _on_subscribe(self, client: mqtt.Client, userdata: Any, mid: int, reasons: Any, props: Any) -> None:
        # connected once subscribed: nothing published after start() returns can be missed
        if any(r.is_failure for r in reasons):
            log.warning(
                "MQTT broker %s refused the subscription to %s/: %s", self.address.host, self._base, reasons
            )
        self._connected.set()

    def _on_disconnect(self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any) -> None:
        self._connected.clear()
        if self._client is not None:
            log.warning(
                "MQTT broker %s:%d lost (%s); reconnecting", self.address.host, self.address.port, reason
            )

    def _on_message(self, client: mqtt.Client, userdata: Any, message: mqtt.MQTTMessage) -> None:
        try:
            self._receive(message.topic, message.payload)
        except Exception:  # never let a bad message stop the network thread
            log.exception("MQTT message on %s could not be handled", message.topic)

    def _receive(self, topic: str, payload: bytes) -> None:
        if len(payload) > MAX_PAYLOAD:
            with self._lock:
                self.rejected += 1
            self.warnings.warning(
                "MQTT %s: ignored a message of %s bytes, over the %s a message may have",
                topic,
                f"{len(payload):,}",
                f"{MAX_PAYLOAD:,}",
            )
            return
        if topic == f"{self._base}/context":
            try:
                values = json.loads(payload.decode("utf-8"))
                if not isinstance(values, dict):
                    raise ValueError("not a JSON object")
            except (UnicodeDecodeError, ValueError) as e:
                self._reject(topic, payload, str(e))
                return
            self.update(values, topic=topic)
        elif topic.startswith(f"{self._base}/state/"):
            if not payload:
                return  # a retained value being cleared
            try:
                text = payload.decode("utf-8")
            except UnicodeDecodeError as e:
                self._reject(topic, payload, str(e))
                return
            self.update({topic.rsplit("/", 1)[1]: text.strip()}, topic=topic)

    def update(self, values: Mapping[str, object], *, topic: str = "(local)") -> bool:
        """Take values as if received; invalid ones are ignored and counted. Returns whether
        anything changed."""
        accepted: dict[str, str] = {}
        unknown: list[str] = []
        bad: list[tuple[str, object, str]] = []
        for name, value in values.items():
            if name not in self._known:
                unknown.append(str(name))
                continue
            try:
                accepted[name] = normalize(self.home, name, value)
            except ContextError as e:
                bad.append((name, value, str(e)))
        if unknown or bad:
            self._rejected(topic, unknown, bad)
        with self._changed:
            changed = {n: v for n, v in accepted.items() if self._values.get(n) != v}
            was_complete = all(n in self._values for n in self._names)
            before = {n: self._values[n] for n in self._names} if was_complete else None
            self._values.update(changed)
            complete = was_complete or all(n in self._values for n in self._names)
            snapshot = {n: self._values[n] for n in self._names} if complete else None
            if changed:
                self._changed.notify_all()
        if changed:
            log.debug("MQTT context %s", changed)
            self._tell_devices(changed, before)
        if changed and snapshot is not None and self.on_change is not None:
            try:
                self.on_change(snapshot)
            except Exception:
                log.exception("MQTT on_change callback failed")
        return bool(changed)

    def _tell_devices(self, changed: Mapping[str, str], before: dict[str, str] | None) -> None:
        """Tell the listeners of each device that changed (a device's first value is no change)."""
        at = self.clock()
        for name, value in changed.items():
            if name in self._devices and before is not None:
                self._tell(DeviceChange(name, value == "on", before, at))
                before = {**before, name: value}

    def status(self) -> dict[str, Any]:
        """The connection as the HMI shows it."""
        return {"kind": "mqtt", "connected": self.connected}

    def _reject(self, topic: str, payload: object, why: str) -> None:
        with self._lock:
            self.rejected += 1
        self.warnings.warning("MQTT %s: ignored %s: %s", topic, _short(payload), why)

    def _rejected(self, topic: str, unknown: list[str], bad: list[tuple[str, object, str]]) -> None:
        """Count the values of one message that were ignored and say so in one warning: how many
        names the home does not have (the first :data:`NAMED` of them) and the first bad value."""
        with self._lock:
            self.rejected += len(unknown) + len(bad)
        parts = []
        if unknown:
            more = f", … ({len(unknown) - NAMED:,} more)" if len(unknown) > NAMED else ""
            names = ", ".join(_short(n) for n in unknown[:NAMED])
            parts.append(f"{len(unknown):,} unknown name{'s' * (len(unknown) != 1)} ({names}{more})")
        if bad:
            name, value, why = bad[0]
            more = f" and {len(bad) - 1:,} more" if len(bad) > 1 else ""
            parts.append(f"{_short(value)} for {name}: {why}{more}")
        self.warnings.warning("MQTT %s: ignored %s", topic, "; ".join(parts))


def _short(value: object, limit: int = 40) -> str:
    """A value as a warning quotes it: its repr, of at most ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"
