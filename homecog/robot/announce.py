"""The running robot announced to Home Assistant by MQTT discovery: its
decisions and actions become the state of its entities there
(:class:`~homecog.context.ha_discovery.HomeAssistantDiscovery`), and the undo button pressed in
Home Assistant's app undoes its last action as the HMI's undo does — the devices switched back,
its services learned as rejections where it acted.
"""

from __future__ import annotations

import functools
import logging
from typing import Any

from homecog.context.ha_discovery import HomeAssistantDiscovery
from homecog.context.mqtt_broker import DEFAULT_PREFIX
from homecog.errors import HomecogError
from homecog.robot.runtime import Runtime

log = logging.getLogger("homecog.robot")


def announce(runtime: Runtime, url: str, *, prefix: str = DEFAULT_PREFIX) -> HomeAssistantDiscovery:
    """Discovery on the broker at ``url`` for ``runtime``'s home, told the robot's decisions and
    actions from now on; not started (``start()`` connects and announces)."""
    discovery = HomeAssistantDiscovery(
        runtime.home, url, on_undo=functools.partial(undo_last, runtime), prefix=prefix
    )
    runtime.announcers.append(functools.partial(_tell, discovery))
    return discovery


def _tell(discovery: HomeAssistantDiscovery, kind: str, data: Any) -> None:
    if kind == "decision":
        discovery.services(data["services"], explanations=data["explanations"], user=data["user"])
    elif kind == "action":
        discovery.action(data)


def undo_last(runtime: Runtime) -> dict[str, Any] | None:
    """Undo the robot's last action, as ``POST /api/actions/{id}/undo`` does for its user; the
    action as it is after that, or ``None`` when there is none. One already undone, or an undo
    that fails (the home away), is logged and left as it is."""
    latest = runtime.journal.recent(1)
    if not latest:
        log.info("undo from Home Assistant: the robot has done nothing yet")
        return None
    action = latest[0]
    try:
        runtime.undo(action.id)
    except (HomecogError, LookupError) as e:
        log.warning("undo from Home Assistant of action %d: %s", action.id, e)
    else:
        log.info("undone from Home Assistant: action %d (%s)", action.id, ", ".join(action.services))
    return action.as_dict()
