"""A context on the command line: ``--context`` with every feature and device, or the short way.

The short way gives what matters and leaves the rest: ``--at 20:30`` (the home's clock
feature), ``--where sofa`` (where the user is), ``--doing watch_tv`` (what they do), and
``NAME=VALUE`` arguments for any feature or device (:mod:`homecog.home.roles` finds the three
features in any home). Over ``--context`` it changes what it names; alone, every feature it
does not name is ``unknown`` (a missing reading) and every device it does not name is off.

Every name and value is checked before any work: all that is wrong is said in one line, and a
command that stores (``correct``) stores nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Annotated

import typer

from homecog.errors import ContextError, UsageProblemError
from homecog.home.codec import UNKNOWN, Point, Space, is_missing, parse_context
from homecog.home.model import Feature, Home
from homecog.home.roles import clock_feature, role_feature
from homecog.home.states import parse_state
from homecog.names import shown

AtOption = Annotated[
    str | None, typer.Option("--at", help="The time (HH:MM) of the home's clock feature: a short context.")
]
WhereOption = Annotated[
    str | None, typer.Option("--where", help="Where the user is (a value of the home's location feature).")
]
DoingOption = Annotated[
    str | None,
    typer.Option("--doing", help="What the user does (a value of the home's behavior or activity feature)."),
]
PairsArgument = Annotated[
    list[str] | None,
    typer.Argument(
        metavar="NAME=VALUE",
        help="Features and devices of a short context (the features left out unknown, the devices off).",
        show_default=False,
    ),
]
_HOW = (
    "give --context with every feature and device, or the short way: --at HH:MM, --where PLACE, "
    "--doing ACTIVITY and NAME=VALUE arguments"
)


@dataclass(frozen=True)
class GivenContext:
    """A context from the command line: the point, and what the short way left out (filled in:
    features as ``unknown``, devices off)."""

    point: Point
    assumed: tuple[str, ...] = ()


def given_context(
    home: Home,
    context: str | None,
    at: str | None = None,
    where: str | None = None,
    doing: str | None = None,
    pairs: Sequence[str] | None = None,
) -> GivenContext:
    """The context of ``--context`` and the short way; a usage error where neither is given."""
    given = optional_context(home, context, at, where, doing, pairs)
    if given is None:
        raise UsageProblemError(f"no context: {_HOW}")
    return given


def optional_context(
    home: Home,
    context: str | None,
    at: str | None = None,
    where: str | None = None,
    doing: str | None = None,
    pairs: Sequence[str] | None = None,
) -> GivenContext | None:
    """The context of ``--context`` and the short way, or None where neither is given."""
    space = Space(home)
    short = _short_values(home, space, at=at, where=where, doing=doing, pairs=pairs or ())
    if context is None and not short:
        return None
    if context is not None:
        values = space.context(parse_context(context, space))
        assumed: tuple[str, ...] = ()
    else:
        values = {f.name: UNKNOWN for f in home.features} | {d.name: "off" for d in home.devices}
        assumed = tuple(name for name in space.names if name not in short)
    values.update(short)
    return GivenContext(space.point(values), assumed)


def _short_values(
    home: Home, space: Space, *, at: str | None, where: str | None, doing: str | None, pairs: Sequence[str]
) -> dict[str, str]:
    """Name → value of the short way, every name and value checked; one error naming all that
    is wrong."""
    short = _Short(home, space)
    short.option("--at", at, lambda _: clock_feature(home))
    short.option("--where", where, lambda v: role_feature(home, "where", v))
    short.option("--doing", doing, lambda v: role_feature(home, "doing", v))
    unknown = [name for pair in pairs if (name := short.pair(pair)) is not None]
    if unknown:
        short.problems.insert(0, _unknown_names(home, unknown))
    short.check_values()
    if short.problems:
        raise UsageProblemError("; ".join(short.problems))
    return {name: value for name, (value, _) in short.given.items()}


class _Short:
    """The names and values of a short context as they come, and what is wrong with them."""

    def __init__(self, home: Home, space: Space) -> None:
        self.home, self.space = home, space
        self.problems: list[str] = []
        self.given: dict[str, tuple[str, str]] = {}  # name -> (value, how it was given)

    def put(self, name: str, value: str, how: str) -> None:
        if name in self.given:
            self.problems.append(f"{name} given twice ({self.given[name][1]} and {how})")
        else:
            self.given[name] = (value, how)

    def option(self, option: str, value: str | None, find: Callable[[str], Feature]) -> None:
        """``--at``, ``--where`` or ``--doing``: its value for the feature ``find`` finds."""
        if value is None:
            return
        try:
            self.put(find(value).name, value, f"{option} {_cut(value)}")
        except ContextError as e:
            self.problems.append(f"{option} {_cut(value)}: {e}; give it as NAME=VALUE")

    def pair(self, pair: str) -> str | None:
        """A ``NAME=VALUE`` argument; its name where the home has no such feature or device."""
        name, equals, value = (s.strip() for s in pair.partition("="))
        if not equals or not name:
            self.problems.append(f"{shown(pair)} is not NAME=VALUE")
        elif name not in self.space.index:
            return name
        else:
            self.put(name, value, pair)
        return None

    def check_values(self) -> None:
        """Every value given checked against its feature or device."""
        for name, (value, how) in self.given.items():
            problem = _value_problem(self.home, self.space, name, value)
            if problem is not None:
                self.problems.append(f"{how}: {problem}" if how.startswith("--") else problem)


def _cut(value: str) -> str:
    """A value as a message shows it: as typed, or quoted and cut where long or unprintable."""
    return value if len(value) <= 40 and value.isprintable() else shown(value)


def _unknown_names(home: Home, names: Sequence[str]) -> str:
    """The message of names that are no feature or device of the home."""
    listed = ", ".join(shown(n) for n in names)
    return (
        f"unknown feature{'s' * (len(names) > 1)} {listed} of home '{home.name}' "
        f"(features: {', '.join(home.feature_names)}; devices: {', '.join(home.device_names)})"
    )


def _value_problem(home: Home, space: Space, name: str, value: str) -> str | None:
    """Why ``value`` is no value of the feature or device ``name``, or None."""
    j = space.index[name]
    try:
        if j >= space.n_features:
            parse_state(value, name)
            return None
        feature = home.features[j]
        if not is_missing(feature, value):
            feature.discretize(value)
    except ContextError as e:
        return str(e)
    return None
