"""The IHDR knowledge tree (the paper's §3.2, Algorithms 2 and 3).

root → service categories → services. Each node keeps clusters; a cluster keeps, per
dimension of the input space (context features, then devices), "unrelated" or a
condition: a set of values, or a numeric interval (mean ± range, Table 6). A context
reaches a service node when a cluster of it and of its category responds; the services
reached are ordered by priority (their mean position in the learned sequences).

Two modes:

- ``paper``: one cluster per node, updated exactly as Algorithm 2 (a sample that marks a
  dimension unrelated makes it unrelated for good; discrete values collect in a list;
  numeric readings update mean and range) and searched as Algorithm 3.
- ``multi`` (default): a service node keeps many clusters, each a box of values that the
  samples showed sufficient; a new sample joins a box that covers it, or merges with a box
  that differs from it in one dimension, or starts a box. Numeric dimensions are kept as
  sets of bins.

Corrections go into a per-user layer (:mod:`homecog.knowledge.corrections`) that adds or
rejects a service where the user's evidence says so, over the shared answer, so one user's
corrections never change another's answers.

The tree itself is plain data (:class:`~homecog.knowledge.tree.Tree`); learning is in
:mod:`homecog.knowledge.update` and :mod:`homecog.knowledge.batch`, answering in
:mod:`homecog.knowledge.lookup` and :mod:`homecog.knowledge.search`. This class puts them
together with the users' layers as one learner.

The learner speaks river's API:

>>> from homecog.home import load_home
>>> tree = IHDRTree(load_home("paper"))
>>> x = {"time": "19:00", "temperature": 30, "illumination": 200, "location": "sofa",
...      "posture": "sit", "behavior": "watch_tv", "window": "on", "curtain": "on",
...      "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off",
...      "lamp": "off", "ceiling_light": "off"}
>>> tree.predict_one(x)
[]
>>> tree.learn_one(x, ["TurnOnTVL", "SendDrinks"],
...                relevant={"TurnOnTVL": {"behavior", "location", "tv_living"},
...                          "SendDrinks": {"behavior"}})
>>> tree.predict_one(x)
['TurnOnTVL', 'SendDrinks']
>>> tree.predict_one({**x, "location": "bed"})   # the living-room TV matters on the sofa only
['SendDrinks']
>>> tree.predict_one({**x, "behavior": "read"})   # both were learned for watching TV
[]
"""

from __future__ import annotations

import threading
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from homecog.errors import ContextError
from homecog.home.codec import Point, Space
from homecog.home.model import Home
from homecog.knowledge import lookup, search
from homecog.knowledge.batch import learn_sample_set
from homecog.knowledge.correction import Correction
from homecog.knowledge.corrections import Example, UserLayers
from homecog.knowledge.model import IDLE, Cluster, Cognition, Node
from homecog.knowledge.state import NodeState, TreeState, signature
from homecog.knowledge.tree import Tree
from homecog.knowledge.update import SampleRow, learn_row


