"""Homes of real size: groups from the action model, Sarsa per group, the exact rate
of the composed roll-out, the grouped Q file, ground truth and conflicts group by group, and
sizes refused at once."""

from __future__ import annotations

import itertools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from homecog.environment.conflicts import find_conflicts
from homecog.environment.core import Core
from homecog.environment.reachability import greedy_outcomes
from homecog.errors import HomeTooLargeError, QTableError
from homecog.home import load_home, load_home_text
from homecog.home.classes import group_classes
from homecog.home.groups import device_groups, project
from homecog.home.scenes import scene_services
from homecog.home.truth import optimal_service_sets
from homecog.learning.grouped import train_policy
from homecog.learning.policy import Policy
from homecog.learning.rollout import Rollout
from homecog.learning.sarsa import SarsaConfig, train
from homecog.learning.size import check_size, estimate, exact_states

ROOT = Path(__file__).parent.parent
HOMES = Path(__file__).parent / "homes"

LAB = """
name: lab
context:
  time: {kind: clock, bins: {day: [7, 20], night: [20, 7]}}
  who: {kind: categorical, values: [nobody, someone]}
devices: {fan: {}, heater: {}, vent: {}, light: {}, alarm: {}}
services:
  FanOn: {category: air, set: {fan: on}}
  FanOff: {category: air, set: {fan: off}}
  HeatOn: {category: air, set: {heater: on}}
  HeatOff: {category: air, set: {heater: off}}
  VentOpen: {category: air, set: {vent: on}}
  VentShut: {category: air, set: {vent: off}}
  LightsOut: {category: light, set: {light: off, fan: off}}
  LightOn: {category: light, set: {light: on}}
  LightOff: {category: light, set: {light: off}}
  Silence: {category: talk, set: {alarm: off}}
  Greet: {category: talk}
  Warn: {category: talk}
comfort:
  fan: [{when: {who: [someone], time: [day]}, want: on}, {want: off}]
  heater: [{when: {who: [someone], time: [night]}, want: on}, {want: off}]
  vent: [{when: {who: [nobody]}, want: off}, {when: {time: [night]}, want: off}, {want: on}]
  light: [{when: {who: [someone], time: [night]}, want: on}, {want: off}]
  alarm: [{want: off}]
needs:
  Greet: [{when: {who: [someone]}}]
  Warn: [{when: {who: [nobody], time: [night]}}]
prohibited:
  HeatOn: [{when: {vent: [on]}}]
  Warn: [{when: {alarm: [on]}}]
"""


@pytest.fixture(scope="module")
def lab():
    return load_home_text(LAB, "lab.yaml")


# -- groups --------------------------------------------------------------------------------------
def test_groups_come_from_the_action_model(lab):
    groups = [(g.devices, g.services) for g in device_groups(lab)]
    assert groups == [
        (("fan",), ("FanOn", "FanOff")),
        (("heater", "vent"), ("HeatOn", "HeatOff", "VentOpen", "VentShut")),  # heat never with vent open
        (("light",), ("LightOn", "LightOff")),
        (("alarm",), ("Silence", "Warn")),  # a prohibited rule ties the interaction service to a device
        ((), ("Greet",)),  # an interaction service of its own
    ]
    # LightsOut sets the light and the fan as LightOff and FanOff do: a scene, in no group
    assert [lab.services[a].name for a in scene_services(lab)] == ["LightsOut"]


def test_one_service_that_is_not_a_scene_ties_what_it_sets(lab):
    # the fan off only with the light: LightsOut is then the one way, and it ties them
    tied = load_home_text(LAB.replace("  FanOff: {category: air, set: {fan: off}}\n", ""), "tied.yaml")
    assert scene_services(tied) == ()
    assert device_groups(tied)[0].devices == ("fan", "light")
    # so does a device-state rule of a service that sets several devices
    ruled = load_home_text(LAB.replace("Warn: [{when: {alarm: [on]}}]", "LightsOut: [{when: {vent: [on]}}]"))
    assert scene_services(ruled) == ()
    assert device_groups(ruled)[0].devices == ("fan", "heater", "vent", "light")


