"""The HTN domain of a home's services (SPEC §8; the paper's §3.3, Fig. 7), derived from its
devices (``iot``), services and layout, so that any home with a layout plans.

The planning state holds the robot's place, what it holds, where each object is, where the
user is and the device states. Atomic actions:

========================  ==================================================================
``move from to``          the robot goes from one place to another
``pick obj place``        takes an object from where it is (hands empty)
``pour obj place``        fills the held cup at the place it came from (the dispenser)
``hand_over obj user``    gives the held object to the user (the robot is with the user)
``speak text``            says something to the user
``switch_iot dev on``     switches a device with ``iot: true`` by an IoT command
``switch_by_hand dev on`` switches any device by hand, at the device's place
``dock place``            docks at a charger
========================  ==================================================================

Compound tasks and their methods, tried in order:

* a service that sets devices → ``switch dev state`` for each; ``switch`` → ``switch_iot``
  where the device has ``iot: true``, else ``goto`` the device and ``switch_by_hand``;
* an interaction service by its errand (``layout.errands``): ``bring`` → ``fetch``, ``fill``
  (with ``pour``), ``deliver``; ``dock`` → ``goto``, ``dock``; ``say`` → ``goto`` the user,
  ``speak``; without an errand: ``goto`` the user and speak the service's name;
* ``goto place`` → ``move`` from wherever the robot is.

>>> from homecog.home import load_home
>>> from homecog.planning import plan_services
>>> plan = plan_services(load_home("paper"), ["SendDrinks"], user="sofa")
>>> plan.actions
[('move', 'charger', 'dispenser'), ('pick', 'cup', 'dispenser'), ('pour', 'cup', 'dispenser'), \
('move', 'dispenser', 'sofa'), ('hand_over', 'cup', 'user')]
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Any

from homecog.home.layout import Layout
from homecog.home.model import Home
from homecog.planning.planner import Domain, Method, Task

USER = "user"


@dataclass
class State:
    """The planning state: places are names of layout places (or rooms)."""

    robot: str
    user: str
    holding: str | None = None
    objects: dict[str, str] = field(default_factory=dict)  # object -> place (or "robot")
    devices: dict[str, bool] = field(default_factory=dict)
    docked: bool = False

    def copy(self) -> State:
        return State(self.robot, self.user, self.holding, dict(self.objects), dict(self.devices), self.docked)


def on_off(value: bool) -> str:
    return "on" if value else "off"


def words(service: str) -> str:
    """A service name as words: ``CallToWakeup`` -> ``call to wakeup``."""
    return " ".join(w.lower() for w in re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+", service)) or service


# -- actions: (state, *args) -> state | None ------------------------------------------------
def move(s: State, origin: str, target: str) -> State | None:
    if s.robot != origin:
        return None
    s.robot, s.docked = target, False
    return s


def pick(s: State, obj: str, place: str) -> State | None:
    if s.robot != place or s.holding is not None or s.objects.get(obj) != place:
        return None
    s.holding, s.objects[obj] = obj, "robot"
    return s


def pour(s: State, obj: str, place: str) -> State | None:
    return s if s.holding == obj and s.robot == place else None


def hand_over(s: State, obj: str, who: str) -> State | None:
    if s.holding != obj or s.robot != s.user or who != USER:
        return None
    s.holding, s.objects[obj] = None, s.user
    return s


def speak(s: State, text: str) -> State | None:
    return s


def dock(s: State, place: str) -> State | None:
    if s.robot != place:
        return None
    s.docked = True
    return s


def _switch_action(home: Home, layout: Layout | None, by_hand: bool) -> Any:
    iot = {d.name: d.iot for d in home.devices}

    def switch_iot(s: State, device: str, state: str) -> State | None:
        if not iot.get(device, False):
            return None
        s.devices[device] = state == "on"  # switching to the state it is in still happens
        return s

    def switch_by_hand(s: State, device: str, state: str) -> State | None:
        if device not in iot or layout is None or s.robot != layout.device_place(device):
            return None
        s.devices[device] = state == "on"
        return s

    return switch_by_hand if by_hand else switch_iot


# -- methods: (state, *args) -> subtasks | None ---------------------------------------------
def goto(s: State, place: str) -> list[Task]:
    return [("move", s.robot, place)]


def _make_methods(home: Home, layout: Layout | None) -> dict[str, list[Method]]:
    iot = {d.name: d.iot for d in home.devices}

    def by_iot(s: State, device: str, state: str) -> list[Task] | None:
        return [("switch_iot", device, state)] if iot[device] else None

    def by_hand(s: State, device: str, state: str) -> list[Task] | None:
        if layout is None:
            return None
        return [("goto", layout.device_place(device)), ("switch_by_hand", device, state)]

    def fetch_held(s: State, obj: str) -> list[Task] | None:
        return [] if s.holding == obj else None

    def fetch_from_place(s: State, obj: str) -> list[Task] | None:
        where = s.objects.get(obj)
        if where is None or where == "robot" or s.holding is not None:
            return None
        return [("goto", where), ("pick", obj, where)]

    def fill_here(s: State, obj: str) -> list[Task] | None:
        source = layout.objects.get(obj) if layout is not None else None
        return [("pour", obj, source)] if source is not None and s.robot == source else None

    def fill_at_source(s: State, obj: str) -> list[Task] | None:
        source = layout.objects.get(obj) if layout is not None else None
        return None if source is None else [("goto", source), ("pour", obj, source)]

    def deliver_to_user(s: State, obj: str) -> list[Task]:
        return [("goto", s.user), ("hand_over", obj, USER)]

    methods: dict[str, list[Method]] = {
        "goto": [goto],
        "switch": [by_iot, by_hand],
        "fetch": [fetch_held, fetch_from_place],
        "fill": [fill_here, fill_at_source],
        "deliver": [deliver_to_user],
    }
    for service in home.services:
        methods[service.name] = [_service_method(service.name, service.sets, layout)]
    return methods


def _service_method(name: str, sets: tuple[tuple[str, bool], ...], layout: Layout | None) -> Method:
    if sets:

        def switch_devices(s: State) -> list[Task]:
            return [("switch", device, on_off(value)) for device, value in sets]

        return switch_devices
    errand = layout.errand(name) if layout is not None else None
    if errand is not None and errand.bring is not None:
        obj, fill = errand.bring, errand.pour

        def bring(s: State) -> list[Task]:
            return [("fetch", obj), *([("fill", obj)] if fill else []), ("deliver", obj)]

        return bring
    if errand is not None and errand.dock is not None:
        place = errand.dock

        def go_and_dock(s: State) -> list[Task]:
            return [("goto", place), ("dock", place)]

        return go_and_dock
    text = errand.say if errand is not None and errand.say is not None else words(name)

    def go_and_speak(s: State) -> list[Task]:
        return [("goto", s.user), ("speak", text)]

    return go_and_speak


def make_domain(home: Home) -> Domain:
    """The HTN domain of a home (its layout, if any, gives places for by-hand switching)."""
    layout = home.layout
    actions = {
        "move": move,
        "pick": pick,
        "pour": pour,
        "hand_over": hand_over,
        "speak": speak,
        "switch_iot": _switch_action(home, layout, by_hand=False),
        "switch_by_hand": _switch_action(home, layout, by_hand=True),
        "dock": dock,
    }
    return Domain(name=home.name, actions=actions, methods=_make_methods(home, layout))
