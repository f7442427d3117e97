"""Carrying out a plan on the floor plan (SPEC §8): the robot drives collision-free paths
between places, every other action takes its time, switches change the devices, and the
trajectory and a timeline are recorded.

Durations of the actions other than ``move`` (seconds), after the paper's Fig. 15 run:

==================  ========================
``pick``            4
``pour``            6
``hand_over``       3
``speak``           1 + 0.4 per word
``switch_iot``      0.5 (an IoT command)
``switch_by_hand``  3 (at the device's place)
``dock``            5
==================  ========================

>>> from homecog.home import load_home
>>> result = simulate(load_home("paper"), [("switch_iot", "window", "off"), ("move", "charger", "table")])
>>> result.devices["window"], round(result.seconds, 2), round(result.distance_m, 2)
(False, 8.95, 4.08)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from homecog.errors import PlanningError
from homecog.home.layout import Layout
from homecog.home.model import Home
from homecog.simulation.grid import plan_path
from homecog.simulation.robot import DiffDrive

Action = Sequence[str]

SECONDS = {
    "pick": 4.0,
    "pour": 6.0,
    "hand_over": 3.0,
    "switch_iot": 0.5,
    "switch_by_hand": 3.0,
    "dock": 5.0,
}
SPEAK_SECONDS, SPEAK_SECONDS_PER_WORD = 1.0, 0.4
# the number of strings in each kind of action, its kind included
_ARITY = {
    "move": 3,
    "pick": 3,
    "pour": 3,
    "hand_over": 3,
    "speak": 2,
    "switch_iot": 3,
    "switch_by_hand": 3,
    "dock": 2,
}


def action_seconds(action: Action) -> float:
    """How long an action other than ``move`` takes, in seconds.

    >>> action_seconds(("speak", "Good morning, it is time to get up."))
    4.2
    """
    if action[0] == "speak":
        return round(SPEAK_SECONDS + SPEAK_SECONDS_PER_WORD * len(action[1].split()), 6)
    return SECONDS[action[0]]


@dataclass
class SimulationResult:
    """What happened when a plan ran: the per-action timeline, the totals, the trajectory
    (one row ``t, x, y, theta`` per step; still rows where the robot works on the spot), the
    device states at the end and what the robot holds."""

    actions: list[tuple[str, ...]]
    timeline: list[dict[str, Any]]
    seconds: float
    distance_m: float
    trajectory: np.ndarray
    devices: dict[str, bool] = field(default_factory=dict)
    held: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able summary (the trajectory left out)."""
        return {
            "actions": [list(a) for a in self.actions],
            "seconds": self.seconds,
            "distance_m": self.distance_m,
            "timeline": [dict(row, action=list(row["action"])) for row in self.timeline],
            "devices": {d: "on" if v else "off" for d, v in self.devices.items()},
        }


