"""The planning domain of a home and a request as HDDL (the hierarchical PDDL of the IPC 2020
HTN track), so that other planners (unified-planning with Aries, PANDA, ...) read the same
problem that :func:`homecog.planning.plan_services` solves.

The HDDL domain is :mod:`homecog.planning.domain` written out for one home. Where the two
differ, it is for HDDL's sake, and :func:`actions_from_hddl` maps a plan back:

* ``object`` is PDDL's root type, so movable objects are of type ``item``; the user is a
  ``person`` and the texts the robot says are ``message`` constants, one per speaking service;
* a move to where the robot is (which our planner keeps in the plan: ``goto`` always moves)
  is the action ``stay``, since ``move p p`` would delete and add ``(robot-at p)`` at once,
  which Aries takes for two conflicting effects and never plans;
* actions that set a device to on or off are split by value (``switch-iot-on d`` is our
  ``switch_iot d on``), since the effect may not depend on an argument without conditional
  effects; ``hand-over`` and ``switch-by-hand-*`` carry the place where they happen;
* our methods are tried in order, HDDL's are a free choice: a later method gets the negation
  of what made an earlier one apply (``switch-by-hand-*`` needs ``(not (iot ?d))``,
  ``fill-at-source`` needs the robot elsewhere), so an HDDL planner finds the plan we find;
* names are lowercase identifiers: ``SendDrinks`` is the task ``send-drinks``; a name used
  for two things (the paper home's ``lamp`` is a device and a place) gets its type appended
  to the second (``lamp-place``).

>>> from homecog.home import load_home
>>> from homecog.planning import initial_state
>>> home = load_home("paper")
>>> print(domain_hddl(home).splitlines()[0])
(define (domain paper)
>>> problem = problem_hddl(home, ["SendDrinks", "CloseWindow"], initial_state(home, user="sofa"))
>>> print(problem[problem.index("(:htn"):].splitlines()[2].strip())
:ordered-subtasks (and (send-drinks) (close-window))
>>> actions_from_hddl(home, [("move", ["charger", "dispenser"]), ("hand-over", ["cup", "user", "sofa"]),
...                          ("switch-iot-off", ["window"]), ("speak", ["remind-to-sleep-msg"])])
[('move', 'charger', 'dispenser'), ('hand_over', 'cup', 'user'), ('switch_iot', 'window', 'off'), \
('speak', 'It is late; time to go to sleep.')]

``benchmarks/bench_planning.py`` compares our planner with unified-planning and Aries on these
files.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.planning.domain import USER, State, words
from homecog.planning.planner import Task

__all__ = ["actions_from_hddl", "domain_hddl", "hddl_name", "problem_hddl"]

TYPES = ("place", "item", "device", "person", "message", "setting")
PREDICATES = (
    "(robot-at ?p - place)",
    "(at ?i - item ?p - place)",
    "(holding ?i - item)",
    "(hand-empty)",
    "(user-at ?u - person ?p - place)",
    "(is-on ?d - device)",
    "(iot ?d - device)",
    "(device-at ?d - device ?p - place)",
    "(source ?i - item ?p - place)",
    "(docked)",
)


@dataclass(frozen=True)
class _Action:
    name: str
    parameters: str
    precondition: str
    effect: str


ACTIONS = (
    _Action(
        "move",
        "?from - place ?to - place",
        "(robot-at ?from)",
        "(and (not (robot-at ?from)) (robot-at ?to) (not (docked)))",
    ),
    _Action("stay", "?p - place", "(robot-at ?p)", "(not (docked))"),
    _Action(
        "pick",
        "?i - item ?p - place",
        "(and (robot-at ?p) (hand-empty) (at ?i ?p))",
        "(and (holding ?i) (not (hand-empty)) (not (at ?i ?p)))",
    ),
    _Action("pour", "?i - item ?p - place", "(and (holding ?i) (robot-at ?p))", "(and)"),
    _Action(
        "hand-over",
        "?i - item ?u - person ?p - place",
        "(and (holding ?i) (robot-at ?p) (user-at ?u ?p))",
        "(and (not (holding ?i)) (hand-empty) (at ?i ?p))",
    ),
    _Action("speak", "?m - message", "", "(and)"),
    _Action("switch-iot-on", "?d - device", "(iot ?d)", "(is-on ?d)"),
    _Action("switch-iot-off", "?d - device", "(iot ?d)", "(not (is-on ?d))"),
    _Action(
        "switch-by-hand-on", "?d - device ?p - place", "(and (device-at ?d ?p) (robot-at ?p))", "(is-on ?d)"
    ),
    _Action(
        "switch-by-hand-off",
        "?d - device ?p - place",
        "(and (device-at ?d ?p) (robot-at ?p))",
        "(not (is-on ?d))",
    ),
    _Action("dock", "?p - place", "(robot-at ?p)", "(docked)"),
)

TASKS = {
    "goto": "?p - place",
    "switch": "?d - device ?s - setting",
    "fetch": "?i - item",
    "fill": "?i - item",
    "deliver": "?i - item",
}


@dataclass(frozen=True)
class _Method:
    name: str
    parameters: str
    task: str
    precondition: str
    subtasks: tuple[str, ...]


METHODS = (
    _Method(
        "goto-move",
        "?p - place ?from - place",
        "(goto ?p)",
        "(and (robot-at ?from) (not (= ?from ?p)))",
        ("(move ?from ?p)",),
    ),
    _Method("goto-stay", "?p - place", "(goto ?p)", "(robot-at ?p)", ("(stay ?p)",)),
    _Method(
        "by-iot-on",
        "?d - device ?s - setting",
        "(switch ?d ?s)",
        "(and (iot ?d) (= ?s on))",
        ("(switch-iot-on ?d)",),
    ),
    _Method(
        "by-iot-off",
        "?d - device ?s - setting",
        "(switch ?d ?s)",
        "(and (iot ?d) (= ?s off))",
        ("(switch-iot-off ?d)",),
    ),
    _Method(
        "by-hand-on",
        "?d - device ?s - setting ?p - place",
        "(switch ?d ?s)",
        "(and (not (iot ?d)) (= ?s on) (device-at ?d ?p))",
        ("(goto ?p)", "(switch-by-hand-on ?d ?p)"),
    ),
    _Method(
        "by-hand-off",
        "?d - device ?s - setting ?p - place",
        "(switch ?d ?s)",
        "(and (not (iot ?d)) (= ?s off) (device-at ?d ?p))",
        ("(goto ?p)", "(switch-by-hand-off ?d ?p)"),
    ),
    _Method("fetch-held", "?i - item", "(fetch ?i)", "(holding ?i)", ()),
    _Method(
        "fetch-from-place",
        "?i - item ?p - place",
        "(fetch ?i)",
        "(and (at ?i ?p) (hand-empty))",
        ("(goto ?p)", "(pick ?i ?p)"),
    ),
    _Method(
        "fill-here",
        "?i - item ?p - place",
        "(fill ?i)",
        "(and (source ?i ?p) (robot-at ?p))",
        ("(pour ?i ?p)",),
    ),
    _Method(
        "fill-at-source",
        "?i - item ?p - place",
        "(fill ?i)",
        "(and (source ?i ?p) (not (robot-at ?p)))",
        ("(goto ?p)", "(pour ?i ?p)"),
    ),
    _Method(
        "deliver-to-user",
        "?i - item ?u - person ?p - place",
        "(deliver ?i)",
        "(user-at ?u ?p)",
        ("(goto ?p)", "(hand-over ?i ?u ?p)"),
    ),
)

# HDDL's keywords and the names of the fixed part of the domain: no constant or service task
# may take one of them (unified-planning keeps a single namespace for all of them).
_RESERVED = {
    "and",
    "or",
    "not",
    "imply",
    "exists",
    "forall",
    "when",
    "either",
    "object",
    "define",
    "domain",
    "problem",
    "number",
    "at",
    "over",
    "start",
    "end",
    "all",
    *TYPES,
    *(p[1:].split()[0].rstrip(")") for p in PREDICATES),
    *(a.name for a in ACTIONS),
    *TASKS,
    *(m.name for m in METHODS),
}


def _identifier(text: str) -> str:
    """A lowercase HDDL name: letters, digits, ``-`` and ``_``, starting with a letter."""
    name = re.sub(r"[^a-z0-9_-]+", "-", text.strip().lower()).strip("-") or "x"
    return name if name[0].isalpha() else f"x-{name}"


@dataclass
class _Names:
    """The HDDL names of a home's things, and back."""

    home: Home
    of: dict[tuple[str, str], str] = field(default_factory=dict)  # (kind, our name) -> HDDL name
    kind_of: dict[str, str] = field(default_factory=dict)  # HDDL name -> kind
    back: dict[str, str] = field(default_factory=dict)  # HDDL name -> our name (or text)
    tasks: dict[str, str] = field(default_factory=dict)  # service -> task name
    methods: dict[str, str] = field(default_factory=dict)  # service -> its method
    messages: dict[str, str] = field(default_factory=dict)  # service -> message constant

    def add(self, kind: str, name: str, wanted: str | None = None) -> str:
        if (kind, name) in self.of:
            return self.of[(kind, name)]
        base = _identifier(wanted or name)
        candidate, n = base, 1
        while candidate in _RESERVED or candidate in self.kind_of:
            candidate = f"{base}-{kind}" if n == 1 else f"{base}-{kind}{n}"
            n += 1
        self.of[(kind, name)], self.kind_of[candidate], self.back[candidate] = candidate, kind, name
        return candidate

    def __call__(self, kind: str, name: str) -> str:
        return self.of[(kind, name)]


