"""Every method of ``eval`` and ``replay`` learned from one policy.

The trees learn the samples of every group, one group at a time. K-means and the Hoeffding
trees learn from samples of the whole home; for a policy learned group by group these are
random start states of the home whose services are read off the groups' samples in the same
pass (a start state performs a service exactly when its group's part does), so no stage ever
enumerates the joint space. A joint policy gives them its samples as before.

A baseline that cannot run at a home's size is left out and the reason said
(:data:`HOEFFDING_BUDGET`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from homecog.errors import EvaluationError
from homecog.evaluation.baselines import BASELINES, OnlineMethod
from homecog.evaluation.methods import METHODS, HoeffdingMethod, KMeansMethod, Method, TreeMethod
from homecog.home.codec import Space
from homecog.home.model import Home
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet, draw_readings, policy_samples
from homecog.learning.policy import Policy

Progress = Callable[[str], None]
#: Random start states drawn for K-means and the Hoeffding trees of a grouped policy.
DRAWS = 30_000
#: Most (instances × features) the Hoeffding baseline's trees learn in all: river's tree
#: updates about 150,000 features a second here, so 10 million is about a minute.
HOEFFDING_BUDGET = 10_000_000
HOEFFDING_SAMPLES = 8_000
#: Samples the counting baselines (frequency, ha_usage, markov) count, and the naive Bayes
#: baseline learns. river's
#: BernoulliNB takes about 0.15 ms a sample and service to learn and about 0.5 ms a service to
#: answer (paper: 10 ms a scenario), so it is given fewer samples, and is left out, like the
#: Hoeffding trees, where (samples × services) passes its budget (homes of over 50 services).
FREQUENCY_SAMPLES = 8_000
NAIVE_BAYES_SAMPLES = 2_000
NAIVE_BAYES_BUDGET = 100_000


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


def _baseline(name: str, home: Home, samples: SampleSet, n: int, seed: int) -> OnlineMethod:
    """A simple online learner that has learned ``n`` of the samples, in a random order."""
    method = OnlineMethod(name, home)
    pick = np.random.default_rng([seed, 11]).permutation(len(samples))[:n]
    method.learn_samples(samples.codes[pick], samples.positions[pick] >= 0, samples.readings[pick])
    return method


def learn_methods(
    home: Home,
    policy: Policy,
    names: Sequence[str],
    *,
    seed: int = 0,
    kmeans_k: int = 64,
    keep_log: bool = False,
    progress: Progress | None = None,
) -> Learned:
    """Learn every method named (and the multi tree) from a policy, one group at a time."""
    unknown = [n for n in names if n not in METHODS]
    if unknown:
        raise EvaluationError(f"unknown method {unknown[0]!r}; expected some of {', '.join(METHODS)}")
    wanted = [m for m in ("multi", "paper") if m in names or (m == "multi" and keep_log)]
    trees = {mode: IHDRTree(home, mode=mode) for mode in wanted}
    baselines = [n for n in names if n in ("kmeans", "hoeffding", *BASELINES)]
    log = SampleLog(seed=seed, joint=policy.joint) if keep_log else None
    draws: SampleSet | None = None
    if baselines and not policy.joint:
        codes, readings = _draw_starts(home, DRAWS, np.random.default_rng([seed, 7]))
        n_f = len(home.features)
        positions = np.full((DRAWS, len(home.services)), -1, dtype=np.int8)
        draws = SampleSet(
            space=Space(home),
            codes=codes.astype(np.int16),
            readings=readings,
            positions=positions,
            masks=np.zeros((DRAWS, len(home.services) + 1), dtype=np.int64),
        )
    if progress:
        progress(f"learning from the samples of {len(policy.groups)} group(s) ...")
    groups = [i for i, g in enumerate(policy.groups) if g.services]
    for i, samples in zip(groups, policy_samples(home, policy, seed=seed), strict=True):
        for tree in trees.values():
            tree.learn_many(samples)
        if log is not None:
            log.add(samples, i)
        if draws is not None:
            group = policy.groups[i]
            h = np.zeros(DRAWS, dtype=np.int64)
            for k, d in enumerate(group.device_index):
                h |= codes[:, n_f + d].astype(np.int64) << k
            rows = samples.rows(codes, h)
            draws.positions[:, list(group.service_index)] = samples.positions[rows]
        elif baselines and policy.joint:
            draws = samples
    out: dict[str, Method] = {}
    skipped: dict[str, str] = {}
    for name in names:
        if name in trees:
            out[name] = TreeMethod(trees[name])
            continue
        assert draws is not None
        if name == "kmeans":
            if progress:
                progress("learning kmeans ...")
            out[name] = KMeansMethod(draws, k=kmeans_k, seed=seed)
        elif name == "hoeffding":
            # a service's tree sees the context and the devices of its group: nothing else can
            # matter to it (the action model says so), and it keeps the baseline's cost linear
            seen = _seen_features(home, policy)
            work = HOEFFDING_SAMPLES * sum(len(f) for f in seen)
            if work > HOEFFDING_BUDGET:
                skipped[name] = (
                    f"not run: its {len(home.services)} river trees (one per service) learning "
                    f"{HOEFFDING_SAMPLES:,} samples would update {work:,} features, "
                    f"{work / HOEFFDING_BUDGET:.1f} times the {HOEFFDING_BUDGET:,} (about a minute) "
                    "it is given"
                )
                continue
            if progress:
                progress("learning hoeffding ...")
            out[name] = HoeffdingMethod(draws, max_samples=HOEFFDING_SAMPLES, seed=seed, features=seen)
        elif name in BASELINES:
            n = NAIVE_BAYES_SAMPLES if name == "naive_bayes" else FREQUENCY_SAMPLES
            work = n * len(home.services)
            if name == "naive_bayes" and work > NAIVE_BAYES_BUDGET:
                skipped[name] = (
                    f"not run: its {len(home.services)} river models (one per service) learning "
                    f"{n:,} samples would make {work:,} updates, {work / NAIVE_BAYES_BUDGET:.1f} "
                    f"times the {NAIVE_BAYES_BUDGET:,} it is given (beyond, its answers take minutes)"
                )
                continue
            if progress:
                progress(f"learning {name} ...")
            out[name] = _baseline(name, home, draws, n, seed)
    return Learned(methods=out, skipped=skipped, log=log, tree=trees.get("multi"))