def simulate(
    home: Home,
    actions: Sequence[Action],
    *,
    devices: Mapping[str, bool] | None = None,
    robot: DiffDrive | None = None,
    start: str | None = None,
) -> SimulationResult:
    """Run ``actions`` (a plan's atomic actions) on ``home``'s floor plan.

    The robot starts at ``start`` (default: the layout's ``robot`` place) facing +x, the
    devices as ``devices`` says (off where it says nothing). Raises :class:`PlanningError` for
    an action of unknown kind or shape, an unknown place or device, an action done somewhere
    other than where the robot is, and a path that cannot be driven.

    >>> from homecog.home import load_home
    >>> plan = [("move", "charger", "dispenser"), ("pick", "cup", "dispenser"), ("dock", "charger")]
    >>> simulate(load_home("paper"), plan)
    Traceback (most recent call last):
    ...
    homecog.errors.PlanningError: action 3 ('dock', 'charger'): the robot is at 'dispenser', not at 'charger'
    """
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to simulate (SPEC §8)")
    robot = robot or DiffDrive()
    known = [d.name for d in home.devices]
    state = dict.fromkeys(known, False)
    for name, value in (devices or {}).items():
        if name not in state:
            raise PlanningError(f"unknown device {name!r}; the home has {', '.join(known)}")
        state[name] = bool(value)
    at = start if start is not None else layout.robot
    _check_place(layout, at, "the robot's start")
    x, y = layout.place(at)
    chunks = [np.array([[0.0, x, y, 0.0]])]
    clock, total, held = 0.0, 0.0, None
    timeline: list[dict[str, Any]] = []
    plan = [tuple(a) for a in actions]

    for index, action in enumerate(plan, start=1):
        where = f"action {index} {action}"
        kind = action[0] if action else ""
        if kind not in _ARITY:
            raise PlanningError(f"{where}: unknown kind {kind!r}; expected one of {', '.join(_ARITY)}")
        if len(action) != _ARITY[kind] or not all(isinstance(a, str) for a in action):
            raise PlanningError(f"{where}: expected {_ARITY[kind]} strings for {kind}")
        distance, begin = 0.0, clock
        if kind == "move":
            origin, target = action[1], action[2]
            _check_place(layout, origin, where)
            _check_place(layout, target, where)
            _require_at(at, origin, where)
            poses = robot.follow(
                plan_path(layout, origin, target, radius=robot.radius),
                theta=float(chunks[-1][-1, 3]),
                t=clock,
            )
            if len(poses):
                steps = np.diff(np.vstack([chunks[-1][-1:], poses])[:, 1:3], axis=0)
                distance = float(np.hypot(steps[:, 0], steps[:, 1]).sum())
                clock = round(float(poses[-1, 0]), 6)
                chunks.append(poses)
            at = target
        else:
            if kind == "switch_by_hand":
                _require_at(at, _device_place(layout, action[1], known, where), where)
            elif kind in ("pick", "pour", "dock"):
                _check_place(layout, action[-1], where)
                _require_at(at, action[-1], where)
            if kind in ("switch_iot", "switch_by_hand"):
                device, value = action[1], action[2]
                if device not in state:
                    raise PlanningError(
                        f"{where}: unknown device {device!r}; the home has {', '.join(known)}"
                    )
                if value not in ("on", "off"):
                    raise PlanningError(f"{where}: expected 'on' or 'off', got {value!r}")
                state[device] = value == "on"
            elif kind == "pick":
                if held is not None:
                    raise PlanningError(f"{where}: the robot already holds {held!r}")
                held = action[1]
            elif kind == "hand_over":
                if held != action[1]:
                    raise PlanningError(f"{where}: the robot holds {held!r}, not {action[1]!r}")
                held = None
            clock = round(clock + action_seconds(action), 6)
            last = chunks[-1][-1]
            chunks.append(np.array([[clock, last[1], last[2], last[3]]]))
        total += distance
        timeline.append(
            {"index": index, "action": list(action), "start": begin, "end": clock, "distance_m": distance}
        )
    return SimulationResult(
        actions=plan,
        timeline=timeline,
        seconds=clock,
        distance_m=total,
        trajectory=np.vstack(chunks),
        devices=state,
        held=held,
    )


def _check_place(layout: Layout, name: str, where: str) -> None:
    if not layout.has_place(name):
        known = ", ".join([*layout.places, *layout.rooms])
        raise PlanningError(f"{where}: unknown place {name!r}; the layout has {known}")


def _require_at(at: str, place: str, where: str) -> None:
    if place != at:
        raise PlanningError(f"{where}: the robot is at {at!r}, not at {place!r}")


def _device_place(layout: Layout, device: str, known: list[str], where: str) -> str:
    if device not in known:
        raise PlanningError(f"{where}: unknown device {device!r}; the home has {', '.join(known)}")
    try:
        return layout.device_place(device)
    except KeyError:
        raise PlanningError(f"{where}: device {device!r} has no place or room in the layout") from None