def test_the_reward_never_decides_a_group(lab):
    # other comfort and needs rules (the reward being learned) leave the groups as they were
    other = load_home_text(
        LAB.replace(
            "fan: [{when: {who: [someone], time: [day]}, want: on}, {want: off}]", "fan: [{want: on}]"
        ).replace("Greet: [{when: {who: [someone]}}]", "Greet: [{when: {time: [night]}}]"),
        "other.yaml",
    )
    assert other.content_hash != lab.content_hash
    assert [(g.devices, g.services) for g in device_groups(other)] == [
        (g.devices, g.services) for g in device_groups(lab)
    ]


def test_the_paper_home_splits_into_ten_groups(paper):
    groups = device_groups(paper)
    assert [g.devices for g in groups][:6] == [
        ("window", "ac_living", "ac_bedroom"),
        ("curtain",),
        ("tv_living",),
        ("tv_bedroom",),
        ("lamp",),
        ("ceiling_light",),
    ]
    assert sorted(a for g in groups for a in g.service_index) == list(range(len(paper.services)))


def test_a_projection_keeps_the_homes_optimum_on_its_devices(lab):
    for group in device_groups(lab):
        sub = project(lab, group)
        for codes in itertools.product(*(range(f.radix) for f in lab.features)):
            wanted = lab.wanted(codes)
            assert sub.wanted(codes) == tuple(wanted[d] for d in group.device_index)
            needs = [lab.services[a].name for a in lab.needs_of(codes)]
            assert [sub.services[a].name for a in sub.needs_of(codes)] == [
                n for n in needs if n in group.services
            ]


# -- learning and the exact rate -------------------------------------------------------------------
def _composed_rate(home, policy) -> float:
    roll = Rollout(home, policy)
    ok = total = 0
    for codes in itertools.product(*(range(f.radix) for f in home.features)):
        for states in itertools.product((False, True), repeat=len(home.devices)):
            ok += roll.run(codes, states)[1]
            total += 1
    return ok / total


@pytest.mark.parametrize("episodes", [None, 40, 400])
def test_the_rate_from_the_groups_is_the_rate_of_the_composed_rollout(lab, episodes):
    # also with too few episodes, so that the rate is neither 0 nor 1 and the product is tested
    result = train_policy(lab, SarsaConfig(seed=3), episodes=episodes)
    assert result.greedy_optimal_rate == pytest.approx(_composed_rate(lab, result.policy), abs=1e-12)
    if episodes is None:
        assert result.greedy_optimal_rate == 1.0
    else:
        assert result.episodes == episodes


def test_grouped_and_joint_reach_the_optimum_from_the_same_start_states():
    # without the scene: the joint table's greedy choice settles once every service was tried
    # in a state, and a scene saves too little of Eq. 1's discounted reward to win it back there
    lab = load_home_text(LAB.replace("  LightsOut: {category: light, set: {light: off, fan: off}}\n", ""))
    joint = train(lab, SarsaConfig(episodes=200_000, seed=0))
    core = Core(lab)
    joint_ok = greedy_outcomes(core.tables, joint.q_table.q)
    roll = Rollout(lab, train_policy(lab, SarsaConfig(seed=0)).policy)
    for c in range(core.n_contexts):
        for h in range(1 << core.n_devices):
            assert roll.run(core.codes(c), core.states(h))[1] == joint_ok[c, h]
    assert joint_ok.all()


def test_training_is_reproducible_and_independent_of_threads(lab):
    one = train_policy(lab, SarsaConfig(seed=5), workers=1).policy
    many = train_policy(lab, SarsaConfig(seed=5), workers=4).policy
    assert [t.episodes for t in one.tables] == [t.episodes for t in many.tables]
    assert all(np.array_equal(a.q, b.q) for a, b in zip(one.tables, many.tables, strict=True))


def test_large_homes_learn_linearly_and_exactly(rooms8):
    result = train_policy(rooms8, SarsaConfig(seed=0))
    assert len(result.policy.groups) == 44 and result.greedy_optimal_rate >= 0.999
    # every group's table covers only its own devices, over the contexts it can tell apart:
    # 48 devices, yet no table over 2^48, and none with a row per room's value of location
    for group, table in zip(result.policy.groups, result.policy.tables, strict=True):
        classes = group_classes(rooms8, group)
        assert table.q.shape[0] == exact_states(rooms8, group) <= classes.count << len(group.services)
        assert len(classes.members[rooms8.feature_index("location")]) <= 2
    assert sum(t.q.size for t in result.policy.tables) < 100_000


