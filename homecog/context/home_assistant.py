"""Context from a Home Assistant instance, and the robot's IoT switches as its service calls.

The home file's ``home_assistant`` section (:mod:`homecog.home.home_assistant`) says which entity
holds each feature and device. :class:`HomeAssistantSource` connects to the instance's WebSocket
API with a token, takes a snapshot of those entities' states (``get_states``) and then every
change as it happens (``subscribe_events`` for ``state_changed``), and carries out the robot's
switches as service calls (``call_service``: ``light.turn_on``, ``cover.close_cover``, …).

A state that cannot be read — ``unavailable``, ``unknown``, a number outside every bin, a word
the section does not map — is logged, counted in :attr:`HomeAssistantSource.rejected` and
skipped: the feature keeps its last good value. When the connection drops (Home Assistant
restarts, the network goes away) the source connects again, with a delay that doubles from
:data:`~homecog.context.ha_connection.MIN_RECONNECT_DELAY` up to
:data:`~homecog.context.ha_connection.MAX_RECONNECT_DELAY`, and subscribes and takes a new
snapshot; while it is away the robot does not act on stale states (:attr:`ready` is false) and a
switch it is asked for is logged and skipped.

The client (:mod:`homecog.context.ha_client`) runs on an event loop of its own in a thread, so
that the rest of homecog stays synchronous, as with MQTT. The values taken from the entities are
:mod:`homecog.context.ha_readings`'s, the connection :mod:`homecog.context.ha_connection`'s.

Against an instance (not run as a doctest)::

    source = HomeAssistantSource(load_home("my_home.yaml"), "http://homeassistant.local:8123",
                                 token=os.environ["HOMECOG_HA_TOKEN"], on_change=print)
    source.start()                  # HomeAssistantError: unreachable, refused token, unknown entities
    source.snapshot()["behavior"]   # 'read'
    source.switch("lamp", True)     # light.turn_on on the lamp's entity
    source.stop()

A home without the section, or no token, fails at once:

>>> from homecog.home import load_home
>>> HomeAssistantSource(load_home("paper"), "http://127.0.0.1:8123", token="x")
Traceback (most recent call last):
...
homecog.errors.HomeAssistantError: paper.yaml: no home_assistant section; see homecog ha scaffold
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import threading
from collections.abc import Callable, Mapping
from typing import Any

from homecog.context.ha_client import CONNECT_TIMEOUT, TOKEN_HELP, websocket_url
from homecog.context.ha_connection import HomeAssistantConnection
from homecog.errors import ContextError, HomeAssistantError
from homecog.home.home_assistant import DeviceEntity, FeatureEntity, HomeAssistantMap
from homecog.home.model import Home

log = logging.getLogger(__name__)


class HomeAssistantSource(HomeAssistantConnection):
    """The context of a home, followed in a Home Assistant instance; a :class:`ContextSource`.

    Parameters
    ----------
    home
        A home with a ``home_assistant`` section.
    url
        The instance, e.g. ``http://homeassistant.local:8123``.
    token
        An access token of the Home Assistant user the robot acts as.
    on_change
        Called (on the client's thread) with the new snapshot whenever a value changes once
        every feature and device has a value. Its errors are logged, never raised.
    on_state
        Called (on the client's thread) with ``(entity_id, state object, time.time() at
        receipt)`` for every state of a mapped entity that arrives; for measurements.
    connect_timeout
        Seconds :meth:`start` waits for the first connection.
    """

    #: :meth:`switch` answers ``None`` for a switch it skipped (the instance away)
    skips_switches = True

    def __init__(
        self,
        home: Home,
        url: str,
        *,
        token: str | None,
        on_change: Callable[[dict[str, str]], None] | None = None,
        on_state: Callable[[str, Mapping[str, Any], float], None] | None = None,
        connect_timeout: float = CONNECT_TIMEOUT,
    ) -> None:
        if home.home_assistant is None:
            raise HomeAssistantError(f"{home.source}: no home_assistant section; see homecog ha scaffold")
        if not token:
            raise HomeAssistantError(f"no token for Home Assistant at {url}: give {TOKEN_HELP}")
        self.home = home
        self.url = url
        self.token = token
        self.on_change = on_change
        self.on_state = on_state
        self.connect_timeout = connect_timeout
        self.ws_url = websocket_url(url)  # a bad URL fails here, before anything starts
        self.mapping: HomeAssistantMap = home.home_assistant
        self.rejected = 0
        self.skipped_switches = 0
        self.reconnects = 0
        self.version: str | None = None
        self.user_id: str | None = None
        self.last_error: str | None = None
        self.connected_since: float | None = None
        self._readers: dict[str, list[FeatureEntity | DeviceEntity]] = {}
        for m in (*self.mapping.features, *self.mapping.devices):
            self._readers.setdefault(m.entity, []).append(m)
        mapped = {f.feature for f in self.mapping.features}
        self._clocks = [f.name for f in home.features if f.kind == "clock" and f.name not in mapped]
        self._names = [n for n in home.feature_names + home.device_names if n not in self._clocks]
        self._device_names = frozenset(home.device_names)
        self._values: dict[str, str] = {}
        self._updated: dict[str, str] = {}  # entity -> last_updated of the state taken
        self._said: dict[str, str] = {}  # name -> the last skip logged, so a stuck state logs once
        self._dirty = False  # a value changed since on_change was last called
        self._lock = threading.Lock()
        self._changed = threading.Condition(self._lock)
        self._connected = threading.Event()
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._task: asyncio.Task[None] | None = None
        self._client: Any = None
        self._first: concurrent.futures.Future[None] = concurrent.futures.Future()

    # -- lifecycle -------------------------------------------------------------------------------
    def start(self) -> HomeAssistantSource:
        """Connect, check the entities, take the snapshot and follow the changes; raises
        :class:`HomeAssistantError` (one line) when the instance cannot be reached, refuses the
        token or lacks a mapped entity."""
        if self._thread is not None:
            return self
        self._thread = threading.Thread(target=self._run, name="homecog-home-assistant", daemon=True)
        self._thread.start()
        try:
            self._first.result(timeout=self.connect_timeout + 5)
        except concurrent.futures.TimeoutError:
            self.stop()
            raise HomeAssistantError(
                f"Home Assistant at {self.ws_url} did not answer within {self.connect_timeout:g} s"
            ) from None
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Disconnect and end the client's thread."""
        loop, task, thread = self._loop, self._task, self._thread
        if loop is not None and task is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop closed in between
                loop.call_soon_threadsafe(task.cancel)
        if thread is not None:
            thread.join(10)
        self._thread = None
        self._connected.clear()

    def status(self) -> dict[str, Any]:
        """The connection as the HMI shows it."""
        return {
            "kind": "home_assistant",
            "url": self.url,
            "connected": self.connected,
            "since": self.connected_since,
            "version": self.version,
            "reconnects": self.reconnects,
            "missing": self.missing(),
            "skipped": self.rejected,
            "skipped_switches": self.skipped_switches,
            "last_error": self.last_error,
        }

    # -- the context -----------------------------------------------------------------------------
    @property
    def ready(self) -> bool:
        """Connected, and every feature and device has a value: the robot may act."""
        return self.connected and not self.missing()

    def switch(self, device: str, on: bool) -> concurrent.futures.Future[bool] | None:
        """The robot's IoT command as a service call (``light.turn_on`` on the device's entity),
        sent without waiting; the future says whether Home Assistant carried it out. While the
        instance is away the switch is logged and skipped (``None``)."""
        if device not in self.home.device_names:
            raise ContextError(
                f"unknown device {device!r}; expected one of {', '.join(self.home.device_names)}"
            )
        mapping = self.mapping.device(device)
        domain, service = mapping.service(on)
        loop = self._loop
        if not self.connected or loop is None or loop.is_closed():
            self.skipped_switches += 1
            log.warning("Home Assistant not connected: skipped %s.%s on %s", domain, service, mapping.entity)
            return None
        log.info("Home Assistant: %s.%s on %s", domain, service, mapping.entity)
        return asyncio.run_coroutine_threadsafe(self._call(domain, service, mapping.entity), loop)
