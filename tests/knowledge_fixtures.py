"""Trained and built homes for the knowledge tests, made once per test session.

``studio`` and ``flat`` are learned with the paper's joint table (their samples cover the joint
space, which some tests walk); ``paper`` group by group, as homecog learns it by default."""

from __future__ import annotations

import functools
from pathlib import Path

from homecog.environment.core import Core
from homecog.home import Home, load_home
from homecog.home.classes import group_classes
from homecog.home.groups import device_groups
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import learn_policy
from homecog.knowledge.samples import SampleSet, make_samples
from homecog.learning.grouped import train_policy
from homecog.learning.policy import Policy
from homecog.learning.sarsa import SarsaConfig, train

HOMES = Path(__file__).parent / "homes"
EPISODES = {"studio": 30_000, "flat": 600_000}


@functools.cache
def home(name: str) -> Home:
    return load_home(name if name == "paper" else HOMES / f"{name}.yaml")


def sample_count(name: str) -> int:
    """A home's samples, learned group by group: per group with services, its classes of contexts
    × its device states."""
    h = home(name)
    return sum(group_classes(h, g).count << len(g.devices) for g in device_groups(h) if g.services)


@functools.cache
def q_values(name: str):
    h = home(name)
    result = train(h, SarsaConfig(episodes=EPISODES[name], seed=0))
    assert result.greedy_optimal_rate >= 0.999, (name, result.greedy_optimal_rate)
    return result.q_table


@functools.cache
def samples(name: str) -> SampleSet:
    return make_samples(Core(home(name)), q_values(name).q, seed=0)


@functools.cache
def policy(name: str) -> Policy:
    """The home learned group by group (seconds)."""
    result = train_policy(home(name), SarsaConfig(seed=0))
    assert result.greedy_optimal_rate >= 0.999, (name, result.greedy_optimal_rate)
    return result.policy


@functools.cache
def tree(name: str, mode: str = "multi") -> IHDRTree:
    t = IHDRTree(home(name), mode=mode)
    if name == "paper":
        learn_policy(home(name), policy(name), t)
    else:
        t.learn_many(samples(name))
    return t
