"""The planning state: where the robot is and what it holds, where each object and
the user are, the device states, and whether the robot is docked.

>>> from homecog.home import load_home
>>> state = initial_state(load_home("paper"), {"window": "on"}, user="sofa")
>>> state.robot, state.user, state.objects, state.devices["window"], state.devices["lamp"]
('charger', 'sofa', {'cup': 'dispenser'}, True, False)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.home.states import parse_state

USER = "user"
"""The one person of the planning state (the argument of ``hand_over``)."""
HELD = "robot"
"""Where an object is while the robot holds it (``State.objects``)."""


@dataclass
class State:
    """The planning state: places are names of layout places (or rooms)."""

    robot: str
    user: str
    holding: str | None = None
    objects: dict[str, str] = field(default_factory=dict)  # object -> place (or HELD)
    devices: dict[str, bool] = field(default_factory=dict)
    docked: bool = False

    def copy(self) -> State:
        return State(self.robot, self.user, self.holding, dict(self.objects), dict(self.devices), self.docked)


def device_states(home: Home, context: Mapping[str, object] | None = None) -> dict[str, bool]:
    """Every device of the home as the context says (``on``/``off`` or a bool), off where it says
    nothing."""
    context = context or {}
    states = {}
    for d in home.devices:
        value = context.get(d.name, False)
        states[d.name] = value if isinstance(value, bool) else parse_state(value)
    return states


def initial_state(
    home: Home, context: Mapping[str, object] | None = None, *, user: str | None = None
) -> State:
    """The planning state of a home: the robot at its start place, objects where the layout
    puts them, devices as the context says (off where it says nothing), and the user at the
    place named by ``user``, else by the context's ``location``, else at the first place
    that is a value of a context feature."""
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to plan")
    context = context or {}
    if user is None and "location" in context:
        user = str(context["location"])
        if not layout.has_place(user):
            raise PlanningError(f"the user's location {user!r} is not a place or room of the layout")
    if user is None:
        values = [v for f in home.features if f.is_discrete for v in f.values]
        user = next((v for v in values if layout.has_place(v)), layout.robot)
    elif not layout.has_place(user):
        raise PlanningError(f"unknown place {user!r} for the user; the layout has {', '.join(layout.places)}")
    return State(
        robot=layout.robot, user=user, objects=dict(layout.objects), devices=device_states(home, context)
    )


def observed_state(home: Home, context: Mapping[str, object], robot: State | None = None) -> State:
    """The planning state as observed: the devices and the user's place from ``context`` (a
    context source's snapshot), the rest (where the robot is, what it holds, where the objects
    are, whether it is docked) from ``robot``, the robot's own state (default: as the home
    starts). The user stays where ``robot`` has them while the context's location is no place
    of the layout. A home without a layout has no places: its state serves IoT switches only.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> robot = initial_state(home, user="sofa")
    >>> robot.robot = "bed"
    >>> state = observed_state(home, {"location": "table", "window": "on"}, robot)
    >>> state.robot, state.user, state.devices["window"]
    ('bed', 'table', True)
    """
    devices = device_states(home, context)
    layout = home.layout
    if layout is None:
        return State(robot="", user="", devices=devices)
    state = robot.copy() if robot is not None else initial_state(home)
    state.devices = devices
    location = context.get("location")
    if location is not None and layout.has_place(str(location)):
        state.user = str(location)
    return state
