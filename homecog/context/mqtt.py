"""Context from an MQTT broker, and the robot's IoT commands to it (SPEC §10).

A real home (or the simulated one, through :class:`MqttPublisher`) publishes the state of every
feature and device to a broker; :class:`MqttSource` follows those topics and gives the running
system the whole context, and publishes the robot's switch commands for the home's devices to act
on. The topic layout, with ``PREFIX`` (default ``homecog``) and ``HOME`` the home's name:

``PREFIX/HOME/state/<feature or device>``
    The current value as text, published *retained* so a newcomer learns it at once: a time of
    day ``HH:MM``, a number as a decimal (``25.5``), a category (``read``), a device ``on`` or
    ``off``. E.g. ``homecog/paper/state/temperature`` → ``25.5``.
``PREFIX/HOME/context``
    Optional: several values at once as a JSON object, ``{"behavior": "sleep", "lamp": "off"}``.
``PREFIX/HOME/command/<device>``
    The robot's IoT command, ``on`` or ``off`` (QoS 1, not retained), e.g.
    ``homecog/paper/command/window`` → ``off``. The home switches the device and publishes its
    new state.

A value that does not fit the home (an unknown category, not a number, outside every bin) is
ignored with a logged warning and counted in :attr:`MqttSource.rejected`. A broker that goes
away is reconnected to (with a growing delay, at most :data:`MAX_RECONNECT_DELAY` seconds) and
the topics are subscribed to again; retained states arrive anew.

Against a broker (not run as a doctest)::

    source = MqttSource(load_home("paper"), "mqtt://127.0.0.1:1883", on_change=print)
    source.start()                      # raises MqttError when the broker cannot be reached
    source.wait_ready(10)               # every feature and device received
    source.snapshot()["behavior"]       # 'read'
    source.switch("window", False)      # publishes 'off' to homecog/paper/command/window
    source.stop()

Topic names and URLs need no broker:

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> state_topic(home, "temperature"), command_topic(home, "window", prefix="lab")
('homecog/paper/state/temperature', 'lab/paper/command/window')
>>> parse_url("mqtts://robot:secret@broker.local")
BrokerAddress(host='broker.local', port=8883, tls=True, username='robot', password='secret')
"""

from __future__ import annotations

import json
import logging
import ssl
import threading
import time
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any
from urllib.parse import unquote, urlsplit

import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from homecog.context import ConnectedSource
from homecog.errors import ContextError, MqttError
from homecog.home.codec import normalize
from homecog.home.model import Home
from homecog.home.states import parse_state

log = logging.getLogger(__name__)

DEFAULT_PREFIX = "homecog"
CONNECT_TIMEOUT = 5.0  # seconds to wait for the broker at start
MIN_RECONNECT_DELAY = 1  # seconds; paho doubles it after each failed attempt
MAX_RECONNECT_DELAY = 8


@dataclass(frozen=True)
class BrokerAddress:
    """Where a broker is, from a URL such as ``mqtt://user:password@host:1883``."""

    host: str
    port: int
    tls: bool = False
    username: str | None = None
    password: str | None = None


def parse_url(url: str) -> BrokerAddress:
    """A broker URL (``mqtt://`` or ``mqtts://`` for TLS) as a :class:`BrokerAddress`.

    >>> parse_url("mqtt://127.0.0.1")
    BrokerAddress(host='127.0.0.1', port=1883, tls=False, username=None, password=None)
    >>> parse_url("http://x")
    Traceback (most recent call last):
    ...
    homecog.errors.MqttError: MQTT URL 'http://x': unknown scheme 'http'; expected mqtt:// or mqtts://
    """
    try:
        parts = urlsplit(str(url).strip())
        port = parts.port
    except ValueError as e:
        raise MqttError(f"MQTT URL {url!r}: {e}") from None
    scheme = parts.scheme.lower()
    if scheme not in ("mqtt", "mqtts"):
        raise MqttError(
            f"MQTT URL {url!r}: unknown scheme {parts.scheme!r}; expected mqtt:// or mqtts://"
            if scheme
            else f"MQTT URL {url!r}: expected e.g. mqtt://127.0.0.1:1883"
        )
    if not parts.hostname:
        raise MqttError(f"MQTT URL {url!r}: no host; expected e.g. mqtt://127.0.0.1:1883")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise MqttError(f"MQTT URL {url!r}: unexpected path or query; expected mqtt://host:port")
    tls = scheme == "mqtts"
    return BrokerAddress(
        host=parts.hostname,
        port=port or (8883 if tls else 1883),
        tls=tls,
        username=unquote(parts.username) if parts.username is not None else None,
        password=unquote(parts.password) if parts.password is not None else None,
    )


