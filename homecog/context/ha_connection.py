"""The connection to a Home Assistant instance, on an event loop of its own in a thread: connect
with the token, subscribe to ``state_changed``, take a snapshot of the states (``get_states``),
listen until the connection closes, and connect again with a delay that doubles from
:data:`MIN_RECONNECT_DELAY` up to :data:`MAX_RECONNECT_DELAY`; the robot's switches go out as
service calls (``call_service``).

:class:`HomeAssistantConnection` is the half of
:class:`~homecog.context.home_assistant.HomeAssistantSource` that talks to the instance; what it
receives it hands to :class:`~homecog.context.ha_readings.EntityReadings`.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import time
from typing import Any

from homecog.context.ha_client import connect, reason
from homecog.context.ha_readings import EntityReadings
from homecog.errors import HomeAssistantError
from homecog.home.home_assistant import HomeAssistantMap, unknown_entities

log = logging.getLogger(__name__)

MIN_RECONNECT_DELAY = 0.25  # seconds; doubled after each failed attempt ...
MAX_RECONNECT_DELAY = 2.0  # ... up to this, so the robot is back within ~2 s of the instance


class HomeAssistantConnection(EntityReadings):
    """The client's thread: the sessions with the instance, one after another, and the service calls."""

    url: str
    ws_url: str
    token: str
    connect_timeout: float
    mapping: HomeAssistantMap
    version: str | None
    user_id: str | None
    last_error: str | None
    connected_since: float | None
    reconnects: int
    skipped_switches: int
    _loop: asyncio.AbstractEventLoop | None
    _task: asyncio.Task[None] | None
    _client: Any
    _first: concurrent.futures.Future[None]  # start()'s answer: the first session, or its error

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
