"""The HTN domain of a home's services (the paper's §3.3, Fig. 7), written once as data
(:mod:`homecog.planning.schema`) and derived from the home's devices (``iot``), services and
layout, so that any home with a layout plans. The planner's Python functions
(:mod:`homecog.planning.compile`) and the HDDL export (:mod:`homecog.planning.hddl`) are both
generated from it.

The planning state (:class:`~homecog.planning.state.State`) holds the robot's place, what it
holds, where each object is, where the user is and the device states. Atomic actions:

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
* ``goto place`` → nothing where the robot is already there (a plan has no move from a place
  to itself), else ``move`` from wherever the robot is.

>>> from homecog.home import load_home
>>> from homecog.planning import plan_services
>>> plan = plan_services(load_home("paper"), ["SendDrinks"], user="sofa")
>>> plan.actions
[('move', 'charger', 'dispenser'), ('pick', 'cup', 'dispenser'), ('pour', 'cup', 'dispenser'), \
('move', 'dispenser', 'sofa'), ('hand_over', 'cup', 'user')]
>>> domain = make_domain(load_home("paper"))
>>> domain.why_not(plan.start, ("pick", "cup", "dispenser"))
"the robot is at 'charger', not at 'dispenser'"
"""

from __future__ import annotations

import functools
import re
from typing import Any

from homecog.home.model import Home
from homecog.planning.compile import compile_domain
from homecog.planning.planner import Domain
from homecog.planning.schema import (
    SETTINGS,
    ActionSchema,
    MethodSchema,
    TaskSchema,
    action,
    method,
    parse_params,
)
from homecog.planning.state import HELD, USER

__all__ = [
    "ACTIONS",
    "METHOD_SCHEMAS",
    "TASKS",
    "make_domain",
    "on_off",
    "service_methods",
    "words",
]

AT = "the robot is at {s.robot!r}, not at {%s!r}"
SWITCH = ("(when (= ?setting on) (is-on ?device))", "(when (= ?setting off) (not (is-on ?device)))")

ACTIONS: tuple[ActionSchema, ...] = (
    action(
        "move",
        "?origin - place ?target - place",
        pre=[("(robot-at ?origin)", AT % "origin")],
        effects=["(robot-at ?target)", "(not (robot-at ?origin))", "(not (docked))"],
        # goto never plans a move to where the robot is (already_there), but the action takes
        # one; in HDDL it would delete and add (robot-at p) at once, which Aries takes for a
        # conflict
        variants=[("move", {}), ("stay", {"?target": "?origin"})],
    ),
    action(
        "pick",
        "?obj - item ?place - place",
        pre=[
            ("(robot-at ?place)", AT % "place"),
            ("(hand-empty)", "the robot already holds {s.holding!r}"),
            ("(at ?obj ?place)", "{obj!r} is not at {place!r}"),
        ],
        effects=["(holding ?obj)", "(not (hand-empty))", "(not (at ?obj ?place))"],
    ),
    action(
        "pour",
        "?obj - item ?place - place",
        pre=[
            ("(holding ?obj)", "the robot holds {s.holding!r}, not {obj!r}"),
            ("(robot-at ?place)", AT % "place"),
        ],
    ),
    action(
        "hand_over",
        "?obj - item ?who - person",
        lets=["(user-at ?who ?where)"],
        pre=[
            ("(holding ?obj)", "the robot holds {s.holding!r}, not {obj!r}"),
            ("(robot-at ?where)", "the robot is at {s.robot!r}, not with the user at {where!r}"),
        ],
        effects=["(not (holding ?obj))", "(hand-empty)", "(at ?obj ?where)"],
    ),
    action("speak", "?text - message"),
    action(
        "switch_iot",
        "?device - device ?setting - setting",
        pre=[("(iot ?device)", "{device!r} has no IoT switch")],
        effects=SWITCH,
        # HDDL's effects may not depend on an argument without conditional effects
        variants=[("switch-iot-on", {"?setting": "on"}), ("switch-iot-off", {"?setting": "off"})],
    ),
    action(
        "switch_by_hand",
        "?device - device ?setting - setting",
        lets=[("(device-at ?device ?where)", "device {device!r} has no place or room in the layout")],
        pre=[("(robot-at ?where)", AT % "where")],
        effects=SWITCH,
        variants=[("switch-by-hand-on", {"?setting": "on"}), ("switch-by-hand-off", {"?setting": "off"})],
    ),
    action("dock", "?place - place", pre=[("(robot-at ?place)", AT % "place")], effects=["(docked)"]),
)

TASKS: tuple[TaskSchema, ...] = (
    TaskSchema("goto", parse_params("?place - place")),
    TaskSchema("switch", parse_params("?device - device ?setting - setting")),
    TaskSchema("fetch", parse_params("?obj - item")),
    TaskSchema("fill", parse_params("?obj - item")),
    TaskSchema("deliver", parse_params("?obj - item")),
)