def state_topic(home: Home, name: str, *, prefix: str = DEFAULT_PREFIX) -> str:
    """The retained topic that holds a feature's or device's value."""
    return f"{prefix}/{home.name}/state/{name}"


def command_topic(home: Home, device: str, *, prefix: str = DEFAULT_PREFIX) -> str:
    """The topic the robot's switch commands for ``device`` go to."""
    return f"{prefix}/{home.name}/command/{device}"


def context_topic(home: Home, *, prefix: str = DEFAULT_PREFIX) -> str:
    """The topic for several values at once, as a JSON object."""
    return f"{prefix}/{home.name}/context"


def _client(address: BrokerAddress, client_id: str | None) -> mqtt.Client:
    client = mqtt.Client(
        CallbackAPIVersion.VERSION2, client_id=client_id or f"homecog-{uuid.uuid4().hex[:12]}"
    )
    if address.username is not None:
        client.username_pw_set(address.username, address.password)
    if address.tls:
        client.tls_set(cert_reqs=ssl.CERT_REQUIRED)
    client.reconnect_delay_set(min_delay=MIN_RECONNECT_DELAY, max_delay=MAX_RECONNECT_DELAY)
    return client


def _connect(client: mqtt.Client, address: BrokerAddress, connected: threading.Event, timeout: float) -> None:
    """Connect and start the network thread (which reconnects by itself), or raise MqttError."""
    where = f"{address.host}:{address.port}"
    client.connect_timeout = timeout
    try:
        client.connect(address.host, address.port, keepalive=30)
    except (OSError, ValueError) as e:
        raise MqttError(f"MQTT broker {where} cannot be reached: {e}") from None
    client.loop_start()
    if not connected.wait(timeout):
        client.loop_stop()
        client.disconnect()
        raise MqttError(f"MQTT broker {where} did not accept the connection within {timeout:g} s")


