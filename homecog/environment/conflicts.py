"""Conflicting rules, group by group (``homecog home check``; SPEC §4.1).

A start state is stuck when no sequence of allowed services, each lowering the distance,
reaches its optimum: a prohibited rule blocks the only way, or no service sets a device the
comfort rules care about. Groups are independent, so a start state of the home is stuck
exactly when its part in some group is; each group is checked on its own small space and the
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
from homecog.home.groups import Group, device_groups, project
from homecog.home.model import Home


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
    """Every group's stuck start states, and how many start states of the home are stuck."""
    n_c = home.context_count
    ok_counts = []
    conflicts = []
    for group in device_groups(home):
        core = Core(project(home, group))
        ok = _solvable(core)
        ok_counts.append(ok.sum(axis=1))
        stuck = int((~ok).sum())
        if stuck:
            c, h = (int(x[0]) for x in np.nonzero(~ok))
            example = dict(
                zip(
                    home.feature_names,
                    (f.values[k] for f, k in zip(home.features, core.codes(c), strict=True)),
                    strict=True,
                )
            )
            example |= {d: "on" if h >> i & 1 else "off" for i, d in enumerate(group.devices)}
            conflicts.append(GroupConflict(group, stuck, n_c << len(group.devices), example))
    total = n_c << len(home.devices)
    stuck = 0
    if conflicts:
        full = [1 << len(g.devices) for g in device_groups(home)]
        partial = np.zeros(n_c, dtype=bool)
        for counts, size in zip(ok_counts, full, strict=True):
            partial |= counts < size
        for c in np.flatnonzero(partial).tolist():
            solvable = 1
            for counts in ok_counts:
                solvable *= int(counts[c])
            stuck += (1 << len(home.devices)) - solvable
    return ConflictReport(stuck=stuck, start_states=total, groups=conflicts)
