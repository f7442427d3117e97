"""The tree as plain data, for the store: :meth:`IHDRTree.to_state` and
:meth:`IHDRTree.from_state` convert; :mod:`homecog.knowledge.store` maps it to rows and back.

>>> from homecog.home import load_home
>>> from homecog.knowledge.ihdr import IHDRTree
>>> tree = IHDRTree(load_home("paper"))
>>> state = tree.to_state()
>>> state.nodes[0].kind, len(state.shared)
('root', 0)
>>> IHDRTree.from_state(tree.home, state).signature() == tree.signature()
True
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from homecog.knowledge.corrections import Example
from homecog.knowledge.model import Cluster, Condition, Numeric


@dataclass(frozen=True)
class NodeState:
    """A node: its id, its parent's, its name and kind, its service position (−1: none), and
    the count and position sum of what it learned."""

    id: int
    parent: int | None
    name: str
    kind: str
    service: int
    count: int
    position_sum: float


COUNTERS = ("precedence", "next_id", "seq", "n_samples")
"""The fields of a :class:`TreeState` that :meth:`TreeState.counters` gives, stored as one JSON
object."""


@dataclass
class TreeState:
    """Everything a tree is: its mode, nodes, shared clusters (by node id, in order), every user's
    corrections (in order), the precedence of services and its counters."""

    mode: str
    nodes: list[NodeState]
    shared: list[tuple[int, Cluster]]
    users: dict[str, list[Example]] = field(default_factory=dict)
    precedence: list[list[int]] = field(default_factory=list)
    next_id: int = 0
    seq: int = 0
    n_samples: int = 0

    def counters(self) -> dict[str, Any]:
        """The precedence and counters as one JSON-ready mapping."""
        return {name: getattr(self, name) for name in COUNTERS}


def _condition(c: Condition) -> Any:
    return ("n", c.count, round(c.total, 6), c.low, c.high) if isinstance(c, Numeric) else tuple(sorted(c))


def _conditions(cluster: Cluster) -> tuple[Any, ...]:
    return tuple((j, _condition(c)) for j, c in sorted(cluster.conditions.items()))


def signature(state: TreeState) -> tuple[Any, ...]:
    """Everything a tree answers from — per node its name, counts and clusters (by id), per user
    the corrections in order — for comparing two trees; ids and seq numbers left out."""
    by_node: dict[int, list[Cluster]] = {}
    for node_id, cluster in state.shared:
        by_node.setdefault(node_id, []).append(cluster)
    shared = tuple(
        (
            n.name,
            n.count,
            round(n.position_sum, 6),
            tuple(
                (c.count, round(c.position_sum, 6), _conditions(c))
                for c in sorted(by_node.get(n.id, []), key=lambda c: c.id)
            ),
        )
        for n in state.nodes
    )
    users = tuple(
        (user, tuple((e.codes, e.readings, tuple(sorted(e.want))) for e in examples))
        for user, examples in sorted(state.users.items())
    )
    return shared, users
