"""The HDDL names of a home's things, and back (:mod:`homecog.planning.hddl`).

Names are lowercase identifiers: ``SendDrinks`` is the task ``send-drinks``; a name used for
two things (the paper home's ``lamp`` is a device and a place) gets its type appended to the
second (``lamp-place``); no name may be an HDDL keyword or a name of the domain's fixed part
(unified-planning keeps a single namespace for all of them).

>>> from homecog.home import load_home
>>> names = home_names(load_home("paper"))
>>> names("device", "lamp"), names("place", "lamp"), names.tasks["CallToWakeup"], names("setting", "on")
('lamp', 'lamp-place', 'call-to-wakeup', 'on')
>>> names.back["call-to-wakeup-msg"]
'Good morning, it is time to get up.'
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.planning.domain import ACTIONS, METHODS, TASKS, service_methods, words
from homecog.planning.schema import PREDICATES, SETTINGS, TYPES, MethodSchema
from homecog.planning.state import HELD, USER, State

_KEYWORDS = {
    "and", "or", "not", "imply", "exists", "forall", "when", "either", "object", "define", "domain",
    "problem", "number", "at", "over", "start", "end", "all",
}  # fmt: skip


def identifier(text: str) -> str:
    """A lowercase HDDL name: letters, digits, ``-`` and ``_``, starting with a letter."""
    name = re.sub(r"[^a-z0-9_-]+", "-", text.strip().lower()).strip("-") or "x"
    return name if name[0].isalpha() else f"x-{name}"


def action_variants() -> dict[str, list[str]]:
    """Per action, the names of the HDDL actions it is written as."""
    return {a.name: [v.name for v in a.variants] for a in ACTIONS}


def method_names(m: MethodSchema, base: str) -> list[str]:
    """The HDDL methods one of ours is written as: one per choice of an HDDL action for each of
    its action subtasks that has several (``goto-move``, ``goto-stay``), named by the part of
    the HDDL action's name that differs from the action's."""
    variants = action_variants()
    several = [t[0] for t in m.subtasks if len(variants.get(t[0], ())) > 1]
    out = []
    for combo in itertools.product(*(variants[kind] for kind in several)):
        parts = [v.removeprefix(kind.replace("_", "-") + "-") for v, kind in zip(combo, several, strict=True)]
        out.append("-".join([base, *parts]))
    return out


RESERVED = {
    *_KEYWORDS,
    *TYPES,
    *PREDICATES,
    *(v for names in action_variants().values() for v in names),
    *(t.name for t in TASKS),
    *(n for m in METHODS for n in method_names(m, identifier(m.name.replace("_", "-")))),
}
"""Names no constant or service task may take."""


@dataclass
class Names:
    """The HDDL names of a home's things, and back."""

    home: Home
    of: dict[tuple[str, str], str] = field(default_factory=dict)  # (kind, our name) -> HDDL name
    kind_of: dict[str, str] = field(default_factory=dict)  # HDDL name -> kind
    back: dict[str, str] = field(default_factory=dict)  # HDDL name -> our name (or text)
    tasks: dict[str, str] = field(default_factory=dict)  # service -> task name
    methods: dict[str, str] = field(default_factory=dict)  # service -> its method

    def add(self, kind: str, name: str, wanted: str | None = None) -> str:
        if (kind, name) in self.of:
            return self.of[(kind, name)]
        base = identifier(wanted or name)
        candidate, n = base, 1
        while candidate in RESERVED or candidate in self.kind_of:
            candidate = f"{base}-{kind}" if n == 1 else f"{base}-{kind}{n}"
            n += 1
        self.of[(kind, name)], self.kind_of[candidate], self.back[candidate] = candidate, kind, name
        return candidate

    def __call__(self, kind: str, name: str) -> str:
        return self.of[(kind, name)]


def home_names(home: Home, state: State | None = None) -> Names:
    """The names of a home's services, settings, the user, devices, objects, places (and those
    of ``state``) and spoken sentences."""
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to plan")
    names = Names(home)
    for service in home.services:
        task = names.add("task", service.name, "-".join(words(service.name).split()))
        names.tasks[service.name] = task
        names.methods[service.name] = names.add("method", service.name, f"do-{task}")
    for setting in SETTINGS:
        names.add("setting", setting)
    names.add("person", USER)
    for device in home.devices:
        names.add("device", device.name)
    for item in layout.objects:
        names.add("item", item)
    places = [*layout.places, *layout.rooms]
    if state is not None:
        places += [state.robot, state.user, *(p for p in state.objects.values() if p != HELD)]
    for place in places:
        names.add("place", place)
    _add_messages(names, home)
    return names


def _add_messages(names: Names, home: Home) -> None:
    """The spoken sentences: each a message constant named after its service."""
    for service, m in zip(home.services, service_methods(home), strict=True):
        for subtask in m.subtasks:
            if subtask[0] == "speak":
                names.add("message", subtask[1], f"{names.tasks[service.name]}-msg")
