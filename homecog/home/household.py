"""The ``household`` section of a home file: how the running robot learns from what the people
who live there do by hand, and how it keeps out of their way.

.. code-block:: yaml

    household:
      undo_window: 15          # minutes: a person switching back the robot's switch within this
                               # is an undo (a rejection of the robot's service where it acted)
      hold: 30                 # minutes: after a person switches a device, the robot leaves it
                               # alone this long at most (and while the situation is the same)
      weights: {explicit: 1, observed: 5, undo: 5}   # corrections' worth of each kind
      users: {8a2c41…: ann, 5f11e0…: kim}            # who is who, as a source names people
                               # (Home Assistant's user ids); with a map, a person it lacks is
                               # not learned from; without one, every person is `default_user`
      default_user: default

Every key is optional; the section does not change what the robot learns from the home itself
(it is left out of the content hash).

>>> parse_household(None).undo_window, parse_household(None).weights
(900.0, {'explicit': 1, 'observed': 5, 'undo': 5})
>>> h = parse_household({"hold": 5, "weights": {"undo": 3}})
>>> h.hold, h.weight("undo"), h.user("8a2c41"), parse_household({"users": {"8a2c41": "ann"}}).user("x")
(300.0, 3, 'default', None)
>>> parse_household({"hold": -1})
Traceback (most recent call last):
...
homecog.errors.HomeFileError: <home>: household.hold: -1 minutes; expected 0 to 1440
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from homecog.errors import ContextError, HomeFileError
from homecog.names import user_name_problem

KINDS = ("explicit", "observed", "undo")
#: a correction told is a whole set; a person's switch, or an undo, speaks of one service and is
#: deliberate: it counts as five of the situations lived through without a switch, which say
#: "not wanted" once each (measured: docs/design.md, Learning from the household)
DEFAULT_WEIGHTS = {"explicit": 1, "observed": 5, "undo": 5}


def _fail(path: str, message: str) -> HomeFileError:
    return HomeFileError(f"<home>: {path}: {message}")


@dataclass(frozen=True)
class Household:
    """How the robot learns from the household and keeps out of its way; times in seconds."""

    undo_window: float = 900.0
    hold: float = 1800.0
    weights: dict[str, int] = field(default_factory=lambda: dict(DEFAULT_WEIGHTS))
    users: dict[str, str] | None = None
    default_user: str = "default"

    def __hash__(self) -> int:  # the home is hashable; its maps are fixed once read
        users = tuple(sorted(self.users.items())) if self.users is not None else None
        return hash(
            (self.undo_window, self.hold, tuple(sorted(self.weights.items())), users, self.default_user)
        )

    def weight(self, kind: str) -> int:
        """How many corrections' worth a correction of ``kind`` counts."""
        return self.weights.get(kind, DEFAULT_WEIGHTS.get(kind, 1))

    def knows(self, user: str) -> bool:
        """Whether ``user`` is one of the household: with ``users``, one of its names or the
        default user; without, any user."""
        return self.users is None or user == self.default_user or user in self.users.values()

    def member(self, user: str) -> None:
        """:class:`ContextError` naming the household where ``user`` is not one of it."""
        if not self.knows(user):
            raise ContextError(f"user {user!r}: not one of the household ({self.names()})")

    def names(self) -> str:
        """The household's users, for a message (``any`` without ``users``)."""
        if self.users is None:
            return "any"
        return ", ".join(sorted({*self.users.values(), self.default_user}))

    def user(self, person: str | None) -> str | None:
        """The homecog user of a person as the source names them (``None``: nobody known)."""
        if self.users is None:
            return self.default_user
        if person is None:
            return self.default_user
        return self.users.get(person)


def parse_household(section: object, fail: Callable[[str, str], HomeFileError] = _fail) -> Household:
    """Validate a ``household`` section; ``None`` gives the defaults."""
    if section is None:
        return Household()
    if not isinstance(section, dict):
        raise fail("household", "expected a mapping (undo_window, hold, weights, users, default_user)")
    allowed = ("undo_window", "hold", "weights", "users", "default_user")
    for key in section:
        if key not in allowed:
            raise fail(f"household.{key}", f"unknown key; expected one of {', '.join(allowed)}")
    out = Household()
    minutes = {
        k: _minutes(section[k], f"household.{k}", fail) for k in ("undo_window", "hold") if k in section
    }
    weights = _weights(section.get("weights", {}), out.weights, fail)
    users = _users(section.get("users"), fail)
    default = section.get("default_user", out.default_user)
    problem = user_name_problem(default)
    if problem is not None:
        raise fail("household.default_user", problem)
    return Household(
        undo_window=minutes.get("undo_window", out.undo_window),
        hold=minutes.get("hold", out.hold),
        weights=weights,
        users=users,
        default_user=default,
    )


def _weights(
    raw: object, defaults: dict[str, int], fail: Callable[[str, str], HomeFileError]
) -> dict[str, int]:
    """The defaults with the section's ``weights`` over them."""
    if not isinstance(raw, dict):
        raise fail("household.weights", "expected a mapping of explicit, observed, undo to whole numbers")
    weights = dict(defaults)
    for kind, w in raw.items():
        if kind not in KINDS:
            raise fail(f"household.weights.{kind}", f"unknown kind; expected one of {', '.join(KINDS)}")
        if isinstance(w, bool) or not isinstance(w, int) or not 1 <= w <= 100:
            raise fail(f"household.weights.{kind}", f"{w!r}; expected a whole number from 1 to 100")
        weights[kind] = w
    return weights


def _users(users: object, fail: Callable[[str, str], HomeFileError]) -> dict[str, str] | None:
    """People's ids to homecog user names (``None`` where the section names none)."""
    if users is None:
        return None
    if not isinstance(users, dict) or not all(isinstance(k, str) for k in users):
        raise fail("household.users", "expected a mapping of people's ids to homecog user names")
    for person, name in users.items():
        problem = user_name_problem(name)
        if problem is not None:
            raise fail(f"household.users.{person}", problem)
    return {str(k): str(v) for k, v in users.items()}


def _minutes(value: object, path: str, fail: Callable[[str, str], HomeFileError]) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= 1440:
        shown = (
            f"{value:g}" if isinstance(value, (int, float)) and not isinstance(value, bool) else repr(value)
        )
        raise fail(path, f"{shown} minutes; expected 0 to 1440")
    return float(value) * 60
