"""Random scenarios with their ground truth, and micro precision and recall (SPEC §9).

A scenario is a full context: a reading for every feature (uniform inside a random bin)
and a random state for every device. Its ground truth is the set of services that takes
it to the optimum under a truth home.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> scenarios = random_scenarios(home, 3, seed=0)
>>> len(scenarios), sorted(scenarios[0].context)[:3]
(3, ['ac_bedroom', 'ac_living', 'behavior'])
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from homecog.home.codec import Point, Space, finite_span
from homecog.home.model import Home


@dataclass(frozen=True)
class Scenario:
    """A context as a scenario-file row, its point, and the services the truth home wants.

    ``truth`` is the canonical optimal set; ``choices`` holds, for every group of devices where
    more than one set is optimal (services that set several devices), that group's optimal
    sets, the canonical one first.
    """

    context: dict[str, str]
    point: Point
    truth: frozenset[str]
    choices: tuple[tuple[frozenset[str], ...], ...] = ()
    user: str | None = None  # an event file's ``user`` column, where it may have one

    def truth_for(self, predicted: Sequence[str]) -> frozenset[str]:
        """The optimal set that agrees best with a prediction: most services in common, then
        fewest differences — chosen group by group, since both counts add up over groups."""
        if not self.choices:
            return self.truth
        p = set(predicted)
        out = set(self.truth)
        for options in self.choices:
            out -= options[0]
            out |= max(options, key=lambda t: (len(p & t), -len(t ^ p)))
        return frozenset(out)


def truth_of(home: Home, point: Point) -> tuple[frozenset[str], tuple[tuple[frozenset[str], ...], ...]]:
    """The canonical optimal set of a point under ``home`` and the groups' choices."""
    from homecog.home.truth import choices

    n_f = len(home.features)
    per_group = choices(home, point.codes[:n_f], tuple(bool(c) for c in point.codes[n_f:]))
    names = home.service_names
    truth = frozenset(names[a] for c in per_group for a in c[0])
    ambiguous = tuple(tuple(frozenset(names[a] for a in s) for s in c) for c in per_group if len(c) > 1)
    return truth, ambiguous


def random_scenarios(home: Home, n: int, *, seed: int = 0, truth: Home | None = None) -> list[Scenario]:
    """``n`` scenarios of a home, truth from ``truth`` (default: the same home)."""
    rng = np.random.default_rng(seed)
    space = Space(home)
    judge = truth or home
    out = []
    for _ in range(n):
        codes, readings = [], []
        for f in home.features:
            k = int(rng.integers(f.radix))
            codes.append(k)
            if f.bins is None:
                readings.append(None)
                continue
            low, high = finite_span(f.bins)[2 * k : 2 * k + 2]
            if f.kind == "clock" and high <= low:
                high += 24
            x = max(float(np.floor((low + (high - low) * rng.random()) * 100) / 100), low)
            readings.append(x % 24 if f.kind == "clock" else x)
        states = [bool(rng.integers(2)) for _ in home.devices]
        point = Point(
            codes=tuple(codes) + tuple(int(s) for s in states),
            readings=tuple(readings) + (None,) * len(states),
        )
        context = space.context(point)
        point = space.point(context)  # what a reader of the scenario file would get
        truth_set, ambiguous = truth_of(judge, point)
        out.append(Scenario(context=context, point=point, truth=truth_set, choices=ambiguous))
    return out
