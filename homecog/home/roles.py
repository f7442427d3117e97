"""Which of a home's features says when it is, where the user is and what they do.

A home file names its features as it likes (``time`` or ``clock``, ``location`` or ``room``,
``behavior`` or ``activity`` or ``doing``); a short way of giving a context ("at 20:30 on the
sofa, watching TV") needs to find them in any home:

- **when**: the home's clock feature (the one of kind ``clock``; of several, the one named
  ``time``);
- **where**: the categorical feature named ``location`` (the home file's convention), ``room``,
  ``place`` or ``where``, in that order; else the one whose values are places or rooms of the
  home's floor plan; else the one categorical feature that has the value given;
- **doing**: the categorical feature named ``behavior``, ``behaviour``, ``activity`` or
  ``doing``, in that order; else the one categorical feature that has the value given.

A home without such a feature is a :class:`~homecog.errors.ContextError` that says what was
looked for.

>>> from homecog.home import load_home
>>> paper = load_home("paper")
>>> clock_feature(paper).name, role_feature(paper, "where", "sofa").name
('time', 'location')
>>> role_feature(paper, "doing", "read").name
'behavior'
"""

from __future__ import annotations

from homecog.errors import ContextError
from homecog.home.model import Feature, Home

#: per role, the names that say it, in order of preference
NAMES = {
    "where": ("location", "room", "place", "where"),
    "doing": ("behavior", "behaviour", "activity", "doing"),
}
#: per role, what it is, for messages
MEANING = {"where": "where the user is", "doing": "what the user does"}


def clock_feature(home: Home) -> Feature:
    """The home's clock feature: its only one, or of several the one named ``time``."""
    clocks = [f for f in home.features if f.kind == "clock"]
    if len(clocks) == 1:
        return clocks[0]
    named = [f for f in clocks if f.name == "time"]
    if named:
        return named[0]
    if not clocks:
        raise ContextError(f"home '{home.name}' has no clock feature")
    raise ContextError(
        f"home '{home.name}' has {len(clocks)} clock features ({', '.join(f.name for f in clocks)}) "
        "and none is named time"
    )


def role_feature(home: Home, role: str, value: str) -> Feature:
    """The categorical feature of ``role`` (``where`` or ``doing``) in ``home``, for ``value``."""
    categorical = [f for f in home.features if f.kind == "categorical"]
    for name in NAMES[role]:
        for f in categorical:
            if f.name == name:
                return f
    if role == "where" and home.layout is not None:
        layout = home.layout
        places = [f for f in categorical if f.values and all(layout.has_place(v) for v in f.values)]
        if len(places) == 1:
            return places[0]
    having = [f for f in categorical if value in f.values]
    if len(having) == 1:
        return having[0]
    names = ", ".join(NAMES[role][:-1]) + f" or {NAMES[role][-1]}"
    looked = f"home '{home.name}' has no feature of {MEANING[role]} (none is named {names}"
    if not having:
        raise ContextError(f"{looked}, and none has the value {value!r})")
    raise ContextError(f"{looked}, and {', '.join(f.name for f in having)} all have the value {value!r})")