# Methods read the state when they are decomposed (left to right), so goto moves from wherever
# the robot really is; they are tried in this order.
METHOD_SCHEMAS: tuple[MethodSchema, ...] = (
    # a goto where the robot already is has nothing to do: no zero-length move in a plan
    method("already_there", "goto", pre=["(robot-at ?place)"]),
    method("goto", "goto", lets=["(robot-at ?here)"], subtasks=[("move", "?here", "?place")]),
    method("by_iot", "switch", pre=["(iot ?device)"], subtasks=[("switch_iot", "?device", "?setting")]),
    method(
        "by_hand",
        "switch",
        lets=["(device-at ?device ?where)"],
        subtasks=[("goto", "?where"), ("switch_by_hand", "?device", "?setting")],
    ),
    method("fetch_held", "fetch", pre=["(holding ?obj)"]),
    method(
        "fetch_from_place",
        "fetch",
        lets=["(at ?obj ?where)"],
        pre=["(hand-empty)"],
        subtasks=[("goto", "?where"), ("pick", "?obj", "?where")],
    ),
    method(
        "fill_here",
        "fill",
        lets=["(source ?obj ?src)"],
        pre=["(robot-at ?src)"],
        subtasks=[("pour", "?obj", "?src")],
    ),
    method(
        "fill_at_source",
        "fill",
        lets=["(source ?obj ?src)"],
        subtasks=[("goto", "?src"), ("pour", "?obj", "?src")],
    ),
    method(
        "deliver_to_user",
        "deliver",
        lets=[f"(user-at {USER} ?where)"],
        subtasks=[("goto", "?where"), ("hand_over", "?obj", USER)],
    ),
)


def on_off(value: bool) -> str:
    return SETTINGS[0] if value else SETTINGS[1]


def words(service: str) -> str:
    """A service name as words: ``CallToWakeup`` -> ``call to wakeup``."""
    return " ".join(w.lower() for w in re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+", service)) or service


def service_methods(home: Home) -> tuple[MethodSchema, ...]:
    """The one method of each service's task, in the home's order."""
    layout = home.layout
    out = []
    for service in home.services:
        errand = layout.errand(service.name) if layout is not None else None
        out.append(
            _service_method(
                service.name,
                service.sets,
                *(
                    (errand.bring, errand.pour, errand.dock, errand.say)
                    if errand is not None
                    else (None, False, None, None)
                ),
            )
        )
    return tuple(out)


@functools.lru_cache(maxsize=4096)  # the same schema object for the same service (compile.py)
def _service_method(
    name: str,
    sets: tuple[tuple[str, bool], ...],
    bring: str | None,
    pour: bool,
    dock: str | None,
    say: str | None,
) -> MethodSchema:
    if sets:
        return method("switch_devices", name, subtasks=[("switch", d, on_off(value)) for d, value in sets])
    if bring is not None:
        subtasks = [("fetch", bring), *([("fill", bring)] if pour else []), ("deliver", bring)]
        return method("bring", name, subtasks=subtasks)
    if dock is not None:
        return method("go_and_dock", name, subtasks=[("goto", dock), ("dock", dock)])
    text = say if say is not None else words(name)
    lets = [f"(user-at {USER} ?where)"]
    return method("go_and_speak", name, lets=lets, subtasks=[("goto", "?where"), ("speak", text)])


def service_tasks(home: Home) -> tuple[TaskSchema, ...]:
    return tuple(_service_task(s.name) for s in home.services)


@functools.lru_cache(maxsize=4096)
def _service_task(name: str) -> TaskSchema:
    return TaskSchema(name)


def tables(home: Home) -> dict[str, Any]:
    """The home's constants and tables the domain's functions read, and the checks of each
    type of argument (a reason, or ``None`` for a fitting value)."""
    layout = home.layout
    devices = home.device_names
    device_place = {}
    for d in devices:
        try:
            device_place[d] = layout.device_place(d) if layout is not None else None
        except KeyError:  # an IoT device without a place is never switched by hand
            device_place[d] = None
    places = [*layout.places, *layout.rooms] if layout is not None else []
    objects = list(layout.objects) if layout is not None else []
    known_devices, known_places = set(devices), set(places)

    def check_place(x: str) -> str | None:
        return None if x in known_places else f"unknown place {x!r}; the layout has {', '.join(places)}"

    def check_device(x: str) -> str | None:
        return None if x in known_devices else f"unknown device {x!r}; the home has {', '.join(devices)}"

    def check_item(x: str) -> str | None:
        return (
            None if x in objects else f"unknown object {x!r}; the layout has {', '.join(objects) or 'none'}"
        )

    def check_person(x: str) -> str | None:
        return None if x == USER else f"unknown person {x!r}; expected {USER!r}"

    def check_setting(x: str) -> str | None:
        return None if x in SETTINGS else f"expected 'on' or 'off', got {x!r}"

    return {
        "HELD": HELD,
        "USER": USER,
        "IOT": frozenset(d.name for d in home.devices if d.iot),
        "DEVICE_PLACE": {d: p for d, p in device_place.items() if p is not None},
        "SOURCE": dict(layout.objects) if layout is not None else {},
        "CHECK": {
            "place": check_place,
            "device": check_device,
            "item": check_item,
            "person": check_person,
            "setting": check_setting,
            "message": lambda x: None,
        },
    }


def make_domain(home: Home) -> Domain:
    """The HTN domain of a home (its layout, if any, gives places for by-hand switching)."""
    return compile_domain(
        home.name, ACTIONS, TASKS + service_tasks(home), METHOD_SCHEMAS + service_methods(home), tables(home)
    )
