"""Corrections by the household's members: per user, per service, counted evidence.

A correction (context, the services the user wants, user) is an example for every service it
concerns: wanted there, or not. Per user and service a
:class:`~homecog.knowledge.evidence.ServiceLearner` counts them, learns which features matter
and the user's own thresholds, and answers over the shared tree: it proposes or rejects the
service where its evidence says so, and leaves the context to the shared tree where it has
none (or a tie). The shared tree is never changed by a correction, so another user's answers
stay as they were.

A user's layer is a pure function of their corrections in order (and of the shared tree, which
answers the prior): the store keeps only the corrections, in the experience log, and the layer
is made again from them on load.

>>> from homecog.home import load_home
>>> from homecog.home.codec import Space
>>> home = load_home("paper")
>>> space = Space(home)
>>> layers = UserLayers(home, space, shared=lambda p: frozenset(), version=lambda: 0)
>>> x = {"time": "19:00", "temperature": 24, "illumination": 200, "location": "sofa",
...      "posture": "sit", "behavior": "read", "window": "off", "curtain": "off",
...      "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off",
...      "lamp": "off", "ceiling_light": "off"}
>>> lamp = home.service_index("TurnOnLamp")
>>> layers.add("ann", space.point(x), frozenset({lamp}))
>>> layers.decide("ann", lamp, space.point({**x, "tv_living": "on"}), False).sign  # other devices
1
>>> layers.decide("kim", lamp, space.point(x), False) is None
True
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from homecog.home.codec import Point, Space
from homecog.home.model import Home
from homecog.home.recent import Recent, recent_names
from homecog.knowledge.additive import AtomLogistic
from homecog.knowledge.evidence import ServiceLearner
from homecog.knowledge.keys import Decision, learner_codes, sign_of
from homecog.knowledge.snapshots import KEEP_AFTER, LayerSnapshots
from homecog.knowledge.threshold import OnlineThreshold
from homecog.knowledge.user_calibration import UserCalibration

#: keys of at most this many atoms (features and the shared answer) ...
ORDER = 3
#: ... fewer where a home has so many features that there would be more keys than this
MAX_KEYS = 100
#: examples judged before a user's threshold is chosen from them (until then: the majority)
CALIBRATE = 20
#: the shares of wanted examples a user's threshold is chosen among
THRESHOLDS = (0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5)


@dataclass(frozen=True)
class Example:
    """One correction as the layer keeps it: the context, the services wanted, the services it
    speaks about (``None``: every one — a whole set; else only these, as an addition or a
    rejection of one service does) and how many examples' worth it counts."""

    codes: tuple[int, ...]
    readings: tuple[float | None, ...]
    want: frozenset[int]
    concerns: frozenset[int] | None = None
    weight: int = 1
    recent: Recent | None = None  # the recent past, where the correction came in a stream
    missing: frozenset[int] = frozenset()  # the features whose reading was missing

    @property
    def point(self) -> Point:
        """The example's context as a point."""
        return Point(self.codes, self.readings, self.recent, self.missing)

    def speaks_of(self, a: int) -> bool:
        """Whether the example says anything about service ``a``."""
        return self.concerns is None or a in self.concerns


