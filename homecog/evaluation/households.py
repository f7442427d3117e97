"""Households with wishes of their own, for measuring how corrections generalize.

A household lives in any home but wants what it wants: per device, a few ordered rules over the
context (the first that matches gives the wanted state; none: it does not care), and per
interaction service, when it is needed — written at random from the home's features, not from
its comfort rules. Two kinds:

- ``wishes``: the rules' conditions are sets of the home's values and bins;
- ``thresholds``: a numeric feature in a rule is a threshold on the reading itself, drawn inside
  the home's bins (the fan from 23 °C where the home's bin is [-inf, 25)).

A stream of events is what the household does in random contexts: the services that bring each
device to its wanted state and the needs met, less the switches it does not bother to make
(``skip``, 15 % by default in the noisy streams) and plus a whim now and then (``whim``: a service
nobody's rule asks for). The *oracle* answers with the rules themselves.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> household = make_household(home, "thresholds", seed=3)
>>> events = household.stream(5, seed=1)
>>> len(events), all(e.clean <= set(home.service_names) for e in events)
(5, True)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from homecog.evaluation.scenarios import random_scenarios
from homecog.home.codec import Point, finite_span
from homecog.home.model import Home

KINDS = ("wishes", "thresholds")


@dataclass(frozen=True)
class Clause:
    """One condition of a rule: feature ``j``'s code in ``codes``, or its reading at or above
    (``above``) or below a ``threshold``."""

    j: int
    codes: frozenset[int] = frozenset()
    threshold: float | None = None
    above: bool = True

    def holds(self, p: Point) -> bool:
        if self.threshold is None:
            return p.codes[self.j] in self.codes
        r = p.readings[self.j]
        assert r is not None
        return (r >= self.threshold) == self.above


@dataclass(frozen=True)
class Rule:
    tests: tuple[Clause, ...]
    want: bool | None  # None: the household does not care

    def holds(self, p: Point) -> bool:
        return all(t.holds(p) for t in self.tests)


@dataclass(frozen=True)
class Event:
    point: Point
    wanted: frozenset[str]  # what the household did (skips and whims included)
    clean: frozenset[str]  # what its rules ask for


@dataclass
class Household:
    """A household's own rules over a home (see the module's docstring)."""

    home: Home
    name: str
    devices: dict[int, list[Rule]] = field(default_factory=dict)  # device position → rules
    needs: dict[int, list[Rule]] = field(default_factory=dict)  # interaction service → rules
    skip: float = 0.15
    whim: float = 0.05

    def _switch(self, d: int, on: bool) -> str | None:
        name = self.home.devices[d].name
        for s in self.home.services:
            if s.sets == ((name, on),):
                return s.name
        return None

    def wants(self, p: Point) -> frozenset[str]:
        """What the rules ask for at ``p``: switches to the wanted states, the needs met."""
        n_f = len(self.home.features)
        out = set()
        for d, rules in self.devices.items():
            rule = next((r for r in rules if r.holds(p)), None)
            if rule is None or rule.want is None or bool(p.codes[n_f + d]) == rule.want:
                continue
            service = self._switch(d, rule.want)
            if service is not None:
                out.add(service)
        for a, rules in self.needs.items():
            if any(r.holds(p) for r in rules):
                out.add(self.home.services[a].name)
        return frozenset(out)

    def stream(self, n: int, *, seed: int = 0, noisy: bool = True) -> list[Event]:
        """``n`` events in random contexts of the home (skips and whims when ``noisy``)."""
        rng = np.random.default_rng([seed, 17])
        n_f = len(self.home.features)
        events = []
        for s in random_scenarios(self.home, n, seed=seed):
            clean = self.wants(s.point)
            wanted = set(clean)
            if noisy:
                # in order, so the same services are skipped in every run (a set's order is not)
                wanted = {x for x in sorted(wanted) if rng.random() >= self.skip}
                if rng.random() < self.whim:
                    # a whim: some service that would change something, not asked for by a rule
                    states = s.point.codes[n_f:]
                    options = [
                        sv.name
                        for sv in self.home.services
                        if sv.name not in clean
                        and (
                            not sv.sets or any(states[self.home.device_index(dn)] != on for dn, on in sv.sets)
                        )
                    ]
                    if options:
                        wanted.add(options[int(rng.integers(len(options)))])
            events.append(Event(point=s.point, wanted=frozenset(wanted), clean=clean))
        return events


def _test(home: Home, j: int, kind: str, rng: np.random.Generator) -> Clause:
    feature = home.features[j]
    n = feature.radix
    if feature.bins is not None and kind == "thresholds":
        k = int(rng.integers(n))
        low, high = finite_span(feature.bins)[2 * k : 2 * k + 2]
        if feature.kind == "clock" and high <= low:
            high += 24
        # inside the bin, away from its edges: a threshold the home's bins cannot express
        t = round(float(low + (high - low) * rng.uniform(0.25, 0.75)), 1)
        return Clause(j=j, threshold=t % 24 if feature.kind == "clock" else t, above=bool(rng.integers(2)))
    size = int(rng.integers(1, n)) if n > 1 else 1
    return Clause(j=j, codes=frozenset(rng.choice(n, size=size, replace=False).tolist()))


def _rules(home: Home, kind: str, rng: np.random.Generator, *, last: bool | None, count: int) -> list[Rule]:
    numeric = [j for j, f in enumerate(home.features) if f.bins is not None]
    rules = []
    want = bool(rng.integers(2))
    for _ in range(count):
        k = int(rng.integers(1, 3))
        if kind == "thresholds" and numeric:
            first = int(rng.choice(numeric))
            rest = [j for j in range(len(home.features)) if j != first]
            chosen = [first, *rng.choice(rest, size=min(k - 1, len(rest)), replace=False).tolist()]
        else:
            chosen = rng.choice(len(home.features), size=min(k, len(home.features)), replace=False).tolist()
        rules.append(Rule(tests=tuple(_test(home, int(j), kind, rng) for j in chosen), want=want))
        want = not want
    rules.append(Rule(tests=(), want=last))
    return rules


def make_household(
    home: Home, kind: str = "wishes", *, seed: int = 0, skip: float = 0.15, whim: float = 0.05
) -> Household:
    """A household of ``kind`` (``wishes`` or ``thresholds``) with random rules over ``home``."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    rng = np.random.default_rng([seed, 23, KINDS.index(kind)])
    household = Household(home=home, name=f"{home.name}/{kind}", skip=skip, whim=whim)
    for d in range(len(home.devices)):
        last = [None, False, True][int(rng.integers(3))]
        household.devices[d] = _rules(home, kind, rng, last=last, count=int(rng.integers(1, 3)))
    for a, service in enumerate(home.services):
        if service.is_interaction:
            rules = _rules(home, kind, rng, last=None, count=1)
            household.needs[a] = [Rule(tests=r.tests, want=True) for r in rules[:1]]
    return household


def oracle_predict(household: Household, p: Point) -> list[str]:
    """The oracle: the household's own rules, without its skips and whims."""
    return sorted(household.wants(p))
