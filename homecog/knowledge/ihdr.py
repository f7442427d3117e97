"""The IHDR knowledge tree (SPEC §5; the paper's §3.2, Algorithms 2 and 3).

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

Corrections (SPEC §7) go into a per-user layer of clusters that add (+) or reject (−) a
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
import itertools
import math
import operator
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from homecog.errors import ContextError
from homecog.home.model import Home, format_clock, format_number
from homecog.knowledge.space import Point, Space

MODES = ("multi", "paper")
#: Largest table (discrete points × service nodes) for which multi mode keeps a dense
#: table of the responding cluster of every node at every point (int16: 256 MB at most).
DENSE_LIMIT = 2**27
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

    def as_dict(self) -> dict[str, Any]:
        return {
            "service": self.service,
            "category": self.category,
            "priority": self.priority,
            "cluster": self.cluster,
            "user": self.user,
            "conditions": self.conditions,
        }


@dataclass
class Cognition:
    """The answer for one context: ordered services, whether the context is unknown, why."""

    services: list[str]
    unknown: bool
    explanations: list[Explanation]

    def as_dict(self) -> dict[str, Any]:
        return {
            "services": self.services,
            "unknown": self.unknown,
            "explanations": [e.as_dict() for e in self.explanations],
        }


class _One:
    """codes -> (codes[j],): itemgetter returns a bare value for a single index."""

    def __init__(self, j: int | None) -> None:
        self.j = j

    def __call__(self, codes: Sequence[int]) -> tuple[int, ...]:
        return () if self.j is None else (codes[self.j],)


def _getter(dims: tuple[int, ...]) -> Any:
    """codes -> the tuple of codes at ``dims``."""
    if len(dims) >= 2:
        return operator.itemgetter(*dims)
    return _One(dims[0] if dims else None)


class _BoxIndex:
    """The clusters of a multi-mode node, grouped by related dimensions for fast lookup."""

    def __init__(self) -> None:
        self.by_mask: dict[int, tuple[Any, dict[tuple[int, ...], Cluster]]] = {}
        # (mask, j, the box's values on its other dimensions) -> boxes: merge partners at a glance
        self.partners: dict[tuple[Any, ...], dict[int, Cluster]] = {}
        self._keys: dict[int, list[tuple[Any, ...]]] = {}  # cluster id (unique in a node) -> partner keys

    @staticmethod
    def partner_keys(cluster: Cluster, mask: int | None = None) -> list[tuple[Any, ...]]:
        dims = _bits(cluster.mask if mask is None else mask)
        values = [cluster.conditions[d] for d in dims]
        mask = sum(1 << j for j in dims)
        return [(mask, j, (*values[:i], *values[i + 1 :])) for i, j in enumerate(dims)]

    def add(self, cluster: Cluster, keys: list[tuple[Any, ...]] | None = None) -> None:
        self.point_to(cluster, cluster.conditions)
        self.link(cluster, keys if keys is not None else self.partner_keys(cluster))

    def point_to(self, cluster: Cluster, conditions: dict[int, Condition], mask: int | None = None) -> None:
        """Make every point of the box ``conditions`` answer ``cluster``."""
        mask = cluster.mask if mask is None else mask
        entry = self.by_mask.get(mask)
        if entry is None:
            entry = self.by_mask[mask] = (_getter(_bits(mask)), {})
        table = entry[1]
        values = [conditions[j] for j in _bits(mask)]
        if all(len(v) == 1 for v in values):  # type: ignore[arg-type]
            table[tuple(next(iter(v)) for v in values)] = cluster  # type: ignore[call-overload]
            return
        for key in itertools.product(*values):  # type: ignore[arg-type]
            table[key] = cluster

    def link(self, cluster: Cluster, keys: list[tuple[Any, ...]]) -> None:
        """Register a box as a merge partner under its keys."""
        self._keys[cluster.id] = keys
        for key in keys:
            self.partners.setdefault(key, {})[cluster.id] = cluster

    def unlink(self, cluster: Cluster) -> None:
        """Withdraw a box from the merge partners (its points still answer it)."""
        for key in self._keys.pop(cluster.id):
            del self.partners[key][cluster.id]

    def partner(self, box: Cluster, keys: list[tuple[Any, ...]]) -> Cluster | None:
        """A box over the same dimensions equal to ``box`` on all but one (their union is a box).

        ``keys`` are ``partner_keys(box)``."""
        for key in keys:
            j = key[1]
            found = [
                c
                for c in self.partners.get(key, {}).values()
                if c is not box and c.conditions[j] != box.conditions[j]
            ]
            if found:
                return min(found, key=lambda c: c.id)
        return None

    def lookup(self, codes: Sequence[int]) -> Cluster | None:
        best = None
        for get, table in self.by_mask.values():
            hit = table.get(get(codes))
            if hit is not None and (best is None or hit.id < best.id):
                best = hit
        return best

    def covering(self, mask: int, key: tuple[int, ...]) -> Cluster | None:
        entry = self.by_mask.get(mask)
        return None if entry is None else entry[1].get(key)


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
        self._index: dict[int, _BoxIndex] = {n.id: _BoxIndex() for n in self._all_services()}
        self._users: dict[str, dict[int, list[Cluster]]] = {}
        # _precedence[a, b]: how often a came before b in a learned sequence
        self._precedence = np.zeros((len(home.services), len(home.services)), dtype=np.int64)
        # multi mode: _dense[point, a] is the index in node a's clusters of the cluster that
        # responds at that point (-1: none); built on demand, dropped when the tree changes
        self._dense: np.ndarray | None = None
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
        return sorted(self._users)

    def clone(self) -> IHDRTree:
        """A new, untrained tree with the same parameters."""
        return IHDRTree(self.home, mode=self.mode)

    def __repr__(self) -> str:
        return f"IHDRTree(home={self.home.name!r}, mode={self.mode!r})"

    def n_clusters(self, user: str | None = None) -> int:
        """Clusters in the shared tree (or, with ``user``, in that user's layer)."""
        if user is not None:
            return sum(len(v) for v in self._users.get(user, {}).values())
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
            self._learn_row(a, mask, p.codes, p.readings, 1, float(pos), None)
        for i, a in enumerate(services):
            for b in services[i + 1 :]:
                self._precedence[a, b] += 1
                self._before = None
        self.n_experiences += 1

    def learn_many(self, samples: Any) -> None:
        """Learn a :class:`~homecog.knowledge.samples.SampleSet` at once.

        The same as ``learn_one`` for each sample in order, but each distinct cluster is
        learned once with its count, which is what makes building from 663,552 samples quick.
        """
        codes, readings, positions, masks = samples.codes, samples.readings, samples.positions, samples.masks
        local_dims = samples.space.dims
        n_dims = len(local_dims)
        # a group's samples: their dimensions and services at their places in the whole home
        dims = samples.dims if samples.dims is not None else tuple(range(n_dims))
        n_services = positions.shape[1]
        where = samples.services if samples.services is not None else tuple(range(n_services))
        numeric = [j for j, d in enumerate(local_dims) if d.numeric]
        radices = tuple(len(d.values) for d in local_dims)
        idle = (positions < 0).all(axis=1)
        done = positions >= 0
        for a in range(n_services):
            both = done & done[:, [a]]
            self._precedence[where[a], list(where)] += (both & (positions > positions[:, [a]])).sum(axis=0)
        self._before = None
        width = len(self._space)
        for a in range(n_services + 1):
            if a < n_services:
                rows = np.flatnonzero(positions[:, a] >= 0)
                row_masks = masks[rows, a]
                row_pos = positions[rows, a].astype(np.float64)
            else:
                rows = np.flatnonzero(idle)
                if masks.shape[1] > n_services:
                    row_masks = masks[rows, n_services]
                else:
                    row_masks = np.full(len(rows), (1 << n_dims) - 1, dtype=np.int64)
                row_pos = np.zeros(len(rows))
            if rows.size == 0:
                continue
            first, inverse, counts = _distinct_rows(row_masks, codes[rows], radices)
            pos_sums = np.bincount(inverse, weights=row_pos, minlength=len(first))
            stats = {}
            # readings matter to the paper's clusters (mean ± range); multi keeps bins only
            if self.mode == "paper" and numeric:
                grouped = np.argsort(inverse, kind="stable")
                for j in numeric:
                    vals = readings[rows, j]
                    low, high = _group_min_max(grouped, inverse, vals, len(first))
                    stats[j] = (np.bincount(inverse, weights=vals, minlength=len(first)), low, high)
            target = where[a] if a < n_services else len(self.home.services)
            order = np.argsort(first, kind="stable")  # in the order the samples came
            picked = rows[first[order]]
            row_codes = codes[picked].tolist()
            row_readings = readings[picked].tolist()
            local_masks = row_masks[first[order]].tolist()
            row_counts, row_sums = counts[order].tolist(), pos_sums[order].tolist()
            row_stats = {j: [stats[j][k][order].tolist() for k in range(3)] for j in stats}
            for i in range(len(order)):
                local_mask = local_masks[i]
                full_codes = [0] * width
                full_readings: list[float | None] = [None] * width
                mask = 0
                for j in _bits(local_mask):
                    g = dims[j]
                    mask |= 1 << g
                    full_codes[g] = row_codes[i][j]
                    r = row_readings[i][j]
                    full_readings[g] = None if r != r else r  # NaN: not a reading
                extra = {dims[j]: (st[0][i], st[1][i], st[2][i]) for j, st in row_stats.items()}
                self._learn_row(
                    target, mask, tuple(full_codes), tuple(full_readings), row_counts[i], row_sums[i], extra
                )
        self.n_experiences += len(codes)

    def _learn_row(
        self,
        a: int,
        mask: int,
        codes: tuple[int, ...],
        readings: tuple[float | None, ...],
        n: int,
        pos_sum: float,
        stats: dict[int, tuple[float, float, float]] | None,
    ) -> None:
        node = self._all_services()[a]
        for target in (node, node.parent):
            assert target is not None
            target.count += n
            target.position_sum += pos_sum
        if self.mode == "paper":
            for target in (node, node.parent):
                self._algorithm2(target, mask, codes, readings, n, stats)  # type: ignore[arg-type]
        else:
            self._merge_box(node, mask, codes, readings, n, pos_sum)

    def _algorithm2(
        self,
        node: Node,
        mask: int,
        codes: tuple[int, ...],
        readings: tuple[float | None, ...],
        n: int,
        stats: dict[int, tuple[float, float, float]] | None,
    ) -> None:
        """Algorithm 2, step 3: update the node's one cluster with a sample row."""
        dims = self._space.dims
        if not node.clusters:  # step 1: the first sample makes the cluster
            conditions: dict[int, Condition] = {}
            for j in range(len(dims)):
                if mask >> j & 1:
                    conditions[j] = (
                        self._numeric(j, codes, readings, n, stats)
                        if dims[j].numeric
                        else frozenset([codes[j]])
                    )
            node.clusters.append(self._new_cluster(conditions))
        else:
            cluster = node.clusters[0]
            for j in list(cluster.conditions):
                cond = cluster.conditions[j]
                if not mask >> j & 1:  # step 3.3: unrelated in this sample: unrelated for good
                    del cluster.conditions[j]
                elif isinstance(cond, Numeric):  # step 3.4
                    if stats is not None and j in stats:
                        total, low, high = stats[j]
                        cond.add(float(readings[j] or 0.0), n, total, low, high)
                    else:
                        cond.add(float(readings[j]))  # type: ignore[arg-type]
                else:  # step 3.5
                    cluster.conditions[j] = cond | {codes[j]}
        node.clusters[0].count += n

    @staticmethod
    def _numeric(
        j: int,
        codes: tuple[int, ...],
        readings: tuple[float | None, ...],
        n: int,
        stats: dict[int, tuple[float, float, float]] | None,
    ) -> Numeric:
        if stats is not None and j in stats:
            total, low, high = stats[j]
            return Numeric(count=n, total=float(total), low=float(low), high=float(high))
        x = float(readings[j])  # type: ignore[arg-type]
        return Numeric(count=1, total=x, low=x, high=x)

    def _merge_box(
        self,
        node: Node,
        mask: int,
        codes: tuple[int, ...],
        readings: tuple[float | None, ...],
        n: int,
        pos_sum: float,
    ) -> None:
        """Multi mode: join a covering box, merge with a box one dimension away, or start one."""
        index = self._index[node.id]
        dims = _bits(mask)
        key = tuple(codes[j] for j in dims)
        hit = index.covering(mask, key)
        if hit is not None:
            hit.count += n
            hit.position_sum += pos_sum
            return
        box = self._new_cluster({j: frozenset([codes[j]]) for j in dims}, count=n, position_sum=pos_sum)
        index.point_to(box, box.conditions, mask)
        while True:
            keys = index.partner_keys(box, mask)
            partner = index.partner(box, keys)
            if partner is None:
                break
            index.unlink(partner)
            node.clusters.remove(partner)
            merged = {j: box.conditions[j] | partner.conditions[j] for j in box.conditions}  # type: ignore[operator]
            # the union takes the partner's identity; of the two objects, the one with more
            # points keeps them, and only the other's points are pointed at it
            keep, other = (partner, box) if _size(partner) >= _size(box) else (box, partner)
            index.point_to(keep, other.conditions, mask)
            keep.id, keep.seq = partner.id, partner.seq
            keep.conditions = merged
            keep.count = box.count + partner.count
            keep.position_sum = box.position_sum + partner.position_sum
            box = keep
        node.clusters.append(box)
        index.link(box, keys)
        self._dense = None

    # -- cognition ---------------------------------------------------------------------------
    def _dense_table(self) -> np.ndarray:
        """The responding cluster of every service node at every discrete point (on demand)."""
        if self._dense is None:
            sizes = [len(d.values) for d in self._space.dims]
            nodes = self._all_services()
            table = np.full([*sizes, len(nodes)], -1, dtype=np.int16)
            for node in nodes:
                # the first cluster (lowest id) wins where boxes overlap, as in the lookup
                for i in sorted(range(len(node.clusters)), key=lambda i: -node.clusters[i].id):
                    cluster = node.clusters[i]
                    axes = [
                        np.array(sorted(cluster.conditions[j]), dtype=np.intp)  # type: ignore[arg-type]
                        if j in cluster.conditions
                        else np.arange(size)
                        for j, size in enumerate(sizes)
                    ]
                    table[(*np.ix_(*axes), node.service)] = i
            self._dense = table.reshape(-1, len(nodes))
        return self._dense

    def _shared_match(self, node: Node, p: Point) -> Cluster | None:
        if self.mode == "multi":
            return self._index[node.id].lookup(p.codes)
        for cluster in node.clusters:
            if cluster.matches(p):
                return cluster
        return None

    def _user_match(self, user: str | None, a: int, p: Point) -> Cluster | None:
        if user is None:
            return None
        best = None
        for cluster in self._users.get(user, {}).get(a, []):
            if cluster.matches(p) and (
                best is None or (len(cluster.conditions), cluster.seq) > (len(best.conditions), best.seq)
            ):
                best = cluster
        return best

    def _search(self, p: Point, user: str | None) -> tuple[list[tuple[Node, Cluster]], bool]:
        """Algorithm 3: the service nodes whose clusters respond, and whether Idle responded."""
        hits: list[tuple[Node, Cluster]] = []
        idle = False
        if self._dense_ok:
            row = self._dense_table()[sum(map(operator.mul, p.codes, self._strides))].tolist()
            layer = self._users.get(user, {}) if user is not None else {}
            for node, i in zip(self._all_services(), row, strict=True):
                user_hit = self._user_match(user, node.service, p) if node.service in layer else None
                if user_hit is not None:
                    if user_hit.polarity > 0:
                        hits.append((node, user_hit))
                elif i >= 0:
                    if node is self._idle:
                        idle = True
                    else:
                        hits.append((node, node.clusters[i]))
            return self._ordered(hits), idle
        for category in self.root.children:
            # a category is searched when its cluster responds (paper); in multi mode a
            # category keeps no cluster of its own and every category is searched
            if self.mode == "paper" and category.clusters and not category.clusters[0].matches(p):
                continue
            for node in category.children:
                user_hit = self._user_match(user, node.service, p) if user is not None else None
                cluster = user_hit if user_hit is not None else self._shared_match(node, p)
                if cluster is None or cluster.polarity < 0:
                    continue
                if node is self._idle:
                    idle = True
                else:
                    hits.append((node, cluster))
        return self._ordered(hits), idle

    def _ordered(self, hits: list[tuple[Node, Cluster]]) -> list[tuple[Node, Cluster]]:
        """By priority (mean position), except that a service the learned sequences always put
        before another (it clears the way: close the window, then cool) goes first."""
        if len(hits) < 2:
            return hits
        multi = self.mode == "multi"
        rest = sorted(
            hits, key=lambda h: ((h[1].priority if multi and h[1].count else h[0].priority), h[0].service)
        )
        if self._before is None:
            prec = self._precedence
            # b must precede a when it came first in (nearly) every sequence with both
            must = (prec.T > 0) & (prec * 100 <= prec.T)
            self._before = [set(np.flatnonzero(must[a]).tolist()) for a in range(len(prec))]
        before = self._before
        present = {node.service for node, _ in rest}
        if not any(before[a] & present for a in present):
            return rest
        out = []
        while rest:
            for i, (node, _) in enumerate(rest):
                need = before[node.service]
                blocked = bool(need) and any(o.service in need for o, _ in rest if o is not node)
                if not blocked:
                    out.append(rest.pop(i))
                    break
            else:  # contradictory experience: keep the priority order
                out.extend(rest)
                break
        return out

    def _priority(self, node: Node, cluster: Cluster) -> float:
        return cluster.priority if self.mode == "multi" and cluster.count else node.priority

    def explain_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> Cognition:
        """Services for a context, ordered by priority, with why (Algorithm 3)."""
        hits, idle = self._search(self.point(x), user)
        explanations = [
            Explanation(
                service=node.name,
                category=node.parent.name if node.parent else "",
                priority=round(self._priority(node, cluster), 3),
                cluster=cluster.id,
                user=cluster.user,
                conditions=self.describe(cluster),
            )
            for node, cluster in hits
        ]
        return Cognition(
            services=[e.service for e in explanations],
            unknown=not hits and not idle,
            explanations=explanations,
        )

    def predict_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> list[str]:
        """The services the user needs in context ``x``, in priority order."""
        return [node.name for node, _ in self._search(self.point(x), user)[0]]

    def describe(self, cluster: Cluster) -> dict[str, str]:
        """A cluster's conditions as text, per related dimension.

        Conditions on codes alone (frozensets, which never change) are described once and
        remembered: explanations are on the path of every ``POST /api/cognize``.
        """
        items = sorted(cluster.conditions.items())
        key = tuple(items)
        try:
            return dict(self._described[key])
        except TypeError:  # a numeric condition: its mean moves with what it learns
            pass
        except KeyError:
            if len(self._described) >= 100_000:
                self._described.clear()
            self._described[key] = self._describe(items)
            return dict(self._described[key])
        return self._describe(items)

    def _describe(self, items: list[tuple[int, Condition]]) -> dict[str, str]:
        labels = self._labels()
        out = {}
        for j, cond in items:
            dim = self._space.dims[j]
            if isinstance(cond, Numeric):
                fmt = format_clock if dim.kind == "clock" else (lambda v: format_number(round(v, 2)))
                out[dim.name] = f"{fmt(cond.mean)} ± {format_number(round(cond.range, 2))}"
            else:
                out[dim.name] = ", ".join([labels[j][k] for k in sorted(cond)])
        return out

    def _labels(self) -> list[list[str]]:
        """Per dimension, each code's text in explanations ("high (≥ 28 °C)", "on"); made once,
        since explanations are on the path of every ``POST /api/cognize``."""
        if self._label_table is None:
            table = []
            for j, dim in enumerate(self._space.dims):
                if dim.numeric:
                    feature = self.home.features[j]
                    table.append([f"{v} {feature.describe_bin(k)}" for k, v in enumerate(feature.values)])
                else:
                    table.append(list(dim.values))
            self._label_table = table
        return self._label_table

    def correct_one(
        self, x: Mapping[str, object] | Point, want: Sequence[str], user: str = "default"
    ) -> tuple[list[str], list[str]]:
        """A user's correction: the services they want in ``x``. Returns (added, rejected).

        It takes effect for that user's next cognition at once. The shared experience
        from learning is not changed, so other users' answers stay as they were.
        """
        p = self.point(x)
        wanted = self._service_positions(want)
        predicted = self._service_positions(self.predict_one(p, user))
        added = [a for a in wanted if a not in predicted]
        rejected = [a for a in predicted if a not in wanted]
        layer = self._users.setdefault(user, {})
        for a, polarity in [(a, 1) for a in added] + [(a, -1) for a in rejected]:
            self._user_example(layer.setdefault(a, []), a, p, polarity, user)
        self.n_experiences += 1
        names = self.home.services
        return [names[a].name for a in added], [names[a].name for a in rejected]

    def _user_example(self, clusters: list[Cluster], a: int, p: Point, polarity: int, user: str) -> None:
        """Add a user's example to their layer, generalized where the shared tree says it may be."""
        codes = p.codes
        # 1. the features that matter: those of the shared cluster nearest to this context
        dims = self._relevant_dims(a, p)
        box = {j: frozenset([codes[j]]) for j in dims}
        # 2. never cover an example of the opposite label: add a dimension where they differ
        for other in clusters:
            if other.polarity != polarity and other.seed is not None and _covers(box, other.seed):
                box = self._specialize(box, codes, other.seed)
        # 3. clusters of the opposite label that cover this context give way
        for other in list(clusters):
            if other.polarity != polarity and _covers(other.conditions, codes):
                if other.seed is None or other.seed == codes:
                    clusters.remove(other)
                else:
                    other.conditions = self._specialize(dict(other.conditions), other.seed, codes)
        # 4. merge with a same-label cluster one dimension away, if nothing opposite falls inside
        seq = 1 + max((c.seq for cs in self._users.get(user, {}).values() for c in cs), default=0)
        new = Cluster(
            id=self._next_id,
            conditions=box,
            count=1,
            user=user,
            polarity=polarity,  # type: ignore[arg-type]
            seed=codes,
            seq=seq,
        )
        self._next_id += 1
        opposite = [o.seed for o in clusters if o.polarity != polarity and o.seed is not None]
        for other in clusters:
            if other.polarity != polarity or other.conditions.keys() != new.conditions.keys():
                continue
            differ = [j for j in new.conditions if new.conditions[j] != other.conditions[j]]
            if len(differ) == 1:
                merged = {j: new.conditions[j] | other.conditions[j] for j in new.conditions}  # type: ignore[operator]
                if not any(_covers(merged, s) for s in opposite):
                    other.conditions = merged
                    other.count += 1
                    other.seq = new.seq
                    # keep the list in seq order, the order the store loads a layer in
                    clusters.remove(other)
                    clusters.append(other)
                    return
        clusters.append(new)

    def _relevant_dims(self, a: int, p: Point) -> list[int]:
        node = self._services[a]
        best: Cluster | None = None
        best_agree = -1
        for cluster in node.clusters:
            if any(isinstance(c, Numeric) for c in cluster.conditions.values()):
                agree = sum(
                    1 for j, c in cluster.conditions.items() if not isinstance(c, Numeric) and p.codes[j] in c
                )
            else:
                agree = sum(1 for j, c in cluster.conditions.items() if p.codes[j] in c)  # type: ignore[operator]
            if agree > best_agree or (
                agree == best_agree and best is not None and len(cluster.conditions) < len(best.conditions)
            ):
                best, best_agree = cluster, agree
        if best is None or not best.conditions:
            return list(range(len(self._space)))
        return sorted(best.conditions)

    def _specialize(
        self, box: dict[int, Condition], keep: tuple[int, ...], drop: tuple[int, ...]
    ) -> dict[int, Condition]:
        """Narrow ``box`` (made around ``keep``) so that it no longer covers ``drop``."""
        free = [j for j in range(len(self._space)) if j not in box and keep[j] != drop[j]]
        if free:
            box[free[0]] = frozenset([keep[free[0]]])
            return box
        for j, cond in box.items():  # a related dimension with a value set: shrink it
            if drop[j] in cond and keep[j] != drop[j]:  # type: ignore[operator]
                box[j] = cond - {drop[j]}  # type: ignore[operator]
                return box
        return box

    # -- persistence helpers (the store maps the tree to rows and back) --------------------
    def user_clusters(self, user: str) -> dict[int, list[Cluster]]:
        return self._users.get(user, {})

    def _state(self) -> dict[str, Any]:
        return {
            "precedence": self._precedence.tolist(),
            "next_id": self._next_id,
            "seq": self._seq,
            "n_experiences": self.n_experiences,
        }

    def _restore_state(self, state: dict[str, Any]) -> None:
        if "precedence" in state:
            self._precedence = np.array(state["precedence"], dtype=np.int64)
        self._next_id = max(self._next_id, state.get("next_id", 0))
        self._seq = max(self._seq, state.get("seq", 0))
        self.n_experiences = state.get("n_experiences", 0)
        self._dense = None
        self._before = None

    def _restore_shared(self, node: Node, cluster: Cluster) -> None:
        node.clusters.append(cluster)
        if self.mode == "multi" and node.id in self._index:
            self._index[node.id].add(cluster)
        self._dense = None

    def _restore_user(self, user: str, service: int, cluster: Cluster) -> None:
        self._users.setdefault(user, {}).setdefault(service, []).append(cluster)

    def _replace_user(self, user: str, layer: dict[int, list[Cluster]], version: int = 0) -> None:
        if layer:
            self._users[user] = layer
        else:
            self._users.pop(user, None)

    def _replay(self, kind: str, user: str | None, payload: dict[str, Any]) -> None:
        """Apply a logged single sample or correction again (for rebuilds)."""
        point = Point(codes=tuple(payload["codes"]), readings=tuple(payload["readings"]))
        if kind == "correction":
            self.correct_one(point, payload["want"], user or "default")
        else:
            self.learn_one(point, payload["services"], relevant=payload.get("relevant"))

    def shared_clusters(self) -> Iterator[tuple[Node, Cluster]]:
        for node in self.root.iter_dfs():
            for cluster in node.clusters:
                yield node, cluster

    def signature(self) -> tuple[Any, ...]:
        """Everything the tree answers from, for comparing two trees."""

        def cond_sig(c: Condition) -> Any:
            return (
                ("n", c.count, round(c.total, 6), c.low, c.high)
                if isinstance(c, Numeric)
                else tuple(sorted(c))
            )

        shared = tuple(
            (
                n.name,
                n.count,
                round(n.position_sum, 6),
                tuple(
                    (
                        cl.count,
                        round(cl.position_sum, 6),
                        tuple((j, cond_sig(c)) for j, c in sorted(cl.conditions.items())),
                    )
                    for cl in sorted(n.clusters, key=lambda c: c.id)
                ),
            )
            for n in self.root.iter_dfs()
        )
        users = tuple(
            (
                u,
                tuple(
                    (
                        a,
                        tuple(
                            (
                                cl.polarity,
                                cl.seed,
                                tuple((j, cond_sig(c)) for j, c in sorted(cl.conditions.items())),
                            )
                            for cl in cls
                        ),
                    )
                    for a, cls in sorted(layer.items())
                ),
            )
            for u, layer in sorted(self._users.items())
        )
        return shared, users

    def __getstate__(self) -> dict[str, Any]:
        state = copy.copy(self.__dict__)
        state["_dense"] = None  # caches, rebuilt on demand
        state["_before"] = None
        return state


def _size(cluster: Cluster) -> int:
    """Points of a box: the product of its value sets."""
    return math.prod(len(c) for c in cluster.conditions.values())  # type: ignore[arg-type]


def _bits(mask: int) -> tuple[int, ...]:
    """The positions of the set bits of a mask, lowest first.

    >>> _bits(0b10110)
    (1, 2, 4)
    """
    out = []
    while mask:
        low = mask & -mask
        out.append(low.bit_length() - 1)
        mask ^= low
    return tuple(out)


def _covers(box: Mapping[int, Condition], codes: Sequence[int]) -> bool:
    return all(codes[j] in c for j, c in box.items())  # type: ignore[operator]


def _distinct_rows(
    masks: np.ndarray, codes: np.ndarray, radices: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Groups of rows with the same mask and the same codes on it: (first row, group, size)."""
    n_dims = codes.shape[1]
    bits = ((masks[:, None] >> np.arange(n_dims)[None, :]) & 1).astype(bool)
    shifted = np.where(bits, codes.astype(np.int64) + 1, 0)  # 0: unrelated
    span = 1
    for r in radices:
        span *= r + 1
    if span * (1 << n_dims) < 2**62:  # one int64 key per row: fast to sort
        key = masks.astype(np.int64)
        for j in range(n_dims):
            key = key * (radices[j] + 1) + shifted[:, j]
        _, first, inverse, counts = np.unique(key, return_index=True, return_inverse=True, return_counts=True)
    else:
        rows = np.concatenate([masks[:, None], shifted], axis=1)
        _, first, inverse, counts = np.unique(
            rows, axis=0, return_index=True, return_inverse=True, return_counts=True
        )
    return first, inverse.reshape(-1), counts


def _group_min_max(
    order: np.ndarray, inverse: np.ndarray, values: np.ndarray, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per group of ``inverse``, the least and greatest value (``order`` sorts ``inverse``)."""
    starts = np.searchsorted(inverse[order], np.arange(size))
    ordered = values[order]
    return np.minimum.reduceat(ordered, starts), np.maximum.reduceat(ordered, starts)
