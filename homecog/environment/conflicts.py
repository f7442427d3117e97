"""Conflicting rules, group by group (``homecog home check``).

A start state is stuck when no sequence of allowed services, each of them progress (lowering
the distance without switching a device away from the state wanted), reaches its optimum: a
prohibited rule blocks the only way, or no service sets a device the comfort rules care about.
Groups are independent, so a start state of the home is stuck exactly when its part in some
group is; each group is checked on its own small space and the
home's count follows without enumerating the joint space.

>>> from homecog.home import load_home
>>> report = find_conflicts(load_home("paper"))
>>> report.stuck, report.groups
(0, [])
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from homecog.environment.core import Core
from homecog.environment.reachability import optimal_start_states, solvable_start_states
from homecog.home.classes import group_classes, home_classes, representatives
from homecog.home.groups import Group, device_groups, project
from homecog.home.model import Home
from homecog.home.states import state_word


@dataclass(frozen=True)
class GroupConflict:
    """A group with stuck start states: how many of how many, and the first one."""

    group: Group
    stuck: int
    start_states: int
    example: dict[str, str]


@dataclass
class ConflictReport:
    """Stuck start states of the whole home, and the groups they come from."""

    stuck: int
    start_states: int
    groups: list[GroupConflict] = field(default_factory=list)


def _solvable(core: Core) -> np.ndarray:
    """Per (context, device states) of a group, whether its optimum can be reached."""
    if core.n_services:
        return solvable_start_states(core.tables)
    return optimal_start_states(core.tables)  # nothing can be done: only the optimum is fine


def find_conflicts(home: Home) -> ConflictReport:
    """Every group's stuck start states, and how many start states of the home are stuck.

    Each group is checked over its classes of contexts (:mod:`homecog.home.classes`); counts
    are of the home's own start states, and an example is a context of the home."""
    n_c = home.context_count
    per_group = []
    conflicts = []
    for group in device_groups(home):
        classes = group_classes(home, group)
        core = Core(project(home, group))
        ok = _solvable(core)
        per_group.append((classes, ok.sum(axis=1), 1 << len(group.devices)))
        stuck = int(((~ok).sum(axis=1) * classes.weights()).sum())
        if stuck:
            c, h = (int(x[0]) for x in np.nonzero(~ok))
            codes = np.unravel_index(c, classes.radices)
            example = {
                f.name: f.values[classes.members[j][int(k)][0]]
                for j, (f, k) in enumerate(zip(home.features, codes, strict=True))
            }
            example |= {d: state_word(bool(h >> i & 1)) for i, d in enumerate(group.devices)}
            conflicts.append(GroupConflict(group, stuck, n_c << len(group.devices), example))
    total = n_c << len(home.devices)
    stuck = 0
    if conflicts:  # summed over the classes of contexts no rule tells apart, each of its weight
        every = home_classes(home)
        codes = representatives(every)
        partial = np.zeros(len(codes), dtype=bool)
        for classes, counts, size in per_group:
            if (counts < size).any():
                partial |= (counts < size)[classes.indices(codes)]
        rows, weights = codes[partial], every.weights()[partial].tolist()
        solvable = [1] * len(rows)
        for classes, counts, _ in per_group:
            for i, n in enumerate(counts[classes.indices(rows)].tolist()):
                solvable[i] *= n
        stuck = sum(w * ((1 << len(home.devices)) - n) for w, n in zip(weights, solvable, strict=True))
    return ConflictReport(stuck=stuck, start_states=total, groups=conflicts)