class UserLayers:
    """Every user's corrections and what they learned, per service position.

    ``shared(point)`` gives the services the shared tree proposes at a point (the prior);
    ``version()`` changes whenever the shared tree does, and the learners are then made again;
    ``relevant(a)`` gives the context features that the shared tree says matter to service ``a``.
    """

    def __init__(
        self,
        home: Home,
        space: Space,
        *,
        shared: Callable[[Point], frozenset[int]],
        version: Callable[[], int],
        relevant: Callable[[int], frozenset[int]] = lambda a: frozenset(),
        order: int = ORDER,
    ) -> None:
        self.home = home
        atoms = space.n_features + 1
        while order > 1 and sum(math.comb(atoms - (r > 2), r - (r > 2)) for r in range(order + 1)) > MAX_KEYS:
            order -= 1
        self.order = order
        self._shared = shared
        self._version = version
        self._relevant = relevant
        self.n_features = space.n_features
        self.recent_names = recent_names(home)
        # and: was the service wanted just before, which services were, when its device switched
        self.n_recent = len(self.recent_names) + 3
        self._device_of = [s.sets[0][0] if s.sets else None for s in home.services]
        self._names = home.service_names
        # per numeric feature, its bins' edges: a threshold learned from readings joins them
        self._numeric = {
            j: tuple(sorted({x for b in f.bins for x in b if not math.isinf(x)}))
            for j, f in enumerate(home.features)
            if f.bins
        }
        # per service, the (dimension, code) it sets: it changes something where one differs
        self._clock = frozenset(j for j, f in enumerate(home.features) if f.kind == "clock")
        index = space.index
        self._effects = [tuple((index[d], int(on)) for d, on in s.sets) for s in home.services]
        # per service of several devices (a scene): the services whose effects it does too
        self._covers = {
            a: frozenset(
                b for b, other in enumerate(self._effects) if b != a and other and set(other) <= set(effects)
            )
            for a, effects in enumerate(self._effects)
            if len(effects) > 1
        }
        self._examples: dict[str, list[Example]] = {}
        self._learners: dict[str, dict[int, ServiceLearner]] = {}
        self._made_at: dict[str, int] = {}
        # per user: the share of wanted examples above which their answers propose
        self._threshold: dict[str, OnlineThreshold] = {}
        # per user who corrected in a stream: the additive model over every service's atoms
        self._additive: dict[str, AtomLogistic] = {}
        # the latest answers: (user, point, the user's examples then, shared version), the
        # shared answer and the user's answers there
        self._last: tuple[tuple[Any, ...], frozenset[int], dict[int, Decision]] | None = None
        # per user, the probability that a service is wanted given the layer's score
        self.calibration = UserCalibration()
        # where the users' learned layers are kept between processes (set by the store)
        self.snapshots: LayerSnapshots | None = None
        # per user, the lock their layer is learned and read under (:meth:`lock`)
        self._locks: dict[str | None, threading.RLock] = {}

    def __getstate__(self) -> dict[str, Any]:
        """The layers as pickle keeps them: without their locks (made again as they are asked)."""
        return {**self.__dict__, "_locks": {}}

    def lock(self, user: str | None) -> threading.RLock:
        """The lock of a user's layer: learning it (the first answer's, a correction's) holds
        it, and so may an answer that reads it; other users' answers never wait on it."""
        lock = self._locks.get(user)
        return lock if lock is not None else self._locks.setdefault(user, threading.RLock())

    def ready(self, user: str | None) -> bool:
        """Whether a user's layer is learned for the shared tree as it is (else the next answer
        learns it from every correction first)."""
        return user not in self._examples or self._made_at.get(user) == self._version()

    @property
    def users(self) -> list[str]:
        return sorted(self._examples)

    def changes(self, a: int, codes: tuple[int, ...]) -> bool:
        """Whether service ``a`` would change anything at these codes (interactions always do)."""
        effects = self._effects[a]
        return not effects or any(codes[j] != code for j, code in effects)

    def covered(self, want: frozenset[int]) -> frozenset[int]:
        """The services a wanted scene does the work of: a correction wanting the scene says
        nothing of them (their devices are switched, as part of the scene)."""
        out: frozenset[int] = frozenset()
        for a in want:
            out |= self._covers.get(a, frozenset())
        return out.difference(a for a in want if a in self._covers)

    def examples(self, user: str) -> list[Example]:
        return self._examples.get(user, [])

    def set_examples(self, user: str, examples: list[Example]) -> None:
        """Replace a user's corrections (the store, loading them from the log)."""
        with self.lock(user):
            self._replace(user, examples)

    def _replace(self, user: str, examples: list[Example]) -> None:
        for made in (self._learners, self._made_at, self._threshold, self._additive):
            made.pop(user, None)
        self.calibration.forget(user)
        if examples:
            self._examples[user] = list(examples)
        else:
            self._examples.pop(user, None)

    def n_examples(self, user: str) -> int:
        return len(self._examples.get(user, []))

    def items(self) -> Iterator[tuple[str, list[Example]]]:
        return iter(sorted(self._examples.items()))

    def add(
        self,
        user: str,
        p: Point,
        want: frozenset[int],
        *,
        concerns: frozenset[int] | None = None,
        weight: int = 1,
    ) -> None:
        """A user's correction: the services ``want`` wanted at ``p`` (of ``concerns``, or of
        every service), counted ``weight`` times; counted at once."""
        self.extend(
            user, [Example(p.codes, p.readings, frozenset(want), concerns, weight, p.recent, p.missing)]
        )

    def extend(self, user: str, more: list[Example]) -> None:
        """A user's corrections that come after those the layer has (another process's): each
        learned at once, as if it had been made here."""
        with self.lock(user):
            examples = self._examples.setdefault(user, [])
            for example in more:
                examples.append(example)
                if self._made_at.get(user) == self._version():
                    self._learn(user, example, len(examples))
                # else: made again from every example at the next answer

    def _learn(self, user: str, example: Example, ident: int) -> None:
        learners = self._learners.setdefault(user, {})
        threshold = self._threshold.get(user)
        if threshold is None:  # the user's: of THRESHOLDS, the best F1 on their corrections so far
            threshold = self._threshold[user] = OnlineThreshold(THRESHOLDS, calibrate=CALIBRATE)
        codes, readings, recent = learner_codes(example.point), example.readings, example.recent
        # the answers just given at this point (a correction follows its cognition) are the
        # answers before this example; else they are asked again
        last = self._last
        if last is not None and last[0] == (user, codes, readings, recent, ident - 1, self._version()):
            shared, answers = last[1], last[2]
        else:
            shared, answers = self._shared(example.point), {}
        covered = self.covered(example.want)
        scores, wanted_ones = [], []  # the scores just before, and what the user wanted
        for a in range(len(self._effects)):
            if not self.changes(a, codes) or not example.speaks_of(a) or a in covered:
                continue
            learner = learners.get(a)
            if learner is None:
                learner = learners[a] = ServiceLearner(
                    self.n_features + self.n_recent + 1,
                    self._numeric,
                    self.order,
                    self._relevant(a),
                    n_recent=self.n_recent,
                    clock=self._clock,
                )
            wanted = a in example.want
            atoms = self.recent_atoms(a, recent)
            before = answers.get(a) or self._answer(user, a, learner, example.point, a in shared, atoms)
            if before.sign and example.concerns is None:  # a whole set: a fair sample of answers
                threshold.judge(before.share, wanted)
            scores.append(before.share if before.sign else float(a in shared))
            wanted_ones.append(wanted)
            learner.add(
                readings,
                codes,
                wanted,
                shared=a in shared,
                ident=ident,
                weight=example.weight,
                partial=example.concerns is not None,
                recent=atoms,
            )
            if recent is not None and example.concerns is None:  # a whole example of a stream
                model = self._additive.setdefault(user, AtomLogistic())
                model.learn_one(a, learner.atoms(readings, codes, a in shared, atoms), wanted, example.weight)
        self.calibration.learn(user, np.array(scores), np.array(wanted_ones, dtype=bool))
        self._last = None

    def _answer(
        self,
        user: str,
        a: int,
        learner: ServiceLearner,
        p: Point,
        shared: bool,
        atoms: tuple[str, ...],
        threshold: float = 0.5,
    ) -> Decision:
        """A learner's answer at ``p``; in a stream, its probability averaged with the user's
        additive model's (:mod:`homecog.knowledge.additive`), the key that explains it kept."""
        codes = learner_codes(p)
        decision = learner.decide(p.readings, codes, shared=shared, threshold=threshold, recent=atoms)
        model = self._additive.get(user)
        if model is None or not learner.streaming:
            return decision
        additive = model.predict_one(a, learner.atoms(p.readings, codes, shared, atoms))
        share = (decision.share + additive) / 2
        return replace(decision, share=share, sign=sign_of(share, threshold, decision.sign > 0))

    def recent_atoms(self, a: int, recent: Recent | None) -> tuple[str, ...]:
        """Service ``a``'s atoms of the recent past: its features' values, whether ``a`` was
        wanted at the previous moment, which services were, and how long ago the device it sets
        switched (``()``: unknown, as without a stream)."""
        if recent is None:
            return ()
        device = self._device_of[a]
        switched = "unknown" if device is None else recent.since_switched(device)
        if recent.previous is None:
            return (*(v for _, v in recent.values), "unknown", "unknown", switched)
        before = ";".join(sorted(recent.previous)) or "none"
        return (*(v for _, v in recent.values), str(self._names[a] in recent.previous), before, switched)

    def learners(self, user: str) -> dict[int, ServiceLearner]:
        """A user's learners per service, made again if the shared tree changed since: from
        the user's snapshot where one holds their first corrections, else from the first."""
        version = self._version()
        if self._made_at.get(user) != version:
            with self.lock(user):
                if self._made_at.get(user) != version:
                    self._make(user)
                    self._made_at[user] = version
        return self._learners.get(user, {})

    def _make(self, user: str) -> None:
        examples = self._examples.get(user, [])
        kept = None if self.snapshots is None else self.snapshots.load(user, examples)
        start, learned = kept if kept is not None else (0, ({}, None, None, None))
        self._learners[user], additive, threshold, calibrator = learned
        self.calibration.put(user, calibrator)
        for made, value in ((self._additive, additive), (self._threshold, threshold)):
            made.pop(user, None)  # learned again too, never twice
            if value is not None:
                made[user] = value
        began = time.perf_counter()
        for i, example in enumerate(examples[start:], start=start + 1):
            self._learn(user, example, i)
        if time.perf_counter() - began >= KEEP_AFTER:
            self.keep(user)

    def keep(self, user: str) -> None:
        """Keep what the user's layer learned (a snapshot), where the layers have a place for it."""
        if self.snapshots is not None and user in self._learners:
            mine = (self._additive.get(user), self._threshold.get(user), self.calibration.get(user))
            learned = (self._learners[user], *mine)
            self.snapshots.save(user, self._examples.get(user, []), learned)

    def _value(self, user: str) -> float:
        threshold = self._threshold.get(user)
        return 0.5 if threshold is None else threshold.value

    def decide(self, user: str | None, a: int, p: Point, shared: bool) -> Decision | None:
        """The user's evidence about service ``a`` at ``p``; None without any."""
        if user is None or user not in self._examples:
            return None
        learner = self.learners(user).get(a)
        if learner is None or not self.changes(a, p.codes):
            return None
        return self._answer(user, a, learner, p, shared, self.recent_atoms(a, p.recent), self._value(user))

    def decisions(self, user: str, p: Point, shared: frozenset[int]) -> Iterator[tuple[int, Decision]]:
        """Every service the user's evidence decides at ``p`` (propose or reject)."""
        learners = self.learners(user)
        threshold = self._value(user)
        answers = {}
        for a, learner in learners.items():
            if self.changes(a, p.codes):
                answers[a] = self._answer(
                    user, a, learner, p, a in shared, self.recent_atoms(a, p.recent), threshold
                )
        self._last = (self._key(user, p), shared, answers)
        for a, d in answers.items():
            if d.sign:
                yield a, d

    def _key(self, user: str, p: Point) -> tuple[Any, ...]:
        """What the latest answers were given for: the user, the point, their examples, the tree."""
        return (user, learner_codes(p), p.readings, p.recent, len(self._examples[user]), self._version())

    def shares(self, user: str | None, p: Point, shared: frozenset[int]) -> dict[int, float]:
        """Per service the user's evidence decides at ``p``, its share of wanted examples (the
        latest answers' where they were given at this point)."""
        if user is None or user not in self._examples:
            return {}
        if self._last is None or self._last[0] != self._key(user, p):
            for _ in self.decisions(user, p, shared):
                pass
        assert self._last is not None
        return {a: d.share for a, d in self._last[2].items() if d.sign}
