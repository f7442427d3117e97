"""The knowledge tree's data model (the paper's §3.2, Table 6).

A :class:`Node` is the root, a service category or a service; it keeps :class:`Cluster` s. A
cluster keeps, per dimension of the input space (context features, then devices), a condition:
a set of values (codes), or a numeric interval kept as count, sum, min and max
(:class:`Numeric`: mean ± range, the paper's Formula 7). Dimensions without a condition are
unrelated to it. Cognition answers with a :class:`Cognition` and an :class:`Explanation` per
service.

>>> c = Cluster(id=7, conditions={0: frozenset({2}), 3: Numeric(count=2, total=50.0, low=24.0, high=26.0)})
>>> c.mask, c.conditions[3].mean, c.conditions[3].range
(9, 25.0, 1.0)
>>> bits(c.mask)
(0, 3)
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from homecog.home.codec import Point

IDLE = "Idle"  # the pseudo-service whose clusters say "nothing is needed here"


@dataclass
class Numeric:
    """A numeric condition kept as count, sum, min and max: mean ± range covers every reading."""

    count: int
    total: float
    low: float
    high: float

    @property
    def mean(self) -> float:
        return self.total / self.count

    @property
    def range(self) -> float:
        return max(self.high - self.mean, self.mean - self.low)

    def add(
        self,
        x: float,
        n: int = 1,
        total: float | None = None,
        low: float | None = None,
        high: float | None = None,
    ) -> None:
        self.count += n
        self.total += x * n if total is None else total
        self.low = min(self.low, x if low is None else low)
        self.high = max(self.high, x if high is None else high)

    def matches(self, x: float | None) -> bool:
        # Formula 7: T ∈ [ave − range, ave + range], with a hair of slack for rounding
        return x is not None and self.mean - self.range - 1e-9 <= x <= self.mean + self.range + 1e-9


Condition = frozenset[int] | Numeric


@dataclass(eq=False)  # a cluster is an identity: equal conditions do not make two clusters one
class Cluster:
    """A cluster of a node: conditions on the related dimensions (the others are unrelated)."""

    id: int
    conditions: dict[int, Condition]
    count: int = 0
    position_sum: float = 0.0
    user: str | None = None
    polarity: int = 1  # +1 performs the service where it matches; −1 (user layer) rejects it
    seed: tuple[int, ...] | None = None  # the context a user cluster was made from
    seq: int = 0  # order of creation, the tie-breaker between equally specific user clusters
    evidence: Any = None  # a user's answer (search): the Decision of their counted corrections

    @property
    def priority(self) -> float:
        return self.position_sum / self.count if self.count else 0.0

    def matches(self, p: Point) -> bool:
        for j, cond in self.conditions.items():
            if isinstance(cond, Numeric):
                if not cond.matches(p.readings[j]):
                    return False
            elif p.codes[j] not in cond:
                return False
        return True

    @property
    def mask(self) -> int:
        return sum(1 << j for j in self.conditions)


@dataclass
class Node:
    """A node of the tree: the root, a service category, or a service."""

    id: int
    name: str
    kind: str  # root, category or service
    parent: Node | None = None
    children: list[Node] = field(default_factory=list)
    clusters: list[Cluster] = field(default_factory=list)
    count: int = 0
    position_sum: float = 0.0
    service: int = -1  # the service's position in the home (-1: not a service node)

    @property
    def priority(self) -> float:
        return self.position_sum / self.count if self.count else 0.0

    def iter_dfs(self) -> Iterator[Node]:
        """This node and its descendants, depth first."""
        yield self
        for child in self.children:
            yield from child.iter_dfs()

    @property
    def height(self) -> int:
        return 1 + max((c.height for c in self.children), default=0)

    @property
    def n_nodes(self) -> int:
        return sum(1 for _ in self.iter_dfs())


@dataclass
class Explanation:
    """Why a service was predicted: the node, the cluster (its priority, the mean position of
    the service in its experiences, rounded to 3 decimals), the conditions it matched."""

    service: str
    category: str
    priority: float
    cluster: int
    user: str | None
    conditions: dict[str, str]
    evidence: dict[str, Any] | None = None  # a user's answer: which corrections, how many agreed

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class Cognition:
    """The answer for one context: ordered services, whether the context is unknown, why."""

    services: list[str]
    unknown: bool
    explanations: list[Explanation]
    probabilities: dict[str, float] = field(default_factory=dict)  # per service proposed

    def as_dict(self) -> dict[str, Any]:
        return {
            "services": self.services,
            "unknown": self.unknown,
            "explanations": [e.as_dict() for e in self.explanations],
            "probabilities": self.probabilities,
        }


def box_size(cluster: Cluster) -> int:
    """Points of a box: the product of its value sets."""
    return math.prod(len(c) for c in cluster.conditions.values())  # type: ignore[arg-type]


def bits(mask: int) -> tuple[int, ...]:
    """The positions of the set bits of a mask, lowest first.

    >>> bits(0b10110)
    (1, 2, 4)
    """
    out = []
    while mask:
        low = mask & -mask
        out.append(low.bit_length() - 1)
        mask ^= low
    return tuple(out)


def covers(box: Mapping[int, Condition], codes: Sequence[int]) -> bool:
    return all(codes[j] in c for j, c in box.items())  # type: ignore[operator]
