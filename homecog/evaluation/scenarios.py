"""Random scenarios with their ground truth.

A scenario is a full context: a reading for every feature (uniform inside a random bin)
and a random state for every device. Its ground truth is the set of services that takes
it to the optimum under a truth home. A scenario is what a row of a scenario file is
(:class:`~homecog.home.scenario_file.Scenario`); the metrics are
:mod:`homecog.evaluation.metrics`'s.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> scenarios = random_scenarios(home, 3, seed=0)
>>> len(scenarios), sorted(scenarios[0].context)[:3]
(3, ['ac_bedroom', 'ac_living', 'behavior'])
"""

from __future__ import annotations

import numpy as np

from homecog.home.codec import Point, Space, reading_in_bin
from homecog.home.model import Home
from homecog.home.scenario_file import Scenario, truth_of


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
            readings.append(float(reading_in_bin(f, k, rng.random())))
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