# -- the Q file ------------------------------------------------------------------------------------
def test_policy_file_round_trip(lab, tmp_path):
    policy = train_policy(lab, SarsaConfig(seed=1)).policy
    path = policy.save(tmp_path / "lab.npz")
    with np.load(path) as z:
        assert z["q0"].dtype == np.float16  # half the bytes (docs/design.md says why it is safe)
    back = Policy.load(path, lab)
    assert not back.joint and back.greedy_optimal_rate == policy.greedy_optimal_rate
    assert all(np.array_equal(a.q, back.q(i)) for i, a in enumerate(policy.tables))
    assert [t.episodes for t in back.tables] == [t.episodes for t in policy.tables]
    other = load_home(HOMES / "studio.yaml")
    with pytest.raises(QTableError, match="made for home 'lab'"):
        Policy.load(path, other)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(QTableError, match="not a homecog Q table"):
        Policy.load(tmp_path / "bad.npz", lab)


def test_a_joint_table_of_the_earlier_format_loads_as_a_joint_policy(lab, tmp_path):
    table = train(lab, SarsaConfig(episodes=20_000, seed=0)).q_table
    path = table.save(tmp_path / "old.npz")
    policy = Policy.load(path, lab)
    assert policy.joint and len(policy.groups) == 1 and np.array_equal(policy.q(0), table.q)
    joint = train_policy(lab, SarsaConfig(episodes=20_000, seed=0), joint=True).policy
    again = Policy.load(joint.save(tmp_path / "joint.npz"), lab)
    assert again.joint and again.tables[0].q.dtype == np.float32 and again.tables[0].tried.shape[0] > 0


# -- ground truth and conflicts ------------------------------------------------------------------
def _joint_truth(home, codes, states):
    """The ground truth searched over the joint space, as before groups (a reference): the
    fewest services of a sequence of progress steps (no wanted device switched away)."""
    wanted, needs = home.wanted(codes), frozenset(home.needs_of(codes))
    effects = [tuple((home.device_index(d), v) for d, v in s.sets) for s in home.services]

    def dist(st, pend):
        return sum(1 for x, w in zip(st, wanted, strict=True) if w is not None and x != w) + len(pend)

    def paths(st, pend):
        d = dist(st, pend)
        if d == 0:
            return {frozenset()}
        out = set()
        for a, effect in enumerate(effects):
            if home.is_prohibited(a, codes, st):
                continue
            nxt = list(st)
            for dev, v in effect:
                nxt[dev] = v
            st2, pend2 = (tuple(nxt), pend) if effect else (st, pend - {a})
            broke = any(x != y and (w is None or x == w) for x, y, w in zip(st, st2, wanted, strict=True))
            if dist(st2, pend2) < d and not broke:
                out |= {rest | {a} for rest in paths(st2, pend2)}
        return out

    found = paths(tuple(states), needs)
    fewest = min(map(len, found))
    return {frozenset(home.services[a].name for a in s) for s in found if len(s) == fewest}


@pytest.mark.parametrize("name", ["lab", "flat"])
def test_ground_truth_by_groups_equals_the_joint_search(lab, name):
    home = lab if name == "lab" else load_home(HOMES / "flat.yaml")
    rng = np.random.default_rng(0)
    for _ in range(300):
        codes = tuple(int(rng.integers(f.radix)) for f in home.features)
        states = tuple(bool(x) for x in rng.integers(0, 2, len(home.devices)))
        sets = optimal_service_sets(home, codes, states)
        joint = _joint_truth(home, codes, states)
        # the same fewest services; the joint search also lists a scene that does one
        # service's work beside it, which is never taken for it
        assert set(sets) <= joint and {len(s) for s in sets} == {len(s) for s in joint}
        for extra in joint - set(sets):
            assert any(home.service_index(a) in scene_services(home) for a in extra)

        def key(s, home=home):
            sets_devices = sum(len(home.services[home.service_index(a)].sets) for a in s)
            return (len(s), sets_devices, sorted(home.service_index(a) for a in s))

        assert sets[0] == min(sets, key=key)  # fewest services, then fewest devices set


