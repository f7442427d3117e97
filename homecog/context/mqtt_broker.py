"""An MQTT broker as homecog reaches it: its address from a URL, the topics of a home on it, and
a paho client connected to it (with its network thread, which reconnects by itself).

A real home (or the simulated one, through :class:`~homecog.context.mqtt_publisher.MqttPublisher`)
publishes the state of every feature and device to a broker;
:class:`~homecog.context.mqtt_source.MqttSource` follows those topics and gives the running system
the whole context, and publishes the robot's switch commands for the home's devices to act on.
The topic layout, with ``PREFIX`` (default ``homecog``) and ``HOME`` the home's name:

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

Topic names and URLs need no broker:

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> context_topic(home), command_topic(home, "lamp")
('homecog/paper/context', 'homecog/paper/command/lamp')
>>> state_topic(home, "temperature"), command_topic(home, "window", prefix="lab")
('homecog/paper/state/temperature', 'lab/paper/command/window')
>>> address = parse_url("mqtts://robot:secret@broker.local")
>>> address, address.password
(BrokerAddress(host='broker.local', port=8883, tls=True, username='robot'), 'secret')

A URL is shown, printed or logged only through :func:`redact_url`, never with its password.
"""

from __future__ import annotations

import logging
import re
import ssl
import threading
import uuid
from dataclasses import KW_ONLY, dataclass, field
from typing import Any, Self
from urllib.parse import unquote, urlsplit

import paho.mqtt.client as mqtt
from paho.mqtt.enums import CallbackAPIVersion

from homecog.errors import MqttError
from homecog.home.model import Home

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
    password: str | None = field(default=None, repr=False)


def redact_url(url: str) -> str:
    """A broker URL as it may be shown: its password (whatever it holds, even a raw ``/`` or
    ``@``) replaced by ``***``, as the database URLs are (:func:`homecog.knowledge.database.redact`).

    >>> redact_url("mqtt://robot:s3cret@broker.local:1883"), redact_url("mqtt://127.0.0.1")
    ('mqtt://robot:***@broker.local:1883', 'mqtt://127.0.0.1')
    >>> redact_url("mqtts://robot:a/b@c@broker.local"), redact_url("mqtt://robot@host")
    ('mqtts://robot:***@broker.local', 'mqtt://robot@host')
    >>> redact_url("robot:s3cret@broker.local"), redact_url("robot:a//b@broker.local")
    ('robot:***@broker.local', 'robot:***@broker.local')
    """
    text = str(url)
    at = text.rfind("@")
    if at < 0:
        return text
    scheme = re.match(r"[A-Za-z][A-Za-z0-9+.-]*://", text)
    begin = scheme.end() if scheme and scheme.end() <= at else 0  # none: the user is first (u:pw@h)
    user, colon, _ = text[begin:at].partition(":")
    return f"{text[:begin]}{user}{':***' if colon else ''}{text[at:]}"


def parse_url(url: str) -> BrokerAddress:
    """A broker URL (``mqtt://`` or ``mqtts://`` for TLS) as a :class:`BrokerAddress`.

    >>> parse_url("mqtt://127.0.0.1")
    BrokerAddress(host='127.0.0.1', port=1883, tls=False, username=None)
    >>> parse_url("http://x")
    Traceback (most recent call last):
    ...
    homecog.errors.MqttError: MQTT URL 'http://x': unknown scheme 'http'; expected mqtt:// or mqtts://
    """
    shown = redact_url(str(url).strip())  # a message never holds the password
    try:
        parts = urlsplit(str(url).strip())
        port = parts.port
    except ValueError as e:
        what = "a port that is no number from 0 to 65535" if "ort" in str(e) else "not a URL"
        raise MqttError(f"MQTT URL {shown!r}: {what}; expected e.g. mqtt://127.0.0.1:1883") from None
    scheme = parts.scheme.lower()
    if scheme not in ("mqtt", "mqtts"):
        raise MqttError(
            f"MQTT URL {shown!r}: unknown scheme {parts.scheme!r}; expected mqtt:// or mqtts://"
            if scheme
            else f"MQTT URL {shown!r}: expected e.g. mqtt://127.0.0.1:1883"
        )
    if not parts.hostname:
        raise MqttError(f"MQTT URL {shown!r}: no host; expected e.g. mqtt://127.0.0.1:1883")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise MqttError(f"MQTT URL {shown!r}: unexpected path or query; expected mqtt://host:port")
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


