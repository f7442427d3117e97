"""Context from a Home Assistant instance, and the robot's IoT switches as its service calls
(SPEC §12).

The home file's ``home_assistant`` section (:mod:`homecog.home.home_assistant`) says which entity
holds each feature and device. :class:`HomeAssistantSource` connects to the instance's WebSocket
API with a token, takes a snapshot of those entities' states (``get_states``) and then every
change as it happens (``subscribe_events`` for ``state_changed``), and carries out the robot's
switches as service calls (``call_service``: ``light.turn_on``, ``cover.close_cover``, …).

A state that cannot be read — ``unavailable``, ``unknown``, a number outside every bin, a word
the section does not map — is logged, counted in :attr:`HomeAssistantSource.rejected` and
skipped: the feature keeps its last good value. When the connection drops (Home Assistant
restarts, the network goes away) the source connects again, with a delay that doubles from
:data:`MIN_RECONNECT_DELAY` up to :data:`MAX_RECONNECT_DELAY`, and subscribes and takes a new
snapshot; while it is away the robot does not act on stale states (:attr:`ready` is false) and a
switch it is asked for is logged and skipped.

The client (:mod:`homecog.context.ha_client`) runs on an event loop of its own in a thread, so
that the rest of homecog stays synchronous, as with MQTT.

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
homecog.errors.HomeAssistantError: paper.yaml: no home_assistant section (SPEC §12); see homecog ha scaffold
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import threading
import time
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import Any

from homecog.context import ConnectedSource
from homecog.context.ha_client import CONNECT_TIMEOUT, TOKEN_HELP, connect, reason, websocket_url
from homecog.errors import ContextError, HomeAssistantError
from homecog.home.clock import format_clock
from homecog.home.home_assistant import (
    DeviceEntity,
    FeatureEntity,
    HomeAssistantMap,
    feature_value,
    unknown_entities,
)
from homecog.home.model import Home

log = logging.getLogger(__name__)

MIN_RECONNECT_DELAY = 0.25  # seconds; doubled after each failed attempt ...
MAX_RECONNECT_DELAY = 2.0  # ... up to this, so the robot is back within ~2 s of the instance


class HomeAssistantSource(ConnectedSource):
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
            raise HomeAssistantError(
                f"{home.source}: no home_assistant section (SPEC §12); see homecog ha scaffold"
            )
        if not token:
            raise HomeAssistantError(
                f"no token for Home Assistant at {url}: set $HOMECOG_HA_TOKEN or give --ha-token, "
                + TOKEN_HELP
            )
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

    def missing(self) -> list[str]:
        """The features and devices without a value yet, in the home's order."""
        with self._lock:
            return [n for n in self._names if n not in self._values]

    def snapshot(self) -> dict[str, str]:
        """The latest value of every feature and device (a clock feature without an entity
        reads the local clock); :class:`ContextError` naming those without a value yet."""
        with self._lock:
            missing = [n for n in self._names if n not in self._values]
            if missing:
                entities = {
                    m.feature if isinstance(m, FeatureEntity) else m.device: m.entity
                    for ms in self._readers.values()
                    for m in ms
                }
                raise ContextError(
                    "Home Assistant: no state yet for " + ", ".join(f"{n} ({entities[n]})" for n in missing)
                )
            values = dict(self._values)
        now = datetime.now()
        clock = format_clock(now.hour + now.minute / 60)
        values.update(dict.fromkeys(self._clocks, clock))
        return {n: values[n] for n in self.home.feature_names + self.home.device_names}

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

    # -- the client's thread ---------------------------------------------------------------------
    def _run(self) -> None:
        try:
            asyncio.run(self._main())
        except BaseException as e:  # never leave start() waiting
            if not self._first.done():
                self._first.set_exception(e)

    async def _main(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._task = asyncio.current_task()
        delay, logged = MIN_RECONNECT_DELAY, None
        try:
            while True:
                first = not self._first.done()  # until start() has its answer
                connected_before = self.connected_since
                try:
                    await self._session(first)
                    self.last_error = "connection closed"
                    log.warning("Home Assistant at %s closed the connection; reconnecting", self.ws_url)
                except Exception as e:  # unreachable, refused, dropped mid-session, a failed command
                    error = e if isinstance(e, HomeAssistantError) else None
                    self.last_error = str(error) if error else f"Home Assistant at {self.ws_url}: {reason(e)}"
                    if not self._first.done():  # start() fails with it
                        self._first.set_exception(error or HomeAssistantError(self.last_error))
                        return
                    # an outage logs once, not every attempt; the HMI shows it as long as it lasts
                    level = logging.DEBUG if self.last_error == logged else logging.WARNING
                    log.log(level, "%s; trying again in %.2g s", self.last_error, delay)
                    logged = self.last_error
                if self.connected_since != connected_before:
                    delay, logged = MIN_RECONNECT_DELAY, None  # it got through: the backoff starts afresh
                await asyncio.sleep(delay)
                delay = min(delay * 2, MAX_RECONNECT_DELAY)
        except asyncio.CancelledError:
            pass

    async def _session(self, first: bool) -> None:
        """One connection: authenticate, subscribe, take the snapshot, then listen until it closes."""
        client = await connect(self.ws_url, self.token, self.connect_timeout)
        listener = asyncio.create_task(client.start_listening())
        try:

            async def command(name: str, **kwargs: Any) -> Any:
                return await asyncio.wait_for(client.send_command(name, **kwargs), self.connect_timeout)

            self.version = client.version
            self.user_id = (await command("auth/current_user")).get("id")
            config = await command("get_config")
            # subscribe before the snapshot: a change in between arrives as an event, and the
            # states' last_updated keep an older snapshot from overwriting a newer event
            await asyncio.wait_for(
                client.subscribe_events(self._on_event, "state_changed"), self.connect_timeout
            )
            states = await command("get_states")
            problems = unknown_entities(self.mapping, (s["entity_id"] for s in states))
            if problems and first and config.get("state") == "RUNNING":
                raise HomeAssistantError(f"Home Assistant at {self.url}: {'; '.join(problems)}")
            for problem in problems:  # while it starts, entities come later, as events
                log.warning("Home Assistant: %s", problem)
            for state in states:
                if state["entity_id"] in self._readers:
                    self._take(state, time.time())
            self._client = client
            self.connected_since = time.time()
            if not first:
                self.reconnects += 1
            self._connected.set()
            # back after a loss is worth the same level as the loss was
            log.log(
                logging.INFO if first else logging.WARNING,
                "Home Assistant %s at %s: following %d entities",
                self.version,
                self.url,
                len(self._readers),
            )
            if first:
                self._first.set_result(None)
            self._notify()
            await listener  # until the connection closes; its error, if any, is raised here
        finally:
            self._connected.clear()
            self._client = None
            await client.disconnect()
            if not listener.done():
                listener.cancel()
            with contextlib.suppress(BaseException):
                await listener

    async def _call(self, domain: str, service: str, entity: str) -> bool:
        client = self._client
        if client is None:
            self.skipped_switches += 1
            log.warning("Home Assistant not connected: skipped %s.%s on %s", domain, service, entity)
            return False
        try:
            await asyncio.wait_for(
                client.call_service(domain, service, target={"entity_id": entity}), self.connect_timeout
            )
            return True
        except Exception as e:
            self.skipped_switches += 1
            log.warning("Home Assistant: %s.%s on %s failed: %s", domain, service, entity, reason(e))
            return False

    def _on_event(self, event: Mapping[str, Any]) -> None:
        data = event.get("data") or {}
        state = data.get("new_state")
        if state is not None and data.get("entity_id") in self._readers:
            try:
                self._take(state, time.time())
            except Exception:  # never let one odd event stop the client
                log.exception("Home Assistant: could not read %r", state)
                return
            self._notify()

    def _take(self, state: Mapping[str, Any], received: float) -> None:
        """Read one entity's state into the features and devices it holds."""
        entity = state["entity_id"]
        updated = str(state.get("last_updated", ""))
        if self.on_state is not None:
            try:
                self.on_state(entity, state, received)
            except Exception:
                log.exception("Home Assistant on_state callback failed")
        accepted: dict[str, str] = {}
        for m in self._readers[entity]:
            try:
                if isinstance(m, FeatureEntity):
                    raw = (
                        state.get("state")
                        if m.attribute is None
                        else (state.get("attributes") or {}).get(m.attribute)
                    )
                    name, value = m.feature, feature_value(self.home.feature(m.feature), m, raw)
                else:
                    name, value = m.device, ("on" if m.state(str(state.get("state"))) else "off")
            except ContextError as e:
                self._reject(m.feature if isinstance(m, FeatureEntity) else m.device, str(e))
                continue
            accepted[name] = value
            self._said.pop(name, None)
        with self._changed:
            if updated and updated < self._updated.get(entity, ""):
                return  # older than what was taken: an event overtaken by the snapshot
            self._updated[entity] = updated
            self._dirty |= any(self._values.get(n) != v for n, v in accepted.items())
            self._values.update(accepted)
            self._changed.notify_all()

    def _notify(self) -> None:
        with self._lock:
            if not self._dirty or any(n not in self._values for n in self._names):
                return
            self._dirty = False
        if self.on_change is not None:
            try:
                self.on_change(self.snapshot())
            except Exception:
                log.exception("Home Assistant on_change callback failed")

    def _reject(self, name: str, why: str) -> None:
        with self._lock:
            self.rejected += 1
            repeated = self._said.get(name) == why
            self._said[name] = why
        if not repeated:
            log.warning("Home Assistant: skipped %s", why)
