"""Exact on any home: on random homes (scenes, devices switched by hand, services over several
devices, prohibited rules naming device states, clocks wrapping midnight, many locations), the
learned policy's rate is the share of start states the rules leave a way from, and the multi
tree's answers are the ground truth wherever there is one: precision and recall 1.0."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, event, given, note, settings
from random_homes import homes

from homecog.environment.conflicts import find_conflicts
from homecog.environment.core import Core
from homecog.environment.reachability import solvable_start_states
from homecog.evaluation.metrics import scores
from homecog.evaluation.scenarios import random_scenarios
from homecog.home import Home, load_home_text
from homecog.home.classes import group_classes
from homecog.home.groups import device_groups, project
from homecog.home.scenes import scene_services
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.pipeline import learn_policy
from homecog.learning.grouped import train_policy
from homecog.learning.sarsa import SarsaConfig


def _solvable(home: Home):
    """Whether the rules leave a way to the optimum from a scenario's point, group by group."""
    n_f = len(home.features)
    parts = []
    for group in device_groups(home):
        ok = solvable_start_states(Core(project(home, group)).tables) if group.services else None
        parts.append((group, group_classes(home, group), ok))

    def check(point) -> bool:
        codes = point.codes
        for group, classes, ok in parts:
            if ok is None:
                continue
            h = sum(1 << k for k, d in enumerate(group.device_index) if codes[n_f + d])
            if not ok[classes.index(codes[:n_f]), h]:
                return False
        return True

    return check


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(homes())
def test_multi_is_exact_on_random_homes(text):
    note(text)  # the home file, shown when a case fails
    home = load_home_text(text, "random.yaml")
    result = train_policy(home, SarsaConfig(seed=0))
    report = find_conflicts(home)
    assert result.greedy_optimal_rate == pytest.approx(1 - report.stuck / report.start_states, abs=1e-12)
    tree = IHDRTree(home)
    learn_policy(home, result.policy, tree)
    solvable = _solvable(home)
    cases = [s for s in random_scenarios(home, 150, seed=1) if solvable(s.point)]
    predicted = [tree.predict_one(s.point) for s in cases]
    truths = [sorted(s.truth_for(p)) for s, p in zip(cases, predicted, strict=True)]
    figures = scores(predicted, truths)
    assert (figures["precision"], figures["recall"]) == (1.0, 1.0), text
    scenes = {home.services[a].name for a in scene_services(home)}
    event(f"scenes in the truth: {bool(scenes & set().union(*map(set, truths)))}")
    event(f"unsolvable scenarios left out: {150 - len(cases) > 0}")
