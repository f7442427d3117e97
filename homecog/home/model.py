"""The home definition: context features, devices, services and the common-sense rules.

A :class:`Home` is immutable and knows nothing of files; :mod:`homecog.home.validator`
builds one from YAML. Codes are 0-based indices internally; the paper's 1-based
coding and its normalization are in :mod:`homecog.home.encoding`.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> home.feature("temperature").discretize(25)      # half-open bins: 25 °C is suitable
1
>>> home.feature("temperature").values[1]
'suitable'
>>> home.feature("time").discretize(7.0)            # 07:00 is early morning
0
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, TypeVar

from homecog.errors import ContextError
from homecog.home.clock import format_clock, parse_clock
from homecog.home.household import Household
from homecog.home.states import parse_state

if TYPE_CHECKING:  # they import this module
    from homecog.home.home_assistant import HomeAssistantMap
    from homecog.home.layout import Layout
    from homecog.home.log_section import LogMap

FeatureKind = Literal["clock", "numeric", "categorical"]
ON, OFF = True, False
Named = TypeVar("Named")


def format_number(x: float) -> str:
    """A reading as people write it: ``25`` not ``25.0``, ``inf`` kept."""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return str(int(x)) if float(x).is_integer() else f"{x:g}"


def reading_text(kind: str, text: str) -> str:
    """A clock or numeric reading written as a scenario file writes it; :class:`ValueError`
    where ``text`` is no time (``kind`` clock) or no finite number.

    >>> reading_text("clock", "7:30"), reading_text("numeric", "25.0")
    ('07:30', '25')
    """
    if kind == "clock":
        return format_clock(parse_clock(text))
    number = float(text)
    if not math.isfinite(number):
        raise ValueError(text)
    return format_number(number)


def find_named(items: Iterable[Named], name: str, key: str = "name") -> Named:
    """The item whose ``key`` attribute is ``name``; :class:`KeyError` where none is."""
    for item in items:
        if getattr(item, key) == name:
            return item
    raise KeyError(name)


@dataclass(frozen=True)
class Feature:
    """One observed context dimension.

    ``values`` are the bin names (clock, numeric) or the categories, in code order.
    ``bins[k]`` is the half-open interval ``[low, high)`` of value ``k``; a clock bin
    with ``low > high`` wraps midnight.
    """

    name: str
    kind: FeatureKind
    values: tuple[str, ...]
    bins: tuple[tuple[float, float], ...] | None = None
    unit: str | None = None
    deadband: float = 0.0  # how far past a bin's edge a reading must be to change bin for the robot

    @property
    def radix(self) -> int:
        """Number of discrete values."""
        return len(self.values)

    @property
    def is_discrete(self) -> bool:
        """True for categorical features, whose readings are the values themselves."""
        return self.kind == "categorical"

    def index(self, value: str) -> int:
        """The code of a value name (bin name or category)."""
        try:
            return self.values.index(value)
        except ValueError:
            raise ContextError(
                f"{self.name}: unknown value {value!r}; expected one of {', '.join(self.values)}"
            ) from None

    def parse(self, reading: object) -> float | str:
        """A raw reading (text or number) as this feature's reading type."""
        if self.kind == "categorical":
            return str(reading).strip()
        if self.kind == "clock":
            try:
                return parse_clock(reading)  # type: ignore[arg-type]
            except ValueError as e:
                raise ContextError(f"{self.name}: {e}") from None
        if isinstance(reading, bool):
            raise ContextError(f"{self.name}: not a number: {reading!r}")
        try:
            x = float(reading)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise ContextError(f"{self.name}: not a number: {reading!r}") from None
        if math.isnan(x):
            raise ContextError(f"{self.name}: not a number: {reading!r}")
        return x

    def discretize(self, reading: object) -> int:
        """The code of the bin (or category) a reading falls into.

        Raises :class:`ContextError` naming the value and the valid range when the
        reading lies outside every bin.
        """
        value = self.parse(reading)
        if self.kind == "categorical":
            return self.index(value)  # type: ignore[arg-type]
        assert self.bins is not None
        x = float(value)  # type: ignore[arg-type]
        for k, (low, high) in enumerate(self.bins):
            if low < high:
                if low <= x < high:
                    return k
            elif x >= low or x < high:  # clock bin wrapping midnight
                return k
        shown = format_clock(x) if self.kind == "clock" else format_number(x)
        raise ContextError(
            f"{self.name}: {shown}{(' ' + self.unit) if self.unit else ''} is outside every bin; "
            f"valid range {self.valid_range()}"
        )

    def valid_range(self) -> str:
        """The readings this feature accepts, for error messages."""
        if self.kind == "categorical":
            return ", ".join(self.values)
        assert self.bins is not None
        if self.kind == "clock":
            return "00:00 to 24:00"
        low = min(b[0] for b in self.bins)
        high = max(b[1] for b in self.bins)
        return f"[{format_number(low)}, {format_number(high)})"

    def describe_bin(self, k: int) -> str:
        """A bin as people read it, e.g. ``[25, 30) °C`` or ``21:00-07:00``."""
        if self.bins is None:
            return self.values[k]
        low, high = self.bins[k]
        if self.kind == "clock":
            return f"{format_clock(low)}-{format_clock(high)}"
        unit = f" {self.unit}" if self.unit else ""
        return f"[{format_number(low)}, {format_number(high)}){unit}"


