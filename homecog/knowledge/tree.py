"""The knowledge tree as plain data: its nodes and their clusters, the boxes' indexes, the
precedence of services and its counters, and the lookup tables derived from them.

Nothing here learns or searches: :mod:`homecog.knowledge.update` changes clusters (the paper's
Algorithm 2), :mod:`homecog.knowledge.lookup` and :mod:`homecog.knowledge.search` answer
(Algorithm 3), and :class:`~homecog.knowledge.ihdr.IHDRTree` puts them together as a learner.

>>> from homecog.home import load_home
>>> tree = Tree.empty(load_home("paper"))
>>> [c.name for c in tree.root.children][:3], len(tree.services), tree.idle.name
(['switch_on', 'interaction', 'switch_off'], 20, 'Idle')
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from homecog.home.codec import Space
from homecog.home.model import Home
from homecog.knowledge.box_index import BoxIndex
from homecog.knowledge.group_index import GroupIndex
from homecog.knowledge.model import IDLE, Cluster, Condition, Node

MODES = ("multi", "paper")
#: Largest table (discrete points × service nodes) for which multi mode keeps a dense
#: table of the responding cluster of every node at every point (int16: 256 MB at most).
DENSE_LIMIT = 2**27


@dataclass(eq=False)
class Tree:
    """root → service categories → services (and Idle, "nothing to do"), each node with its
    clusters; in multi mode a box index per service node. ``precedence[a, b]``: how often ``a``
    came before ``b`` in a learned sequence. ``version`` moves whenever the shared clusters do
    (the users' layers, which take them as prior, follow it)."""

    home: Home
    mode: str
    space: Space
    root: Node
    categories: dict[str, Node]
    services: list[Node]
    idle: Node
    index: dict[int, BoxIndex]
    precedence: np.ndarray
    next_id: int
    seq: int = 0
    n_samples: int = 0
    version: int = 0
    strides: tuple[int, ...] = ()  # per dimension, the step of its code among all points
    dense_ok: bool = False  # whether the dense table of every point's answer fits
    # derived, made on demand and dropped when the clusters change (:meth:`changed`)
    dense: np.ndarray | None = None  # multi: the responding cluster of each node at each point
    gindex: GroupIndex | bool | None = None  # large homes: :mod:`homecog.knowledge.group_index`
    before: list[set[int]] | None = None  # the services that must precede each service
    label_table: list[list[str]] | None = None  # each code's text in explanations
    described: dict[tuple[Any, ...], dict[str, str]] = field(default_factory=dict)

    @classmethod
    def empty(cls, home: Home, mode: str = "multi") -> Tree:
        """The tree of ``home`` before it learns anything."""
        if mode not in MODES:
            raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
        ids = iter(range(1 << 62))
        root = Node(id=next(ids), name="root", kind="root", parent=None)
        categories: dict[str, Node] = {}

        def node(name: str, category: str, service: int) -> Node:
            if category not in categories:
                categories[category] = Node(id=next(ids), name=category, kind="category", parent=root)
                root.children.append(categories[category])
            parent = categories[category]
            made = Node(id=next(ids), name=name, kind="service", parent=parent, service=service)
            parent.children.append(made)
            return made

        services = [node(s.name, s.category, i) for i, s in enumerate(home.services)]
        idle = node(IDLE, IDLE.lower(), len(home.services))
        n = len(home.services)
        space = Space(home)
        sizes = [len(d.values) for d in space.dims]
        return cls(
            home=home,
            mode=mode,
            space=space,
            root=root,
            categories=categories,
            services=services,
            idle=idle,
            index={s.id: BoxIndex() for s in [*services, idle]},
            precedence=np.zeros((n, n), dtype=np.int64),
            next_id=next(ids),
            strides=tuple(math.prod(sizes[j + 1 :]) for j in range(len(sizes))),
            dense_ok=mode == "multi" and math.prod(sizes) * (n + 1) <= DENSE_LIMIT,
        )

    # -- shape --------------------------------------------------------------------------------
    def all_services(self) -> list[Node]:
        """The service nodes in service order, Idle last."""
        return [*self.services, self.idle]

    def nodes(self) -> Iterator[Node]:
        return self.root.iter_dfs()

    def shared_clusters(self) -> Iterator[tuple[Node, Cluster]]:
        for node in self.root.iter_dfs():
            for cluster in node.clusters:
                yield node, cluster

    # -- change -------------------------------------------------------------------------------
    def new_cluster(self, conditions: dict[int, Condition], **kw: Any) -> Cluster:
        """A cluster with the next id and sequence number."""
        cluster = Cluster(id=self.next_id, conditions=conditions, seq=self.seq, **kw)
        self.next_id += 1
        self.seq += 1
        return cluster

    def changed(self) -> None:
        """The shared clusters changed: drop the tables derived from them."""
        self.dense = self.gindex = None
        self.version += 1

    def current_version(self) -> int:
        return self.version

    def without_caches(self) -> dict[str, Any]:
        """The fields to pickle: the derived tables left out (made again on demand)."""
        state = dict(self.__dict__)
        state["dense"] = state["gindex"] = state["before"] = None
        return state

    def __getstate__(self) -> dict[str, Any]:
        return self.without_caches()
