"""Every method of ``eval`` and ``replay`` learned from one policy.

The trees learn the samples of every group, one group at a time. K-means and the Hoeffding
trees learn from samples of the whole home; for a policy learned group by group these are
random start states of the home whose services are read off the groups' samples in the same
pass (a start state performs a service exactly when its group's part does), so no stage ever
enumerates the joint space. A joint policy gives them its samples as before.

A baseline that cannot run at a home's size is left out and the reason said
(:attr:`homecog.evaluation.registry.MethodEntry.refuse`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from homecog.evaluation.methods import Method, TreeMethod, not_run
from homecog.evaluation.registry import REGISTRY, Setting, check_methods
from homecog.home.codec import Space
from homecog.home.model import Home
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet, draw_readings, policy_samples
from homecog.learning.policy import Policy

Progress = Callable[[str], None]
#: Random start states drawn for K-means and the Hoeffding trees of a grouped policy.
DRAWS = 30_000


@dataclass
class Learned:
    """The methods learned, those left out (with why), and the build's sample log."""

    methods: dict[str, Method]
    skipped: dict[str, str] = field(default_factory=dict)
    log: SampleLog | None = None
    tree: IHDRTree | None = None  # the multi tree (for corrections), learned even if not asked


def _draw_starts(home: Home, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random start states of the whole home: codes (features, then devices) and readings."""
    radix = np.array([f.radix for f in home.features])
    ctx = (rng.random((n, len(radix))) * radix).astype(np.int64)
    dev = rng.integers(0, 2, (n, len(home.devices)))
    codes = np.concatenate([ctx, dev], axis=1)
    return codes, draw_readings(Space(home), codes, rng)


def _seen_features(home: Home, policy: Policy) -> list[list[str]]:
    """Per service, the context features and its group's devices (all, for a joint policy)."""
    everything = [*home.feature_names, *home.device_names]
    out = [everything] * len(home.services)
    if not policy.joint:
        for g in policy.groups:
            for a in g.service_index:
                out[a] = [*home.feature_names, *g.devices]
    return out


def _draws(home: Home, seed: int) -> tuple[SampleSet, np.ndarray]:
    """:data:`DRAWS` random start states of the whole home, no service performed yet (the
    groups' samples fill them in), and their codes."""
    codes, readings = _draw_starts(home, DRAWS, np.random.default_rng([seed, 7]))
    positions = np.full((DRAWS, len(home.services)), -1, dtype=np.int8)
    draws = SampleSet(
        space=Space(home),
        codes=codes.astype(np.int16),
        readings=readings,
        positions=positions,
        masks=np.zeros((DRAWS, len(home.services) + 1), dtype=np.int64),
    )
    return draws, codes


def _fill(
    draws: SampleSet, codes: np.ndarray, home: Home, policy: Policy, i: int, samples: SampleSet
) -> None:
    """Read the services of group ``i`` at the drawn start states off its samples."""
    group = policy.groups[i]
    n_f = len(home.features)
    h = np.zeros(DRAWS, dtype=np.int64)
    for k, d in enumerate(group.device_index):
        h |= codes[:, n_f + d].astype(np.int64) << k
    rows = samples.rows(codes, h)
    draws.positions[:, list(group.service_index)] = samples.positions[rows]


def _learn_groups(
    home: Home, policy: Policy, grouped: Sequence[Method], whole: bool, log: SampleLog | None, seed: int
) -> SampleSet | None:
    """One pass over the policy's samples, group by group: the trees learn them, the log keeps
    them; with ``whole``, the samples of the whole home the other methods learn are returned."""
    draws, codes = _draws(home, seed) if whole and not policy.joint else (None, None)
    groups = [i for i, g in enumerate(policy.groups) if g.services]
    for i, samples in zip(groups, policy_samples(home, policy, seed=seed), strict=True):
        for method in grouped:
            method.fit(samples)
        if log is not None:
            log.add(samples, i)
        if draws is not None:
            assert codes is not None
            _fill(draws, codes, home, policy, i, samples)
        elif whole and policy.joint:
            draws = samples
    return draws


def learn_methods(
    home: Home,
    policy: Policy,
    names: Sequence[str],
    *,
    seed: int = 0,
    kmeans_k: int = 64,
    keep_log: bool = False,
    user: str | None = None,
    progress: Progress | None = None,
) -> Learned:
    """Learn every method named (and the multi tree) from a policy, one group at a time; the
    trees answer for ``user``."""
    check_methods(names)
    setting = Setting(home, seed=seed, kmeans_k=kmeans_k, features=_seen_features(home, policy), user=user)
    skipped = {n: why for n in names if (why := REGISTRY[n].refuse(setting))}
    made = {n: REGISTRY[n].make(setting) for n in names if n not in skipped}
    if keep_log and "multi" not in made:
        made["multi"] = REGISTRY["multi"].make(setting)
    grouped = [m for n, m in made.items() if REGISTRY[n].by_group]
    whole = [n for n in made if not REGISTRY[n].by_group]
    log = SampleLog(seed=seed, joint=policy.joint) if keep_log else None
    if progress:
        progress(f"learning from the samples of {len(policy.groups)} group(s) ...")
    draws = _learn_groups(home, policy, grouped, bool(whole), log, seed)
    for name in whole:
        if progress:
            progress(f"learning {name} ...")
        assert draws is not None
        made[name].fit(draws)
        if why := not_run(made[name]):
            skipped[name] = why
    tree = made.get("multi")
    return Learned(
        methods={n: made[n] for n in names if n not in skipped},
        skipped=skipped,
        log=log,
        tree=tree.tree if isinstance(tree, TreeMethod) else None,
    )