class IHDRTree:
    """The knowledge tree of a home, with river's learner API.

    Parameters
    ----------
    home
        The home whose services the tree learns.
    mode
        ``"multi"`` (several clusters per service node) or ``"paper"`` (one cluster per
        node, Algorithms 2 and 3 as published).
    """

    def __init__(self, home: Home, mode: str = "multi") -> None:
        self.data = Tree.empty(home, mode)
        self._layers = UserLayers(
            home,
            self.data.space,
            shared=self._shared_services,
            version=self.data.current_version,
            relevant=self._relevant_features,
        )

    @property
    def home(self) -> Home:
        return self.data.home

    @property
    def mode(self) -> str:
        return self.data.mode

    @property
    def root(self) -> Node:
        return self.data.root

    @property
    def space(self) -> Space:
        return self.data.space

    @property
    def n_samples(self) -> int:
        """Samples the tree learned (a build's, single ones)."""
        return self.data.n_samples

    @property
    def n_experiences(self) -> int:
        """Experiences the tree learned: its samples and every user's corrections."""
        return self.data.n_samples + sum(len(examples) for _, examples in self._layers.items())

    @property
    def users(self) -> list[str]:
        return self._layers.users

    @property
    def layers(self) -> UserLayers:
        """Every user's corrections and what they learned."""
        return self._layers

    def clone(self) -> IHDRTree:
        """A new, untrained tree with the same parameters."""
        return IHDRTree(self.home, mode=self.mode)

    def __repr__(self) -> str:
        return f"IHDRTree(home={self.home.name!r}, mode={self.mode!r})"

    def user_lock(self, user: str | None) -> threading.RLock:
        """The lock of a user's layer (:meth:`UserLayers.lock`)."""
        return self._layers.lock(user)

    def ready(self, user: str | None) -> bool:
        """Whether the user's next answer is quick: their layer is learned."""
        return self._layers.ready(user)

    def prepare(self, user: str | None) -> None:
        """Learn a user's layer now, under the user's lock alone, where it is not learned."""
        if user is not None and not self._layers.ready(user):
            self._layers.learners(user)

    def n_clusters(self, user: str | None = None) -> int:
        """Clusters in the shared tree (or, with ``user``, the corrections in that user's layer)."""
        if user is not None:
            return self._layers.n_examples(user)
        return sum(len(n.clusters) for n in self.data.nodes())

    # -- answers ------------------------------------------------------------------------------
    def explain_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> Cognition:
        """Services for a context, ordered by priority, with why (Algorithm 3); a scene says
        which services it does the work of."""
        p = self.point(x)
        cognition = search.explain(self.data, self._layers, p, user)
        probabilities = self.probabilities_one(p, user)
        cognition.probabilities = {s: probabilities[s] for s in cognition.services if s in probabilities}
        return cognition

    def probabilities_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> dict[str, float]:
        """Per service that would change something in context ``x``: the probability that the
        user wants it now, their layer's score calibrated on their own history
        (:mod:`homecog.knowledge.user_calibration`)."""
        scores = self.scores_one(x, user)
        p = self._layers.calibration.predict(
            user, np.fromiter(scores.values(), dtype=float, count=len(scores))
        )
        return dict(zip(scores, np.round(p, 4).tolist(), strict=True))

    def predict_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> list[str]:
        """The services the user needs in context ``x``, in priority order."""
        return [node.name for node, _ in search.search(self.data, self._layers, self.point(x), user)[0]]

    def scores_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> dict[str, float]:
        """Per service that would change something in context ``x``: the user's evidence's
        share of wanted examples where it decides, else 1 where the shared tree proposes the
        service and 0 where not (what a calibrator makes probabilities of)."""
        p = self.point(x)
        shared = self._shared_services(p)
        decided = self._layers.shares(user, p, shared)
        names = self.home.service_names
        changes = self._layers.changes
        return {
            names[a]: decided.get(a, float(a in shared)) for a in range(len(names)) if changes(a, p.codes)
        }

    def describe(self, cluster: Cluster) -> dict[str, str]:
        """A cluster's conditions as text, per related dimension."""
        return search.describe(self.data, cluster)

    def _shared_services(self, p: Point) -> frozenset[int]:
        """The services the shared tree proposes at ``p`` (what a user's layer takes as prior)."""
        return search.shared_services(self.data, self._layers, p)

    def _relevant_features(self, a: int) -> frozenset[int]:
        return lookup.relevant_features(self.data, a)

    # -- inputs ------------------------------------------------------------------------------
    def point(self, x: Mapping[str, object] | Point) -> Point:
        return x if isinstance(x, Point) else self.space.point(x)

    def _service_positions(self, names: Sequence[str]) -> list[int]:
        known = {s.name: i for i, s in enumerate(self.home.services)}
        out = []
        for n in names:
            if n not in known:
                raise ContextError(f"unknown service {n!r}; expected some of {', '.join(known)}")
            out.append(known[n])
        return out

    def _mask(self, names: object) -> int:
        if names is None:
            return (1 << len(self.space)) - 1
        if isinstance(names, int):
            return names
        mask = 0
        for name in names:  # type: ignore[attr-defined]
            if name not in self.space.index:
                raise ContextError(f"unknown feature or device {name!r}")
            mask |= 1 << self.space.index[name]
        return mask

    # -- learning ----------------------------------------------------------------------------
    def learn_one(
        self, x: Mapping[str, object] | Point, y: Sequence[str], relevant: Mapping[str, object] | None = None
    ) -> None:
        """Learn one sample: the ordered services ``y`` in context ``x``.

        ``relevant`` gives, per service, the dimensions that matter to it (names or a bit
        mask); a service without an entry has every dimension related. A sample with no
        service teaches that nothing is needed in ``x``.
        """
        p = self.point(x)
        services = self._service_positions(y)
        relevant = relevant or {}
        rows = [
            (a, self._mask(relevant.get(self.home.services[a].name)), pos) for pos, a in enumerate(services)
        ]
        if not rows:
            rows = [(len(self.home.services), self._mask(relevant.get(IDLE)), 0)]
        for a, mask, pos in rows:
            learn_row(self.data, a, SampleRow(mask, p.codes, p.readings, 1, float(pos)))
        for i, a in enumerate(services):
            for b in services[i + 1 :]:
                self.data.precedence[a, b] += 1
                self.data.before = None
        self.data.n_samples += 1

    def learn_many(self, samples: Any) -> None:
        """Learn a :class:`~homecog.knowledge.samples.SampleSet` at once.

        The same as ``learn_one`` for each sample in order, but each distinct cluster is
        learned once with its count, which is what makes building from 663,552 samples quick. A
        group's samples over its classes of contexts are learned as boxes of the classes' values
        (multi), or first expanded to the home's contexts (paper, whose clusters keep readings).
        """
        learn_sample_set(self.data, samples)
        self.data.n_samples += len(samples.codes)

    def correct_one(
        self,
        x: Mapping[str, object] | Point,
        want: Sequence[str],
        user: str = "default",
        *,
        concerns: Sequence[str] | None = None,
        weight: int = 1,
    ) -> tuple[list[str], list[str]]:
        """A user's correction: the services they want in ``x``. Returns (added, rejected).

        ``want`` is the whole set wanted there, or, with ``concerns``, which of those services
        are (an addition: ``want=[S], concerns=[S]``; a rejection: ``want=[], concerns=[S]``):
        the others keep what they had. ``weight``: how many corrections' worth it counts. It
        takes effect for that user's next cognition at once, as evidence for every service it
        concerns in the user's layer (:mod:`homecog.knowledge.corrections`); the shared
        experience is not changed, so other users' answers stay as they were. The same as
        :meth:`judge` and then :meth:`apply` of a :class:`Correction`.
        """
        about = None if concerns is None else tuple(concerns)
        c = Correction(user, self.point(x), tuple(want), about, weight=weight)
        added, rejected = self.judge(c)
        self.apply(c)
        return list(added), list(rejected)

    def judge(self, c: Correction) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """What correction ``c`` changes in its user's answer at its point: (added, rejected).
        Changes nothing; :class:`ContextError` for an unknown service, or a scene named with a
        service it does the work of."""
        wanted = self._service_positions(c.want)
        about = None if c.concerns is None else frozenset(self._service_positions(c.concerns))
        both = self._layers.covered(frozenset(wanted)).intersection(wanted)
        if both:
            names = self.home.service_names
            scene = next(a for a in wanted if both & self._layers.covered(frozenset({a})))
            raise ContextError(
                f"{names[scene]} does the work of {names[min(both)]}: a correction names the scene "
                "or its device's own service, not both"
            )
        predicted = self._service_positions(self.predict_one(c.point, c.user))
        names = self.home.service_names
        added = tuple(names[a] for a in wanted if a not in predicted)
        rejected = tuple(names[a] for a in predicted if a not in wanted and (about is None or a in about))
        return added, rejected

    def apply(self, c: Correction) -> None:
        """Learn correction ``c`` (judged already: its names are the home's) into its user's layer."""
        wanted = frozenset(self._service_positions(c.want))
        about = None if c.concerns is None else frozenset(self._service_positions(c.concerns))
        self._layers.add(c.user, c.point, wanted, concerns=about, weight=c.weight)

    # -- persistence (the store maps the state to rows and back) ------------------------------
    def to_state(self) -> TreeState:
        """Everything the tree is, as plain data: nodes, shared clusters, user layers, counters."""
        return TreeState(
            mode=self.mode,
            nodes=[
                NodeState(
                    n.id,
                    n.parent.id if n.parent else None,
                    n.name,
                    n.kind,
                    n.service,
                    n.count,
                    n.position_sum,
                )
                for n in self.root.iter_dfs()
            ],
            shared=[(node.id, c) for node, c in self.shared_clusters()],
            users=dict(self._layers.items()),
            precedence=self.data.precedence.tolist(),
            next_id=self.data.next_id,
            seq=self.data.seq,
            n_samples=self.n_samples,
        )

    @classmethod
    def from_state(cls, home: Home, state: TreeState) -> IHDRTree:
        """The tree a state describes; ValueError when its nodes are not this home's."""
        tree = cls(home, mode=state.mode)
        nodes = {n.id: n for n in tree.root.iter_dfs()}
        for row in state.nodes:
            node = nodes.get(row.id)
            if node is None or node.name != row.name:
                raise ValueError(f"node {row.id} ({row.name}) is not in the tree of home {home.name!r}")
            node.count, node.position_sum = row.count, row.position_sum
        for node_id, cluster in state.shared:
            node = nodes[node_id]
            node.clusters.append(cluster)
            if tree.mode == "multi" and node.id in tree.data.index:
                tree.data.index[node.id].add(cluster)
        for user, examples in state.users.items():
            tree.layers.set_examples(user, examples)
        data = tree.data
        if state.precedence:
            data.precedence = np.array(state.precedence, dtype=np.int64)
        data.next_id = max(data.next_id, state.next_id)
        data.seq = max(data.seq, state.seq)
        data.n_samples = state.n_samples
        return tree

    def user_examples(self, user: str) -> list[Example]:
        """A user's corrections, in order, as their layer keeps them."""
        return self._layers.examples(user)

    def set_user_examples(self, user: str, examples: list[Example]) -> None:
        """Replace a user's corrections (as the database holds them)."""
        self._layers.set_examples(user, examples)

    def extend_user_examples(self, user: str, more: list[Example]) -> None:
        """A user's corrections committed after those the tree holds (another process's),
        learned as they would have been here: the cost of those alone."""
        self._layers.extend(user, more)

    def service_node(self, a: int) -> Node:
        """The node of service position ``a``."""
        return self.data.services[a]

    def shared_clusters(self) -> Iterator[tuple[Node, Cluster]]:
        return self.data.shared_clusters()

    def signature(self) -> tuple[Any, ...]:
        """Everything the tree answers from, for comparing two trees (:func:`state.signature`)."""
        return signature(self.to_state())