def _names(home: Home, state: State | None = None) -> _Names:
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to plan (SPEC §8)")
    names = _Names(home)
    for service in home.services:
        task = names.add("task", service.name, "-".join(words(service.name).split()))
        names.tasks[service.name] = task
        names.methods[service.name] = names.add("method", service.name, f"do-{task}")
    names.add("setting", "on")
    names.add("setting", "off")
    names.add("person", USER)
    for device in home.devices:
        names.add("device", device.name)
    for item in layout.objects:
        names.add("item", item)
    places = [*layout.places, *layout.rooms]
    if state is not None:
        places += [state.robot, state.user, *(p for p in state.objects.values() if p != "robot")]
    for place in places:
        names.add("place", place)
    for service in home.services:
        text = None if service.sets else _errand_text(home, service.name)
        if text is not None:
            message = names.add("message", service.name, f"{names.tasks[service.name]}-msg")
            names.messages[service.name], names.back[message] = message, text
    return names


def _errand_text(home: Home, service: str) -> str | None:
    """What the robot says for an interaction service (None: it brings or docks)."""
    errand = home.layout.errand(service) if home.layout is not None else None
    if errand is not None and (errand.bring is not None or errand.dock is not None):
        return None
    return errand.say if errand is not None and errand.say is not None else words(service)