def test_home_check_names_the_group_and_start_states_of_conflicting_rules(tmp_path):
    text = LAB.replace(
        "HeatOn: [{when: {vent: [on]}}]", "HeatOn: [{when: {vent: [on]}}, {when: {who: [someone]}}]"
    )
    path = tmp_path / "stuck.yaml"
    path.write_text(text)
    report = find_conflicts(load_home(path))
    assert [c.group.devices for c in report.groups] == [("heater", "vent")]
    conflict = report.groups[0]
    assert conflict.example["who"] == "someone" and conflict.example["heater"] == "off"
    # someone at night wants the heater on, which is never allowed then: half the heater states
    assert conflict.stuck == 2  # heater off at night with someone there, whatever the vent
    proc = subprocess.run(
        [sys.executable, "-m", "homecog.cli.main", "home", "check", str(path)], capture_output=True, text=True
    )
    assert proc.returncode == 0
    assert (
        "group 1 (heater, vent): 2 of its 16 start states, e.g. time=night, who=someone, heater=off, vent=off"
        in proc.stdout
    )
    assert report.stuck == conflict.stuck * 2**3  # times every state of the other groups' devices


# -- sizes -----------------------------------------------------------------------------------------
def test_a_group_too_large_is_refused_naming_it(tmp_path):
    # (counted, never enumerated: benchmarks/bench_scale.py measures how fast)
    path = tmp_path / "coupled.yaml"
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from homes import coupled_home_text

    path.write_text(coupled_home_text(34))
    home = load_home(path)
    with pytest.raises(HomeTooLargeError) as e:
        check_size(home)
    assert str(e.value) == (
        "coupled: too large to learn: its largest group, group 0 (d0, d1, d2, d3 and 30 more), has "
        "17,179,869,184 states (1 class of contexts × 2^34 device states) × 35 services; fewer "
        "devices tied together by one service or prohibited rule, or fewer context values"
    )
    context = "who=a," + ",".join(f"d{i}=off" for i in range(34))
    for command in (["train"], ["build"], ["eval", "--scenarios", "10"], ["cognize", "--context", context]):
        proc = subprocess.run(
            [sys.executable, "-m", "homecog.cli.main", *command, "--home", str(path)],
            capture_output=True,
            text=True,
        )
        assert proc.returncode == 2, command
        assert proc.stderr.startswith("homecog: error: coupled: too large to learn: its largest group")
        assert len(proc.stderr.strip().splitlines()) == 1  # at once: nothing learned or built first


def test_memory_budget_refusal_names_the_group_and_sizes(tmp_path, monkeypatch, rooms8):
    monkeypatch.setenv("HOMECOG_MEMORY", "8k")
    with pytest.raises(
        HomeTooLargeError,
        match=r"too large for this machine's memory: its largest group, "
        r"group 3 \(window_room1, ac_room1\), has 64 states \(16 classes of contexts .* of the 8.0 kB free",
    ):
        check_size(rooms8)
    monkeypatch.setenv("HOMECOG_MEMORY", "lots")
    with pytest.raises(HomeTooLargeError, match="HOMECOG_MEMORY: 'lots' is not a size"):
        check_size(rooms8)
    monkeypatch.delenv("HOMECOG_MEMORY")
    assert estimate(rooms8).needed_bytes < 2**20


def test_train_json_names_groups_and_joint(tmp_path):
    out = tmp_path / "lab.npz"
    (tmp_path / "lab.yaml").write_text(LAB)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "homecog.cli.main",
            "train",
            "--home",
            str(tmp_path / "lab.yaml"),
            "--out",
            str(out),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    data = json.loads(proc.stdout)
    assert data["groups"] == 5 and data["joint"] is False and data["greedy_optimal_rate"] == 1.0
    assert Policy.load(out, load_home(tmp_path / "lab.yaml")).episodes == data["episodes"]
