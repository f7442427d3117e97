"""Carrying out a plan on the floor plan: the robot drives collision-free paths
between places, every other action takes its time, and the trajectory and a timeline are
recorded. What an action needs and what it changes (the robot is where it picks, holds what it
hands over; switches change the devices) is the planning domain's own actions applied to a
planning state: the simulator adds only what is physical.

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
from homecog.home.states import state_word
from homecog.planning import Domain, State, initial_state, make_domain
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
    device states at the end, what the robot holds and the planning state it ends in."""

    actions: list[tuple[str, ...]]
    timeline: list[dict[str, Any]]
    seconds: float
    distance_m: float
    trajectory: np.ndarray
    devices: dict[str, bool] = field(default_factory=dict)
    held: str | None = None
    state: State | None = None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-able summary (the trajectory left out)."""
        return {
            "actions": [list(a) for a in self.actions],
            "seconds": self.seconds,
            "distance_m": self.distance_m,
            "timeline": [dict(row, action=list(row["action"])) for row in self.timeline],
            "devices": {d: state_word(v) for d, v in self.devices.items()},
        }


class Simulation:
    """A plan carried out one action at a time (:meth:`run`), from a planning state: the state
    now, the clock, the distance driven, the timeline and the trajectory so far.

    >>> from homecog.home import load_home
    >>> sim = Simulation(load_home("paper"))
    >>> sim.run(("move", "charger", "dispenser"))["end"] > 0, sim.state.robot
    (True, 'dispenser')
    >>> sim.run(("dock", "charger"))
    Traceback (most recent call last):
    ...
    homecog.errors.PlanningError: action 2 ('dock', 'charger'): the robot is at 'dispenser', not at 'charger'
    """

    def __init__(
        self,
        home: Home,
        state: State | None = None,
        *,
        robot: DiffDrive | None = None,
        domain: Domain | None = None,
        pose: tuple[float, float, float] | None = None,
    ) -> None:
        layout = home.layout
        if layout is None:
            raise PlanningError(f"home {home.name!r} has no layout; add a layout section to simulate")
        self.home, self.layout = home, layout
        self.robot = robot or DiffDrive()
        self.domain = domain or make_domain(home)
        self.state = state.copy() if state is not None else initial_state(home)
        _check_place(layout, self.state.robot, "the robot's start")
        x, y, theta = pose if pose is not None else (*layout.place(self.state.robot), 0.0)
        self.clock, self.distance_m = 0.0, 0.0
        self.actions: list[tuple[str, ...]] = []
        self.timeline: list[dict[str, Any]] = []
        self._chunks = [np.array([[0.0, x, y, theta]])]

    @property
    def pose(self) -> tuple[float, float, float]:
        """Where the robot is now: ``x, y, theta``."""
        _, x, y, theta = self._chunks[-1][-1]
        return float(x), float(y), float(theta)

    def run(self, action: Action) -> dict[str, Any]:
        """Carry out one action and return its row of the timeline. Raises
        :class:`PlanningError` naming the action and why when it does not apply (the domain's
        reason: an unknown kind or place, the robot elsewhere, ...) or its path cannot be
        driven; the simulation is then as it was."""
        action = tuple(action)
        index = len(self.timeline) + 1
        where = f"action {index} {action}"
        why = self.domain.why_not(self.state, action)
        if why is not None:
            raise PlanningError(f"{where}: {why}")
        poses = None
        if action[0] == "move":
            poses = self.robot.follow(
                plan_path(self.layout, action[1], action[2], radius=self.robot.radius),
                theta=self.pose[2],
                t=self.clock,
            )
        return self.record(action, poses)

    def record(self, action: Action, poses: np.ndarray | None = None) -> dict[str, Any]:
        """Record an action carried out and return its row of the timeline: a move by its
        ``poses`` (rows ``t, x, y, theta`` after the clock now; none where it did not move),
        any other action by its duration (:func:`action_seconds`) on the spot. The planning
        state changes by the domain's action (:class:`PlanningError` where it does not apply).
        A body other than the simulator's own drives its path and records it here."""
        action = tuple(action)
        after = self.domain.apply(self.state, action)
        kind, distance, begin = action[0], 0.0, self.clock
        if kind == "move":
            if poses is not None and len(poses):
                steps = np.diff(np.vstack([self._chunks[-1][-1:], poses])[:, 1:3], axis=0)
                distance = float(np.hypot(steps[:, 0], steps[:, 1]).sum())
                self.clock = round(float(poses[-1, 0]), 6)
                self._chunks.append(poses)
        else:
            self.clock = round(self.clock + action_seconds(action), 6)
            last = self._chunks[-1][-1]
            self._chunks.append(np.array([[self.clock, last[1], last[2], last[3]]]))
        self.state = after
        self.distance_m += distance
        self.actions.append(action)
        row = {
            "index": len(self.timeline) + 1,
            "action": list(action),
            "start": begin,
            "end": self.clock,
            "distance_m": distance,
        }
        self.timeline.append(row)
        return row

    def result(self) -> SimulationResult:
        """What happened so far."""
        return SimulationResult(
            actions=list(self.actions),
            timeline=list(self.timeline),
            seconds=self.clock,
            distance_m=self.distance_m,
            trajectory=np.vstack(self._chunks),
            devices=dict(self.state.devices),
            held=self.state.holding,
            state=self.state.copy(),
        )


def simulate(
    home: Home,
    actions: Sequence[Action],
    *,
    state: State | None = None,
    devices: Mapping[str, bool] | None = None,
    user: str | None = None,
    start: str | None = None,
    robot: DiffDrive | None = None,
) -> SimulationResult:
    """Run ``actions`` (a plan's atomic actions) on ``home``'s floor plan.

    They start from ``state``, the planning state the plan was made from (``Plan.start``;
    default: the home's initial state); ``devices`` (off where it says nothing), the user's
    place ``user`` and the robot's ``start`` place change it. The robot faces +x. Raises
    :class:`PlanningError` for an action of unknown kind or shape, an unknown place, device or
    object, an action whose preconditions do not hold where the robot is (the planning
    domain's reason), and a path that cannot be driven.

    >>> from homecog.home import load_home
    >>> plan = [("move", "charger", "dispenser"), ("pick", "cup", "dispenser"), ("dock", "charger")]
    >>> simulate(load_home("paper"), plan)
    Traceback (most recent call last):
    ...
    homecog.errors.PlanningError: action 3 ('dock', 'charger'): the robot is at 'dispenser', not at 'charger'
    """
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to simulate")
    state = state.copy() if state is not None else initial_state(home, user=user)
    if user is not None:
        _check_place(layout, user, "the user's place")
        state.user = user
    known = home.device_names
    if devices is not None:
        state.devices = dict.fromkeys(known, False)
        for name, value in devices.items():
            if name not in state.devices:
                raise PlanningError(f"unknown device {name!r}; the home has {', '.join(known)}")
            state.devices[name] = bool(value)
    if start is not None:
        state.robot = start
    simulation = Simulation(home, state, robot=robot)
    for action in actions:
        simulation.run(action)
    return simulation.result()


def _check_place(layout: Layout, name: str, where: str) -> None:
    if not layout.has_place(name):
        known = ", ".join([*layout.places, *layout.rooms])
        raise PlanningError(f"{where}: unknown place {name!r}; the layout has {known}")