@dataclass(frozen=True)
class Device:
    """A two-state device the robot can switch (``on`` is True)."""

    name: str
    room: str | None = None
    iot: bool = True
    min_on: float = 0.0  # seconds the robot leaves it on once switched on (homecog.home.pacing)
    min_off: float = 0.0  # ... and off once switched off


@dataclass(frozen=True)
class Service:
    """A service the robot can perform.

    ``sets`` maps device names to the state the service puts them in; a service
    that sets no device is an interaction service (SendDrinks, CallToWakeup, ...).
    """

    name: str
    category: str
    sets: tuple[tuple[str, bool], ...] = ()
    description: str | None = None

    @property
    def is_interaction(self) -> bool:
        """True when the service changes no device."""
        return not self.sets


@dataclass(frozen=True)
class Condition:
    """A rule's ``when``: every listed feature (or device) must take one of its values.

    ``features`` pairs a feature's position with the allowed codes; ``devices``
    pairs a device's position with the allowed states. An empty condition always
    matches.
    """

    features: tuple[tuple[int, frozenset[int]], ...] = ()
    devices: tuple[tuple[int, frozenset[bool]], ...] = ()

    def matches(self, codes: Sequence[int], states: Sequence[bool] | None = None) -> bool:
        """Whether a discrete context (and, for device conditions, device states) matches."""
        if not all(codes[f] in allowed for f, allowed in self.features):
            return False
        if self.devices:
            if states is None:
                raise ValueError("this condition names device states; pass them")
            return all(states[d] in allowed for d, allowed in self.devices)
        return True


@dataclass(frozen=True)
class ComfortRule:
    """One ordered comfort rule of a device: when the condition matches, ``want`` is wanted."""

    when: Condition
    want: bool


@dataclass(frozen=True)
class RewardWeights:
    """The weights w_t, w_p and w_x of Eq. 1's terminal, progress and prohibited terms."""

    terminal: float = 0.5
    progress: float = 0.2
    prohibited: float = 0.3


@dataclass(frozen=True)
class Rewards:
    """Eq. 1 of the paper: total = terminal·w_t + progress·w_p + prohibited·w_x, each ±magnitude."""

    weights: RewardWeights = field(default_factory=RewardWeights)
    magnitude: float = 10.0

    def as_list(self) -> list[float]:
        """w_t, w_p, w_x and the magnitude, in this order."""
        w = self.weights
        return [w.terminal, w.progress, w.prohibited, self.magnitude]


