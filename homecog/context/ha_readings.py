"""The values of a home read from Home Assistant's entities: each state that arrives taken into
the features and devices its entity holds, the snapshot of them, and the states that cannot be
read (``unavailable``, a number outside every bin, a word the section does not map) logged once,
counted and skipped, the feature keeping its last good value.

:class:`EntityReadings` is the half of :class:`~homecog.context.home_assistant.HomeAssistantSource`
that holds the values; :class:`~homecog.context.ha_connection.HomeAssistantConnection` hands it the
states it receives.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from datetime import datetime
from typing import Any

from homecog.context import ConnectedSource, DeviceChange
from homecog.errors import ContextError
from homecog.home.clock import format_clock
from homecog.home.home_assistant import DeviceEntity, FeatureEntity, feature_value
from homecog.home.model import Home
from homecog.home.states import state_word

log = logging.getLogger(__name__)


class EntityReadings(ConnectedSource):
    """The features and devices of a home as their entities' states last said them."""

    home: Home
    rejected: int
    on_change: Callable[[dict[str, str]], None] | None
    on_state: Callable[[str, Mapping[str, Any], float], None] | None
    _readers: dict[str, list[FeatureEntity | DeviceEntity]]  # entity -> what it holds
    _clocks: list[str]  # clock features without an entity: they read the local clock
    _updated: dict[str, str]  # entity -> last_updated of the state taken
    _said: dict[str, str]  # name -> the last skip logged, so a stuck state logs once
    _dirty: bool  # a value changed since on_change was last called
    _lock: threading.Lock
    _device_names: frozenset[str]

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
                    name, value = m.device, state_word(m.state(str(state.get("state"))))
            except ContextError as e:
                self._reject(m.feature if isinstance(m, FeatureEntity) else m.device, str(e))
                continue
            accepted[name] = value
            self._said.pop(name, None)
        with self._changed:
            if updated and updated < self._updated.get(entity, ""):
                return  # older than what was taken: an event overtaken by the snapshot
            self._updated[entity] = updated
            changed = {n: v for n, v in accepted.items() if self._values.get(n) != v}
            complete = all(n in self._values for n in self._names)
            before = dict(self._values) if complete else None
            self._dirty |= bool(changed)
            self._values.update(accepted)
            self._changed.notify_all()
        if before is not None:
            self._tell_devices(changed, before, state.get("context") or {}, received)

    def _tell_devices(
        self, changed: Mapping[str, str], values: dict[str, str], context: Mapping[str, Any], at: float
    ) -> None:
        """Tell the listeners of each device that changed, with who changed it: the user of the
        state's context, an automation where the context has a parent."""
        now = datetime.now()
        clock = format_clock(now.hour + now.minute / 60)
        before = {**values, **dict.fromkeys(self._clocks, clock)}
        order = self.home.feature_names + self.home.device_names
        for name, value in changed.items():
            if name in self._device_names:
                snapshot = {n: before[n] for n in order}
                user = context.get("user_id")
                automation = context.get("parent_id") is not None
                self._tell(DeviceChange(name, value == "on", snapshot, at, user, automation))
                before[name] = value

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
            repeated = self._said.get(name) == why
            self._said[name] = why
        if not repeated:
            log.warning("Home Assistant: skipped %s", why)
        with self._lock:  # counted once logged: whoever waits on the count finds the log line
            self.rejected += 1
