"""Greedy roll-outs of a learned policy.

The roll-out of one table follows its best service until the optimum. The roll-out of a
home learned group by group performs, at each step, the best service over all groups not yet
at their optimum — the greatest Q value of each group's best service not prohibited there, the
first group on ties —
and a scene takes the place of the services it does the work of
(:func:`homecog.home.scenes.compose`).

>>> from homecog.home import load_home
>>> from homecog.learning.grouped import train_policy
>>> home = load_home("paper")
>>> roll = Rollout(home, train_policy(home).policy)
>>> codes, states = home.discretize({"time": "22:00", "temperature": 19, "illumination": 200,
...     "location": "table", "posture": "sit", "behavior": "read", "window": "on", "curtain": "on",
...     "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off",
...     "lamp": "on", "ceiling_light": "on"})
>>> services, optimal = roll.run(codes, states)
>>> sorted(home.services[a].name for a in services), optimal     # Fig. 9, case 1
(['CloseCurtain', 'CloseWindow', 'RemindToSleep', 'SendDrinks'], True)
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from homecog.environment.core import Core
from homecog.environment.kernels import best_allowed, greedy_path
from homecog.home.classes import group_classes
from homecog.home.encoding import context_index
from homecog.home.groups import project
from homecog.home.model import Home
from homecog.home.scenes import compose
from homecog.learning.policy import Policy


def greedy_services(
    core: Core, q: np.ndarray, c: int, h: int, n: int | None = None, limit: int = 64
) -> list[int]:
    """The services of one table's greedy roll-out from (c, h, n) until the optimum or ``limit``."""
    n = core.full_needs(c) if n is None else n
    return [int(a) for a in greedy_path(core.tables, q, c, h, n, limit)]


class Rollout:
    """The greedy roll-out of a whole home from its policy (one environment per group)."""

    def __init__(self, home: Home, policy: Policy) -> None:
        policy.check_home(home)
        self.home = home
        self.policy = policy
        self.cores = [Core(home) if policy.joint else Core(project(home, g)) for g in policy.groups]
        self.classes = [None if policy.joint else group_classes(home, g) for g in policy.groups]
        self.q = [policy.q(i) for i in range(len(policy.groups))]

    def run(
        self, codes: Sequence[int], states: Sequence[bool], limit: int | None = None
    ) -> tuple[list[int], bool]:
        """The services performed from a start state (all needs pending), in order, as positions in
        the home, and whether every group's roll-out was optimal: every step was progress, none
        was prohibited, and the optimum was reached."""
        full = context_index(self.home, codes)
        ctx = [full if cls is None else cls.index(codes) for cls in self.classes]
        groups = self.policy.groups
        h = [sum(1 << k for k, d in enumerate(g.device_index) if states[d]) for g in groups]
        n = [core.full_needs(ctx[i]) for i, core in enumerate(self.cores)]
        limit = limit or 2 * (len(self.home.devices) + len(self.home.services)) + 2
        out: list[int] = []
        optimal = True
        while len(out) < limit:
            best, value = -1, 0.0
            for i, core in enumerate(self.cores):
                if not groups[i].services or core.distance(ctx[i], h[i], n[i]) == 0:
                    continue
                s = core.index(ctx[i], h[i], n[i])
                a = int(best_allowed(core.tables, self.q[i], ctx[i], h[i], n[i]))
                if best < 0 or self.q[i][s, a] > value:
                    best, value, local = i, float(self.q[i][s, a]), a
            if best < 0:
                break
            core, c = self.cores[best], ctx[best]
            h2, n2, _, _, forbidden = core.step(c, h[best], n[best], local)
            optimal &= not forbidden and core.progressed(c, h[best], n[best], h2, n2)
            h[best], n[best] = h2, n2
            out.append(groups[best].service_index[local])
        done = all(core.distance(ctx[i], h[i], n[i]) == 0 for i, core in enumerate(self.cores))
        return compose(self.home, codes, states, out), optimal and done
