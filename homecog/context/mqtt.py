"""Context from an MQTT broker, and the robot's IoT commands to it.

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

The broker's address, topics and connection are :mod:`homecog.context.mqtt_broker`'s, the
source :mod:`homecog.context.mqtt_source`'s and the publisher
:mod:`homecog.context.mqtt_publisher`'s; their names are importable from here.
"""

from __future__ import annotations

import logging

from homecog.context.mqtt_broker import (
    CONNECT_TIMEOUT,
    DEFAULT_PREFIX,
    MAX_RECONNECT_DELAY,
    MIN_RECONNECT_DELAY,
    BrokerAddress,
    command_topic,
    context_topic,
    parse_url,
    state_topic,
)
from homecog.context.mqtt_publisher import MqttPublisher, publish_context
from homecog.context.mqtt_source import MqttSource
from homecog.errors import MqttError

log = logging.getLogger(__name__)  # the logger every MQTT module logs to

__all__ = [
    "CONNECT_TIMEOUT",
    "DEFAULT_PREFIX",
    "MAX_RECONNECT_DELAY",
    "MIN_RECONNECT_DELAY",
    "BrokerAddress",
    "MqttError",
    "MqttPublisher",
    "MqttSource",
    "command_topic",
    "context_topic",
    "parse_url",
    "publish_context",
    "state_topic",
]
