"""Every method ``homecog eval`` and ``homecog replay`` compare, in one registry.

A method's name maps to a :class:`MethodEntry`: what it is (its description), how it is made
for a home (its factory, which does no learning: the work starts at ``fit``), whether it learns
the samples group by group (the trees) or the home's at once, whether a replay starts it from
the home's samples or from nothing, and why it may not run at a home's size.

>>> METHOD_NAMES[:4]
('multi', 'paper', 'kmeans', 'hoeffding')
>>> REGISTRY["markov"].from_rules
False

Every made method speaks the protocol of :class:`homecog.evaluation.methods.Method`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from homecog.errors import EvaluationError

if TYPE_CHECKING:
    from homecog.evaluation.methods import Method
    from homecog.home.model import Home

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
#: Samples the gradient-boosted trees learn in ``eval``; they are left out where (samples ×
#: services) passes the budget: a fit takes about 50 ms a service on 2,000 rows, so 100
#: services are about 5 seconds a fit, and a replay fits again every day.
BOOSTED_SAMPLES = 2_000
BOOSTED_BUDGET = 200_000


@dataclass(frozen=True)
class Setting:
    """What a method is made for: the home, the seed, K-means' k, per service the features its
    Hoeffding tree sees (default: all), and the user whose corrections the trees learn."""

    home: Home
    seed: int = 0
    kmeans_k: int = 64
    features: Sequence[Sequence[str]] | None = None
    user: str | None = None


def _runs(setting: Setting) -> str | None:
    return None


@dataclass(frozen=True)
class MethodEntry:
    """One method of the registry."""

    description: str
    #: The method for a setting, knowing nothing yet.
    make: Callable[[Setting], Method]
    #: True: it learns the samples of every group in turn (``fit`` once a group); else the
    #: samples of the whole home, once.
    by_group: bool = False
    #: True: a replay starts it from the home's samples; else from nothing (the household's
    #: events alone teach it).
    from_rules: bool = True
    #: Why it is not run at a setting's home (None: it is).
    refuse: Callable[[Setting], str | None] = _runs


def _tree(mode: str) -> Callable[[Setting], Method]:
    def make(setting: Setting) -> Method:
        from homecog.evaluation.methods import TreeMethod
        from homecog.knowledge.ihdr import IHDRTree

        return TreeMethod(IHDRTree(setting.home, mode=mode), user=setting.user)

    return make


def _kmeans(setting: Setting) -> Method:
    from homecog.evaluation.methods import KMeansMethod

    return KMeansMethod(setting.home, k=setting.kmeans_k, seed=setting.seed)


def _hoeffding_work(setting: Setting) -> int:
    features = setting.features or [[*setting.home.feature_names, *setting.home.device_names]] * len(
        setting.home.services
    )
    return HOEFFDING_SAMPLES * sum(len(f) for f in features)


def _hoeffding(setting: Setting) -> Method:
    from homecog.evaluation.methods import HoeffdingMethod

    features = None if setting.features is None else [list(f) for f in setting.features]
    return HoeffdingMethod(setting.home, max_samples=HOEFFDING_SAMPLES, seed=setting.seed, features=features)


def _refuse_hoeffding(setting: Setting) -> str | None:
    work = _hoeffding_work(setting)
    if work <= HOEFFDING_BUDGET:
        return None
    return (
        f"not run: its {len(setting.home.services)} river trees (one per service) learning "
        f"{HOEFFDING_SAMPLES:,} samples would update {work:,} features, "
        f"{work / HOEFFDING_BUDGET:.1f} times the {HOEFFDING_BUDGET:,} (about a minute) "
        "it is given"
    )


def _baseline(
    name: str,
    description: str,
    *,
    samples: int = FREQUENCY_SAMPLES,
    refuse: Callable[[Setting], str | None] = _runs,
) -> MethodEntry:
    """A simple online learner (:mod:`homecog.evaluation.baselines`): in ``eval`` it learns
    ``samples`` of the home's samples, in a replay only the household's events."""

    def make(setting: Setting) -> Method:
        from homecog.evaluation.baselines import OnlineMethod

        return OnlineMethod(name, setting.home, max_samples=samples, seed=setting.seed)

    return MethodEntry(description, make, from_rules=False, refuse=refuse)


def _refuse_naive_bayes(setting: Setting) -> str | None:
    n, services = NAIVE_BAYES_SAMPLES, len(setting.home.services)
    work = n * services
    if work <= NAIVE_BAYES_BUDGET:
        return None
    return (
        f"not run: its {services} river models (one per service) learning "
        f"{n:,} samples would make {work:,} updates, {work / NAIVE_BAYES_BUDGET:.1f} "
        f"times the {NAIVE_BAYES_BUDGET:,} it is given (beyond, its answers take minutes)"
    )


def _boosted(setting: Setting) -> Method:
    from homecog.evaluation.boosted import BoostedMethod

    return BoostedMethod(setting.home, max_samples=BOOSTED_SAMPLES, seed=setting.seed)


def _refuse_boosted(setting: Setting) -> str | None:
    services = len(setting.home.services)
    work = BOOSTED_SAMPLES * services
    if work <= BOOSTED_BUDGET:
        return None
    return (
        f"not run: its {services} gradient-boosted models (one per service) would each be fitted "
        f"on up to {BOOSTED_SAMPLES:,} rows at every fit, {work / BOOSTED_BUDGET:.1f} times the "
        f"{BOOSTED_BUDGET:,} rows it is given (about 5 seconds a fit)"
    )


REGISTRY: dict[str, MethodEntry] = {
    "multi": MethodEntry(
        "the knowledge tree (IHDR), every user's corrections in their own leaves",
        _tree("multi"),
        by_group=True,
    ),
    "paper": MethodEntry("the knowledge tree as the paper builds it", _tree("paper"), by_group=True),
    "kmeans": MethodEntry(
        "K-means over the samples; a cluster predicts the services of at least half its members", _kmeans
    ),
    "hoeffding": MethodEntry(
        "river's Hoeffding tree, one binary classifier per service", _hoeffding, refuse=_refuse_hoeffding
    ),
    "frequency": _baseline(
        "frequency", "per service, how often it was wanted in the same key; a threshold chosen online"
    ),
    "naive_bayes": _baseline(
        "naive_bayes",
        "river's Bernoulli naive Bayes, one model per service",
        samples=NAIVE_BAYES_SAMPLES,
        refuse=_refuse_naive_bayes,
    ),
    "ha_usage": _baseline("ha_usage", "Home Assistant's most used services per time of day over 30 days"),
    "markov": _baseline("markov", "a last-event Markov chain over the services wanted"),
    "boosted": MethodEntry(
        "scikit-learn's gradient-boosted trees, one per service, over the features and the recent "
        "past; retrained on every past event at each day boundary; a threshold chosen online",
        _boosted,
        from_rules=False,
        refuse=_refuse_boosted,
    ),
}
#: Every method's name, in the order of the reports.
METHOD_NAMES = tuple(REGISTRY)


def check_methods(names: Sequence[str]) -> None:
    """Refuse a name the registry does not know."""
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise EvaluationError(f"unknown method {unknown[0]!r}; expected some of {', '.join(METHOD_NAMES)}")
