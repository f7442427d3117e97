"""Sarsa group by group: one table per independent group of devices.

Each group is learned by the very kernel of :mod:`homecog.learning.sarsa` — the paper's
policy, Eq. 1 on the group's own distance — on its projection (context, the group's
devices, its pending needs). Episodes start in every start state of the group with every one
of its services once per *sweep*, in a fresh random order each time (exploring starts), so no
start state waits on chance and no service's value there is left as it was first learned (the
paper's policy takes the best once every service was tried, and a service tried before the
values after it were known could never win again); sweeps go on until the greedy choice of
every state stayed the same over a whole sweep and every state an episode has been in has had
every service tried (at least :data:`MIN_SWEEPS`, at most :data:`MAX_SWEEPS`), or for a fixed
number of
episodes when one is given. Groups are independent, so they are learned in parallel threads
(the kernels release the GIL), each from its own seed: the result does not depend on the
number of threads.

A group learns over the classes of contexts it can tell apart (:mod:`homecog.home.classes`),
so its table does not grow with context values that none of its rules names.

The greedy roll-out of the home performs, at each step, the best service over the groups not
yet at their optimum, and composes the scenes. Since no service of a group touches another
group, the home's roll-out from (c, h) is optimal exactly when every group's roll-out from
(c, h_g) is, so the home's greedy-optimal rate is, exactly, the mean over contexts of the
product of the groups' rates in that context (each read at the context's class) — without
enumerating the joint space.

>>> from homecog.home import load_home
>>> result = train_policy(load_home("paper"), SarsaConfig(seed=0))
>>> len(result.policy.groups), result.greedy_optimal_rate
(10, 1.0)
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field

import numpy as np

from homecog.environment.core import Core
from homecog.environment.reachability import greedy_outcomes, optimal_start_states
from homecog.home.classes import group_classes, home_classes, representatives
from homecog.home.groups import Group, device_groups, project
from homecog.home.model import Home
from homecog.learning.policy import Policy, round_q
from homecog.learning.qtable import QTable
from homecog.learning.sarsa import RunFigures, SarsaConfig, run_table, seed_rng, train
from homecog.learning.size import check_size

MIN_SWEEPS = 2
MAX_SWEEPS = 64


@dataclass
class PolicyResult(RunFigures):
    """A run's figures and the policy it made."""

    policy: Policy = field(kw_only=True)


@dataclass
class _Learned:
    table: QTable
    rates: np.ndarray  # per context, the share of the group's start states with an optimal roll-out
    steps: int


def _learn_group(
    home: Home, group: Group, config: SarsaConfig, episodes: int | None, report: Callable[[int], None]
) -> _Learned:
    core = Core(project(home, group))
    table = QTable.empty(core, config=asdict(config))
    n_starts = core.n_start_states()
    rng = seed_rng(config.seed * 1_000_003 + group.index)
    order = np.random.default_rng([config.seed, group.index])
    steps = 0
    if group.services:
        previous: np.ndarray | None = None
        sweep = 0
        n_services = len(group.services)
        while True:
            pairs = order.permutation(n_starts * n_services).astype(np.int64)
            if episodes is not None:
                pairs = pairs[: episodes - table.episodes]
            starts, firsts = pairs // n_services, pairs % n_services
            steps += run_table(core, table, config, len(starts), table.episodes, rng, starts, firsts)
            table.episodes += len(starts)
            sweep += 1
            if episodes is not None:
                if table.episodes >= episodes:
                    break
                continue
            greedy = table.q.argmax(axis=1)
            stable = previous is not None and (greedy == previous).all() and _all_tried(table)
            if (sweep >= MIN_SWEEPS and stable) or sweep >= MAX_SWEEPS:
                break
            previous = greedy
    report(n_starts)
    table.steps = steps
    table.rng = rng
    round_q(table.q)
    ok = greedy_outcomes(core.tables, table.q) if group.services else optimal_start_states(core.tables)
    table.greedy_optimal_rate = float(ok.mean())
    table.tried = np.zeros((0, 1), dtype=np.int64)  # not kept: a grouped run is not resumed
    return _Learned(table=table, rates=ok.mean(axis=1), steps=steps)


def _all_tried(table: QTable) -> bool:
    """Whether every service has been tried in every state an episode has been in: until then a
    greedy choice can rest on a value never compared with an untried service's."""
    n = table.q.shape[1]
    full = np.array([(1 << min(32, n - 32 * w)) - 1 for w in range(table.tried.shape[1])], dtype=np.int64)
    visited = (table.tried != 0).any(axis=1)
    return bool((table.tried[visited] == full).all())


def _starts(home: Home, group: Group) -> int:
    """A group's start states: its classes of contexts × 2^devices."""
    return group_classes(home, group).count << len(group.devices)


def _budgets(home: Home, groups: tuple[Group, ...], episodes: int | None) -> list[int | None]:
    """Episodes per group: automatic (None), or a fixed total split by start states."""
    if episodes is None:
        return [None] * len(groups)
    weights = [_starts(home, g) if g.services else 0 for g in groups]
    total = sum(weights) or 1
    shares = [episodes * w // total for w in weights]
    # the rest, one each, to the groups that lost the largest fractions: exactly `episodes` in all
    rest = sorted(range(len(groups)), key=lambda i: -(episodes * weights[i] % total))
    for i in rest[: episodes - sum(shares)] if any(weights) else []:
        shares[i] += 1
    return shares


def train_policy(
    home: Home,
    config: SarsaConfig | None = None,
    *,
    joint: bool = False,
    episodes: int | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> PolicyResult:
    """Learn a home: group by group (default), or as the paper's one joint table.

    ``episodes``: grouped, a fixed total split over the groups (default: sweeps until stable);
    joint, ``config.episodes``. ``progress(done, total)`` counts start states (grouped) or
    episodes (joint).
    """
    config = config or SarsaConfig()
    config.validate()
    check_size(home, joint=joint)
    start = time.perf_counter()
    if joint:
        result = train(home, config, progress=progress)
        policy = Policy.joint_from(home, result.q_table)
        policy.seconds = result.seconds
        return PolicyResult(
            result.episodes, result.steps, result.seconds, result.greedy_optimal_rate, policy=policy
        )

    groups = device_groups(home)
    budgets = _budgets(home, groups, episodes)
    total = sum(_starts(home, g) for g in groups)
    done = 0

    def report(n: int) -> None:
        nonlocal done
        done += n
        if progress is not None:
            progress(min(done, total), total)

    workers = workers or min(len(groups), os.cpu_count() or 1)
    with ThreadPoolExecutor(max_workers=max(1, workers)) as pool:
        learned = list(
            pool.map(
                lambda gb: _learn_group(home, gb[0], config, gb[1], report), zip(groups, budgets, strict=True)
            )
        )
    # the mean over the home's contexts, summed over the classes no rule tells apart
    every = home_classes(home)
    codes = representatives(every)
    rates = np.ones(len(codes))
    for group, item in zip(groups, learned, strict=True):
        rates *= item.rates[group_classes(home, group).indices(codes)]
    weights = every.weights()
    seconds = time.perf_counter() - start
    rate = float((rates * weights).sum() / weights.sum())
    policy = Policy(
        home_name=home.name,
        home_hash=home.content_hash,
        joint=False,
        groups=groups,
        tables=[item.table for item in learned],
        greedy_optimal_rate=rate,
        config=asdict(config),
        seconds=seconds,
    )
    return PolicyResult(
        policy=policy,
        episodes=policy.episodes,
        steps=policy.steps,
        seconds=seconds,
        greedy_optimal_rate=rate,
    )