def make_client(address: BrokerAddress, client_id: str | None) -> mqtt.Client:
    """A paho client for the broker (credentials, TLS, the reconnect delays), not connected."""
    client = mqtt.Client(
        CallbackAPIVersion.VERSION2, client_id=client_id or f"homecog-{uuid.uuid4().hex[:12]}"
    )
    if address.username is not None:
        client.username_pw_set(address.username, address.password)
    if address.tls:
        client.tls_set(cert_reqs=ssl.CERT_REQUIRED)
    client.reconnect_delay_set(min_delay=MIN_RECONNECT_DELAY, max_delay=MAX_RECONNECT_DELAY)
    return client


def connect(client: mqtt.Client, address: BrokerAddress, connected: threading.Event, timeout: float) -> None:
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


@dataclass(eq=False, repr=False)  # no repr: the URL may hold a password
class BrokerClient:
    """What each of homecog's clients of a broker holds (the source, the publisher, the Home
    Assistant discovery): the home, the broker's URL and address, the topic prefix, the paho
    client once started, and whether it is connected.

    Parameters
    ----------
    home
        The home whose features and devices the topics carry.
    url
        The broker, ``mqtt://[user:password@]host[:port]`` (``mqtts://`` for TLS).
    prefix
        The first level of every topic.
    client_id
        The MQTT client id; a random one by default.
    connect_timeout
        Seconds :meth:`start` waits for the broker.
    """

    home: Home
    url: str
    _: KW_ONLY
    prefix: str = DEFAULT_PREFIX
    client_id: str | None = None
    connect_timeout: float = CONNECT_TIMEOUT

    def __post_init__(self) -> None:
        self.address = parse_url(self.url)  # a bad URL fails here, before anything starts
        self._connected = threading.Event()
        self._client: mqtt.Client | None = None

    # -- the connection ---------------------------------------------------------------------------
    def start(self, *, wait: bool = True) -> Self:
        """Connect (once) and start the network thread, which reconnects by itself. With
        ``wait``, :class:`MqttError` when the broker cannot be reached or does not accept the
        connection within ``connect_timeout`` seconds; without, it connects in the background,
        as long as it takes."""
        if self._client is None:
            client = make_client(self.address, self.client_id)
            self._prepare(client)
            client.on_connect = self._on_connect
            client.on_disconnect = self._on_disconnect
            client.on_subscribe = self._on_subscribe
            client.on_message = self._on_message
            if wait:
                connect(client, self.address, self._connected, self.connect_timeout)
            else:
                client.connect_async(self.address.host, self.address.port, keepalive=30)
                client.loop_start()
            self._client = client
        return self

    def stop(self) -> None:
        """Disconnect and stop the network thread."""
        self._close()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _close(self) -> mqtt.Client | None:
        """Forget the client, let :meth:`_closing` see it, then disconnect it and stop its
        network thread; the client that was (``None`` when not started)."""
        client, self._client = self._client, None
        self._closing(client)
        if client is not None:
            client.disconnect()
            client.loop_stop()
        return client

    def _prepare(self, client: mqtt.Client) -> None:
        """What the client needs before it connects (nothing here)."""

    def _closing(self, client: mqtt.Client | None) -> None:
        """What is done as the client stops, before it disconnects (nothing here)."""

    # -- paho's callbacks (its network thread) ---------------------------------------------------
    def _on_connect(
        self, client: mqtt.Client, userdata: Any, flags: Any, reason: Any, props: Any
    ) -> None:  # pragma: no cover - each client says its own
        raise NotImplementedError

    def _on_message(
        self, client: mqtt.Client, userdata: Any, message: mqtt.MQTTMessage
    ) -> None:  # pragma: no cover - each client says its own
        raise NotImplementedError

    def _on_subscribe(self, *args: Any) -> None:
        """Connected once subscribed: nothing published after :meth:`start` returns is missed."""
        self._connected.set()

    def _on_disconnect(self, *args: Any) -> None:
        self._connected.clear()

    def _refused(self, reason: Any) -> bool:
        """Whether the broker refused the connection (logged, by the client's own module)."""
        if reason.is_failure:
            logging.getLogger(type(self).__module__).warning(
                "MQTT broker %s refused the connection: %s", self.address.host, reason
            )
        return bool(reason.is_failure)