def hddl_name(home: Home, kind: str, name: str) -> str:
    """The HDDL name of one of a home's things: ``kind`` is ``task`` (a service), ``place``,
    ``item``, ``device``, ``person`` or ``setting``.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> [hddl_name(home, k, n) for k, n in [("task", "TurnOnTVL"), ("device", "lamp"), ("place", "lamp")]]
    ['turn-on-tvl', 'lamp', 'lamp-place']
    """
    try:
        return _names(home)(kind, name)
    except KeyError:
        raise PlanningError(f"no {kind} {name!r} in home {home.name!r}") from None


def _service_method(home: Home, names: _Names, service: str) -> tuple[str, str, tuple[str, ...]]:
    """(parameters, precondition, ordered subtasks) of the one method of a service's task."""
    spec = next(s for s in home.services if s.name == service)
    if spec.sets:
        subtasks = tuple(
            f"(switch {names('device', d)} {names('setting', 'on' if v else 'off')})" for d, v in spec.sets
        )
        return "", "", subtasks
    errand = home.layout.errand(service) if home.layout is not None else None
    if errand is not None and errand.bring is not None:
        item = names("item", errand.bring)
        fill = (f"(fill {item})",) if errand.pour else ()
        return "", "", (f"(fetch {item})", *fill, f"(deliver {item})")
    if errand is not None and errand.dock is not None:
        place = names("place", errand.dock)
        return "", "", (f"(goto {place})", f"(dock {place})")
    return "?u - person ?p - place", "(user-at ?u ?p)", ("(goto ?p)", f"(speak {names.messages[service]})")


def _constants(home: Home, names: _Names) -> dict[str, list[str]]:
    """The things the domain's methods name, by type (the problem declares the others)."""
    used: dict[str, list[str]] = {"setting": [names("setting", "on"), names("setting", "off")]}
    for service in home.services:
        for part in _service_method(home, names, service.name)[2]:
            for token in part.strip("()").split()[1:]:
                kind = names.kind_of.get(token)
                if kind is not None and token not in used.setdefault(kind, []):
                    used[kind].append(token)
    return used


def _typed(groups: dict[str, list[str]], indent: str) -> str:
    return "\n".join(f"{indent}{' '.join(objs)} - {kind}" for kind in TYPES if (objs := groups.get(kind)))


def _subtasks(subtasks: Sequence[str]) -> str:
    if len(subtasks) == 1:
        return subtasks[0]
    return f"(and {' '.join(subtasks)})" if subtasks else "()"