@dataclass(frozen=True)
class Home:
    """A validated home definition. Build it with :func:`homecog.home.load_home`."""

    name: str
    features: tuple[Feature, ...]
    devices: tuple[Device, ...]
    services: tuple[Service, ...]
    comfort: tuple[tuple[ComfortRule, ...], ...]  # per device, in device order
    needs: tuple[tuple[Condition, ...], ...]  # per service, in service order; () = never
    prohibited: tuple[tuple[Condition, ...], ...]  # per service, in service order
    rewards: Rewards = field(default_factory=Rewards)
    layout: Layout | None = None
    routine: object | None = None
    home_assistant: HomeAssistantMap | None = None  # where it lives in Home Assistant
    household: Household = field(default_factory=Household)  # learning from people (§7.1)
    log: LogMap | None = None  # which entities of a log of state changes it reads
    description: str | None = None
    source: str = "<memory>"
    content_hash: str = ""

    # -- lookups ---------------------------------------------------------------------
    def feature(self, name: str) -> Feature:
        """The feature of that name."""
        return find_named(self.features, name)

    def feature_index(self, name: str) -> int:
        """Position of a feature."""
        return [f.name for f in self.features].index(name)

    def device_index(self, name: str) -> int:
        """Position of a device."""
        return [d.name for d in self.devices].index(name)

    def service_index(self, name: str) -> int:
        """Position of a service (its action number in the environment)."""
        return [s.name for s in self.services].index(name)

    @property
    def feature_names(self) -> tuple[str, ...]:
        return tuple(f.name for f in self.features)

    @property
    def device_names(self) -> tuple[str, ...]:
        return tuple(d.name for d in self.devices)

    @property
    def service_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.services)

    @property
    def need_services(self) -> tuple[int, ...]:
        """Positions of the services some needs rule can ask for."""
        return tuple(i for i, rules in enumerate(self.needs) if rules)

    @property
    def context_count(self) -> int:
        """Number of discrete contexts: the product of the features' radices."""
        return math.prod(f.radix for f in self.features)

    # -- the rules -------------------------------------------------------------------
    def wanted(self, codes: Sequence[int]) -> tuple[bool | None, ...]:
        """Per device, the state the first matching comfort rule wants (None: don't care)."""
        out: list[bool | None] = []
        for rules in self.comfort:
            want: bool | None = None
            for rule in rules:
                if rule.when.matches(codes):
                    want = rule.want
                    break
            out.append(want)
        return tuple(out)

    def needs_of(self, codes: Sequence[int]) -> tuple[int, ...]:
        """Positions of the interaction services the user needs in a discrete context."""
        return tuple(i for i, rules in enumerate(self.needs) if any(r.matches(codes) for r in rules))

    def is_prohibited(self, service: int, codes: Sequence[int], states: Sequence[bool]) -> bool:
        """Whether performing a service is prohibited in a context with these device states."""
        return any(r.matches(codes, states) for r in self.prohibited[service])

    def optimum(self, codes: Sequence[int], states: Sequence[bool]) -> tuple[bool, ...]:
        """Device states of the optimum: wanted states where cared for, the rest unchanged."""
        return tuple(s if w is None else w for s, w in zip(states, self.wanted(codes), strict=True))

    def optimal_service_sets(
        self, codes: Sequence[int], states: Sequence[bool], limit: int = 256
    ) -> list[frozenset[str]]:
        """Every set of services that takes a context to its optimum: the services of a sequence
        in which each service lowers the distance and none is prohibited. Smallest
        sets first (then fewest devices set, then service order); found group by group
        (:mod:`homecog.home.truth`).

        With services that each set one device there is exactly one such set. A service that
        sets several (``AllQuiet: {speaker: off, hood: off}``) can make several sets optimal.
        Where the rules leave no such sequence, the per-device choice without order is returned.

        >>> from homecog.home import load_home
        >>> home = load_home("paper")
        >>> codes, states = home.discretize({"time": "19:00", "temperature": 30,
        ...     "illumination": 200, "location": "sofa", "posture": "sit", "behavior": "watch_tv",
        ...     "window": "on", "curtain": "on", **{d: "off" for d in home.device_names[2:]}})
        >>> sorted(home.optimal_service_sets(codes, states)[0])
        ['CloseWindow', 'SendDrinks', 'TurnOnACL', 'TurnOnLight', 'TurnOnTVL']
        """
        from homecog.home.truth import optimal_service_sets

        return optimal_service_sets(self, codes, states, limit)

    def services_to_optimum(self, codes: Sequence[int], states: Sequence[bool]) -> list[str]:
        """The set of services that takes a context to its optimum (the ground truth).

        The first of :meth:`optimal_service_sets`, in service order; empty when some wrong
        device has no service that can fix it.
        """
        sets = self.optimal_service_sets(codes, states)
        if not sets:
            return []
        return [s.name for s in self.services if s.name in sets[0]]

    # -- readings -> discrete context ------------------------------------------------
    def discretize(self, readings: Mapping[str, object]) -> tuple[tuple[int, ...], tuple[bool, ...]]:
        """Readings of every feature and device state → (feature codes, device states).

        Device states accept on/off, true/false, yes/no and 1/0. Raises
        :class:`ContextError` naming the first missing, unknown or invalid entry.

        >>> from homecog.home import load_home
        >>> home = load_home("paper")
        >>> codes, states = home.discretize({"time": "7:00", "temperature": 25,
        ...     "illumination": 100, "location": "bed", "posture": "lie", "behavior": "sleep",
        ...     **{d: "off" for d in home.device_names}})
        >>> [home.features[i].values[k] for i, k in enumerate(codes)]
        ['early_morning', 'suitable', 'suitable', 'bed', 'lie', 'sleep']
        """
        known = set(self.feature_names) | set(self.device_names)
        unknown = [k for k in readings if k not in known]
        if unknown:
            raise ContextError(
                f"unknown feature or device {unknown[0]!r}; expected "
                f"{', '.join(self.feature_names + self.device_names)}"
            )
        missing = [k for k in self.feature_names + self.device_names if k not in readings]
        if missing:
            raise ContextError(f"missing {', '.join(missing)}")
        codes = tuple(f.discretize(readings[f.name]) for f in self.features)
        states = tuple(parse_state(readings[d.name], d.name) for d in self.devices)
        return codes, states
