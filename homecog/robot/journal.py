"""What the robot did, when and why: its latest actions, each with the services it
carried out, the devices it switched, the context it acted in and the explanations of the
services, and which of its switches were undone (by a person's hand or from the HMI).

>>> journal = Journal(keep=2)
>>> a = journal.add(at=60.0, services=["TurnOnLamp"], switches=[("lamp", True)], context={}, user="default")
>>> journal.undoable("lamp", False, at=600.0, window=900.0) == (a, "lamp")
True
>>> journal.undoable("lamp", False, at=1000.0, window=900.0) is None   # past the undo window
True
"""

from __future__ import annotations

import itertools
import threading
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from homecog.home.states import state_word


@dataclass
class RobotAction:
    """One time the robot acted."""

    id: int
    at: float  # the source's clock
    services: list[str]
    switches: list[tuple[str, bool]]  # (device, state it switched it to), in order
    context: dict[str, str]  # the context it acted in (before it switched)
    user: str
    why: list[dict[str, Any]] = field(default_factory=list)  # the explanations of the services
    done: list[str] = field(default_factory=list)  # the plan's actions carried out
    undone: dict[str, str] = field(default_factory=dict)  # device -> by whom: "person" or "hmi"
    undone_here: bool = False  # undone from the HMI (its services rejected)
    wall: float = field(default_factory=time.time)

    def as_dict(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "at": self.wall,
            "home_time": self.context.get("time"),
            "services": self.services,
            "switches": [{"device": d, "state": state_word(on)} for d, on in self.switches],
            "user": self.user,
            "why": self.why,
            "actions": self.done,
            "undone": [{"device": d, "by": by} for d, by in dict(self.undone).items()],
            "undone_here": self.undone_here,
        }


class Journal:
    """The robot's latest ``keep`` actions, newest last."""

    def __init__(self, keep: int = 100) -> None:
        self._actions: deque[RobotAction] = deque(maxlen=keep)
        self._ids = itertools.count(1)
        self._lock = threading.Lock()

    def add(self, **fields: Any) -> RobotAction:
        action = RobotAction(id=next(self._ids), **fields)
        with self._lock:
            self._actions.append(action)
        return action

    def recent(self, limit: int = 20) -> list[RobotAction]:
        """The latest actions, newest first."""
        with self._lock:
            return list(reversed(self._actions))[:limit]

    def get(self, ident: int) -> RobotAction | None:
        with self._lock:
            return next((a for a in self._actions if a.id == ident), None)

    def undoable(self, device: str, on: bool, *, at: float, window: float) -> tuple[RobotAction, str] | None:
        """The robot's latest action within ``window`` seconds that switched ``device`` to the
        other state and is not undone: a person switching it to ``on`` now undoes it."""
        with self._lock:
            for action in reversed(self._actions):
                age = at - action.at
                if age > window:
                    return None  # the older ones are older still
                if age < 0:
                    continue  # after now: a clock that went back
                for d, state in reversed(action.switches):
                    if d == device:
                        if state != on and device not in action.undone:
                            return action, device
                        return None  # its latest switch of the device is as the person wants
        return None
