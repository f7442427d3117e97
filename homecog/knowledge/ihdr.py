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

Corrections go into a per-user layer of clusters that add (+) or reject (−) a
service where they match; the user's most specific matching cluster overrides the shared
tree, so one user's corrections never change another's answers.

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

import copy
import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from homecog.errors import ContextError
from homecog.home.codec import Point, Space
from homecog.home.model import Home
from homecog.knowledge.batch import learn_sample_set
from homecog.knowledge.box_index import BoxIndex
from homecog.knowledge.corrections import Example, UserLayers
from homecog.knowledge.group_index import GroupIndex
from homecog.knowledge.model import (
    IDLE,
    Cluster,
    Condition,
    Node,
)
from homecog.knowledge.search import TreeSearch
from homecog.knowledge.state import NodeState, TreeState, signature
from homecog.knowledge.update import ClusterUpdates, SampleRow

MODES = ("multi", "paper")
#: Largest table (discrete points × service nodes) for which multi mode keeps a dense
#: table of the responding cluster of every node at every point (int16: 256 MB at most).
DENSE_LIMIT = 2**27


class IHDRTree(ClusterUpdates, TreeSearch):
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
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        self.home = home
        self.mode = mode
        self._space = Space(home)
        self._next_id = 0
        self._seq = 0
        self.root = self._node("root", "root", None)
        self._categories: dict[str, Node] = {}
        self._services: list[Node] = []
        for i, service in enumerate(home.services):
            self._services.append(self._node(service.name, "service", self._category(service.category), i))
        self._idle = self._node(IDLE, "service", self._category(IDLE.lower()), len(home.services))
        self._index: dict[int, BoxIndex] = {n.id: BoxIndex() for n in self._all_services()}
        self._shared_version = 0  # changes with the shared clusters; the users' layers follow it
        self._layers = UserLayers(
            home,
            self._space,
            shared=self._shared_services,
            version=self._shared_state_version,
            relevant=self._relevant_features,
        )
        # _precedence[a, b]: how often a came before b in a learned sequence
        self._precedence = np.zeros((len(home.services), len(home.services)), dtype=np.int64)
        # multi mode: _dense[point, a] is the index in node a's clusters of the cluster that
        # responds at that point (-1: none); built on demand, dropped when the tree changes
        self._dense: np.ndarray | None = None
        self._gindex: GroupIndex | bool | None = None  # large homes: see _group_index
        self._before: list[set[int]] | None = None  # services that must precede each service
        self._label_table: list[list[str]] | None = None  # see _labels
        self._described: dict[tuple[Any, ...], dict[str, str]] = {}  # see describe
        sizes = [len(d.values) for d in self._space.dims]
        self._radices = tuple(sizes)
        self._strides = tuple(math.prod(sizes[j + 1 :]) for j in range(len(sizes)))
        points = math.prod(sizes)
        self._dense_ok = mode == "multi" and points * (len(home.services) + 1) <= DENSE_LIMIT
        self.n_experiences = 0

    # -- structure ---------------------------------------------------------------------------
    def _node(self, name: str, kind: str, parent: Node | None, service: int = -1) -> Node:
        node = Node(id=self._next_id, name=name, kind=kind, parent=parent, service=service)
        self._next_id += 1
        if parent is not None:
            parent.children.append(node)
        return node

    def _category(self, name: str) -> Node:
        if name not in self._categories:
            self._categories[name] = self._node(name, "category", self.root)
        return self._categories[name]

    def _all_services(self) -> list[Node]:
        return [*self._services, self._idle]

    def _changed(self) -> None:
        """Drop what is derived from the shared clusters (lookup tables); rebuilt on demand."""
        self._dense = self._gindex = None
        self._shared_version += 1

    def _new_cluster(self, conditions: dict[int, Condition], **kw: Any) -> Cluster:
        cluster = Cluster(id=self._next_id, conditions=conditions, seq=self._seq, **kw)
        self._next_id += 1
        self._seq += 1
        return cluster

    @property
    def space(self) -> Space:
        return self._space

    @property
    def users(self) -> list[str]:
        return self._layers.users

    def clone(self) -> IHDRTree:
        """A new, untrained tree with the same parameters."""
        return IHDRTree(self.home, mode=self.mode)

    def __repr__(self) -> str:
        return f"IHDRTree(home={self.home.name!r}, mode={self.mode!r})"

    def n_clusters(self, user: str | None = None) -> int:
        """Clusters in the shared tree (or, with ``user``, the corrections in that user's layer)."""
        if user is not None:
            return self._layers.n_examples(user)
        return sum(len(n.clusters) for n in self.root.iter_dfs())

    # -- inputs ------------------------------------------------------------------------------
    def point(self, x: Mapping[str, object] | Point) -> Point:
        return x if isinstance(x, Point) else self._space.point(x)

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
            return (1 << len(self._space)) - 1
        if isinstance(names, int):
            return names
        mask = 0
        for name in names:  # type: ignore[attr-defined]
            if name not in self._space.index:
                raise ContextError(f"unknown feature or device {name!r}")
            mask |= 1 << self._space.index[name]
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
            self._learn_row(a, SampleRow(mask, p.codes, p.readings, 1, float(pos)))
        for i, a in enumerate(services):
            for b in services[i + 1 :]:
                self._precedence[a, b] += 1
                self._before = None
        self.n_experiences += 1

    def learn_many(self, samples: Any) -> None:
        """Learn a :class:`~homecog.knowledge.samples.SampleSet` at once.

        The same as ``learn_one`` for each sample in order, but each distinct cluster is
        learned once with its count, which is what makes building from 663,552 samples quick. A
        group's samples over its classes of contexts are learned as boxes of the classes' values
        (multi), or first expanded to the home's contexts (paper, whose clusters keep readings).
        """
        learn_sample_set(self, samples)
        self.n_experiences += len(samples.codes)

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
        experience is not changed, so other users' answers stay as they were.
        """
        p = self.point(x)
        wanted = self._service_positions(want)
        about = None if concerns is None else frozenset(self._service_positions(concerns))
        if about is not None and not about.issuperset(wanted):
            raise ContextError("a correction of some services wants only services it concerns")
        both = self._layers.covered(frozenset(wanted)).intersection(wanted)
        if both:
            names = self.home.service_names
            scene = next(a for a in wanted if both & self._layers.covered(frozenset({a})))
            raise ContextError(
                f"{names[scene]} does the work of {names[min(both)]}: a correction names the scene "
                "or its device's own service, not both"
            )
        predicted = self._service_positions(self.predict_one(p, user))
        added = [a for a in wanted if a not in predicted]
        rejected = [a for a in predicted if a not in wanted and (about is None or a in about)]
        self._layers.add(user, p, frozenset(wanted), concerns=about, weight=weight)
        self.n_experiences += 1
        names = self.home.services
        return [names[a].name for a in added], [names[a].name for a in rejected]

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
            precedence=self._precedence.tolist(),
            next_id=self._next_id,
            seq=self._seq,
            n_experiences=self.n_experiences,
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
            if tree.mode == "multi" and node.id in tree._index:
                tree._index[node.id].add(cluster)
        for user, examples in state.users.items():
            tree._layers.set_examples(user, examples)
        if state.precedence:
            tree._precedence = np.array(state.precedence, dtype=np.int64)
        tree._next_id = max(tree._next_id, state.next_id)
        tree._seq = max(tree._seq, state.seq)
        tree.n_experiences = state.n_experiences
        return tree

    def user_examples(self, user: str) -> list[Example]:
        """A user's corrections, in order, as their layer keeps them."""
        return self._layers.examples(user)

    def set_user_examples(self, user: str, examples: list[Example]) -> None:
        """Replace a user's corrections (the store, when another process corrected meanwhile)."""
        self._layers.set_examples(user, examples)

    def service_node(self, a: int) -> Node:
        """The node of service position ``a``."""
        return self._services[a]

    def shared_clusters(self) -> Iterator[tuple[Node, Cluster]]:
        for node in self.root.iter_dfs():
            for cluster in node.clusters:
                yield node, cluster

    def signature(self) -> tuple[Any, ...]:
        """Everything the tree answers from, for comparing two trees (:func:`state.signature`)."""
        return signature(self.to_state())

    def __getstate__(self) -> dict[str, Any]:
        state = copy.copy(self.__dict__)
        state["_dense"] = state["_gindex"] = None  # caches, rebuilt on demand
        state["_before"] = None
        return state