def domain_hddl(home: Home) -> str:
    """The home's HTN domain as an HDDL domain: types, constants, predicates, the actions, the
    compound tasks with their methods and one task (with one method) per service."""
    names = _names(home)
    out = [
        f"(define (domain {_identifier(home.name)})",
        "  (:requirements :hierarchy :typing :negative-preconditions :method-preconditions :equality)",
        f"  (:types {' '.join(TYPES)})",
        "  (:constants",
        _typed(_constants(home, names), "    "),
        "  )",
        "  (:predicates",
        *(f"    {p}" for p in PREDICATES),
        "  )",
    ]
    out += [f"  (:task {name} :parameters ({params}))" for name, params in TASKS.items()]
    out += [f"  (:task {names.tasks[s.name]} :parameters ())" for s in home.services]
    for m in METHODS:
        out += [
            f"  (:method {m.name}",
            f"    :parameters ({m.parameters})",
            f"    :task {m.task}",
            f"    :precondition {m.precondition}",
            f"    :ordered-subtasks {_subtasks(m.subtasks)})",
        ]
    for s in home.services:
        task = names.tasks[s.name]
        params, pre, subtasks = _service_method(home, names, s.name)
        out += [f"  (:method {names.methods[s.name]}", f"    :parameters ({params})", f"    :task ({task})"]
        out += [f"    :precondition {pre}"] if pre else []
        out += [f"    :ordered-subtasks {_subtasks(subtasks)})"]
    for a in ACTIONS:
        out += [f"  (:action {a.name}", f"    :parameters ({a.parameters})"]
        out += [f"    :precondition {a.precondition}"] if a.precondition else []
        out += [f"    :effect {a.effect})"]
    out.append(")")
    return "\n".join(out) + "\n"


def problem_hddl(
    home: Home, services: Sequence[str], state: State | None = None, *, name: str = "request"
) -> str:
    """A request as an HDDL problem: the objects the domain does not name, the initial state
    from ``state`` (default: the home's initial state) and the services, in order, as the
    initial task network."""
    from homecog.planning import initial_state

    state = state if state is not None else initial_state(home)
    known = {s.name for s in home.services}
    for service in services:
        if service not in known:
            raise PlanningError(f"unknown service {service!r}; the home has {', '.join(sorted(known))}")
    names = _names(home, state)
    constants = {c for group in _constants(home, names).values() for c in group}
    objects: dict[str, list[str]] = {}
    for (kind, _), hddl in names.of.items():
        if kind not in ("task", "method", "message") and hddl not in constants:
            objects.setdefault(kind, []).append(hddl)
    layout = home.layout
    assert layout is not None  # _names checked
    init = [
        f"(robot-at {names('place', state.robot)})",
        f"(user-at {names('person', USER)} {names('place', state.user)})",
    ]
    init.append("(hand-empty)" if state.holding is None else f"(holding {names('item', state.holding)})")
    init += [f"(at {names('item', o)} {names('place', p)})" for o, p in state.objects.items() if p != "robot"]
    init += [f"(source {names('item', o)} {names('place', p)})" for o, p in layout.objects.items()]
    init += [f"(is-on {names('device', d)})" for d, on in state.devices.items() if on]
    for device in home.devices:
        if device.iot:
            init.append(f"(iot {names('device', device.name)})")
        with contextlib.suppress(KeyError):  # an IoT device without a place is never switched by hand
            place = names("place", layout.device_place(device.name))
            init.append(f"(device-at {names('device', device.name)} {place})")
    init += ["(docked)"] if state.docked else []
    htn = " ".join(f"({names.tasks[s]})" for s in services)
    return (
        "\n".join(
            [
                f"(define (problem {_identifier(name)})",
                f"  (:domain {_identifier(home.name)})",
                "  (:objects",
                _typed(objects, "    "),
                "  )",
                "  (:htn",
                "    :parameters ()",
                f"    :ordered-subtasks (and {htn})",
                "  )",
                "  (:init",
                *(f"    {fact}" for fact in init),
                "  )",
                ")",
            ]
        )
        + "\n"
    )


def actions_from_hddl(home: Home, steps: Iterable[tuple[str, Sequence[str]]]) -> list[Task]:
    """The plan of an HDDL planner, as ``(action name, argument names)`` pairs, in our
    planner's terms (the tuples of :attr:`homecog.planning.Plan.actions`)."""
    names = _names(home)
    back = names.back

    def place(name: str) -> str:
        return back.get(name, name)

    out: list[Task] = []
    for action, args in steps:
        a = [str(x) for x in args]
        if action == "stay":
            out.append(("move", place(a[0]), place(a[0])))
        elif action in ("move", "pick", "pour", "dock"):
            out.append((action, *(place(x) for x in a)))
        elif action == "hand-over":
            out.append(("hand_over", back[a[0]], back[a[1]]))
        elif action == "speak":
            out.append(("speak", back[a[0]]))
        elif action.startswith(("switch-iot-", "switch-by-hand-")):
            kind, _, value = action.rpartition("-")
            out.append((kind.replace("-", "_"), back[a[0]], value))
        else:
            raise PlanningError(f"unknown HDDL action {action!r}")
    return out