class MqttSource(ConnectedSource):
    """The context of a home, followed on an MQTT broker; a :class:`ContextSource`.

    Parameters
    ----------
    home
        The home whose features and devices the state topics carry.
    url
        The broker, ``mqtt://[user:password@]host[:port]`` (``mqtts://`` for TLS).
    prefix
        The first level of every topic.
    client_id
        The MQTT client id; a random one by default.
    on_change
        Called (on the network thread) with the new snapshot whenever a value changes once
        every feature and device has been received. Its errors are logged, never raised.
    connect_timeout
        Seconds :meth:`start` waits for the broker.
    """

    def __init__(
        self,
        home: Home,
        url: str,
        *,
        prefix: str = DEFAULT_PREFIX,
        client_id: str | None = None,
        on_change: Callable[[dict[str, str]], None] | None = None,
        connect_timeout: float = CONNECT_TIMEOUT,
    ) -> None:
        self.home = home
        self.url = url
        self.prefix = prefix
        self.client_id = client_id
        self.on_change = on_change
        self.connect_timeout = connect_timeout
        self.address = parse_url(url)  # a bad URL fails here, before anything starts
        self.rejected = 0
        self._names = home.feature_names + home.device_names
        self._values: dict[str, str] = {}
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._connected = threading.Event()
        self._client: mqtt.Client | None = None
        self._base = f"{prefix}/{home.name}"

    # -- lifecycle -------------------------------------------------------------------
    def start(self) -> MqttSource:
        """Connect, subscribe and follow the state topics; raises :class:`MqttError` when the
        broker cannot be reached within ``connect_timeout`` seconds."""
        if self._client is not None:
            return self
        client = _client(self.address, self.client_id)
        client.on_connect = self._on_connect
        client.on_disconnect = self._on_disconnect
        client.on_subscribe = self._on_subscribe
        client.on_message = self._on_message
        _connect(client, self.address, self._connected, self.connect_timeout)
        self._client = client
        return self

    def stop(self) -> None:
        """Disconnect and stop the network thread."""
        client, self._client = self._client, None
        if client is not None:
            client.disconnect()
            client.loop_stop()
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
        payload = "on" if on else "off"
        log.info("MQTT command %s -> %s", device, payload)
        # paho queues the message while the broker is away and sends it after reconnecting
        self._client.publish(command_topic(self.home, device, prefix=self.prefix), payload, qos=1)

    # -- network thread callbacks ---------------------------------------------------------
    def _on_connect(self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any) -> None:
        if reason.is_failure:
            log.warning("MQTT broker %s refused the connection: %s", self.address.host, reason)
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
        for name, value in values.items():
            try:
                accepted[name] = normalize(self.home, name, value)
            except ContextError as e:
                self._reject(topic, value, str(e))
        with self._changed:
            changed = {n: v for n, v in accepted.items() if self._values.get(n) != v}
            self._values.update(changed)
            complete = all(n in self._values for n in self._names)
            snapshot = {n: self._values[n] for n in self._names} if complete else None
            if changed:
                self._changed.notify_all()
        if changed:
            log.debug("MQTT context %s", changed)
        if changed and snapshot is not None and self.on_change is not None:
            try:
                self.on_change(snapshot)
            except Exception:
                log.exception("MQTT on_change callback failed")
        return bool(changed)

    def _reject(self, topic: str, payload: object, why: str) -> None:
        with self._lock:
            self.rejected += 1
        log.warning("MQTT %s: ignored %r: %s", topic, payload, why)


class MqttPublisher:
    """Publishes a home's context to a broker (retained state topics), as a real home would;
    the simulated home uses it. Commands the robot publishes are handed to ``on_command``.

    Against a broker (not run as a doctest)::

        sim = SimulatedHome(load_home("paper"))
        pub = MqttPublisher(sim.home, "mqtt://127.0.0.1:1883", on_command=sim.switch).start()
        pub.publish(sim.snapshot())     # only values that changed since the last call go out
        pub.stop()
    """

    def __init__(
        self,
        home: Home,
        url: str,
        *,
        prefix: str = DEFAULT_PREFIX,
        client_id: str | None = None,
        on_command: Callable[[str, bool], None] | None = None,
        connect_timeout: float = CONNECT_TIMEOUT,
    ) -> None:
        self.home = home
        self.url = url
        self.prefix = prefix
        self.client_id = client_id
        self.on_command = on_command
        self.connect_timeout = connect_timeout
        self.address = parse_url(url)
        self._published: dict[str, str] = {}
        self._pending: list[mqtt.MQTTMessageInfo] = []
        self._lock = threading.Lock()  # publish is called from the simulation and paho threads
        self._connected = threading.Event()
        self._client: mqtt.Client | None = None

    def start(self) -> MqttPublisher:
        """Connect; raises :class:`MqttError` when the broker cannot be reached."""
        if self._client is None:
            client = _client(self.address, self.client_id)
            client.on_connect = self._on_connect
            client.on_disconnect = lambda *a: self._connected.clear()
            client.on_message = self._on_message
            client.on_subscribe = lambda *a: self._connected.set()
            _connect(client, self.address, self._connected, self.connect_timeout)
            self._client = client
        return self

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
        client, self._client = self._client, None
        if client is not None:
            client.disconnect()
            client.loop_stop()

    def __enter__(self) -> MqttPublisher:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

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
        if reason.is_failure:
            log.warning("MQTT broker %s refused the connection: %s", self.address.host, reason)
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
            log.warning("MQTT command on %s ignored: %s", message.topic, e)


def publish_context(
    url: str, home: Home, snapshot: Mapping[str, object], *, prefix: str = DEFAULT_PREFIX
) -> None:
    """Publish a whole context once (retained state topics) and disconnect."""
    with MqttPublisher(home, url, prefix=prefix) as publisher:
        publisher.publish(snapshot, everything=True)
