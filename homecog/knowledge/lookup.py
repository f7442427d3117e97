"""The shared tree's answer at a point (the paper's Algorithm 3, before any user's corrections):
the service nodes whose clusters respond, in the order they are carried out.

Three ways find the responding clusters, fastest first: a dense table of the responding cluster
of every node at every point (small homes, multi mode), a table per group of devices (large
homes, :mod:`homecog.knowledge.group_index`), and asking every node's clusters. They give the
same answers (tests check it). Functions over the tree's data
(:class:`~homecog.knowledge.tree.Tree`); the lookup tables they make are kept there.
"""

from __future__ import annotations

import itertools
import math
import operator
from typing import TYPE_CHECKING

import numpy as np

from homecog.home.codec import Point, bin_reading
from homecog.knowledge.group_index import LIMIT_BYTES as GROUP_INDEX_BYTES
from homecog.knowledge.group_index import GroupIndex
from homecog.knowledge.model import Cluster, Node

if TYPE_CHECKING:
    from homecog.knowledge.tree import Tree

#: the most completions of a context's missing readings the shared tree is asked at
COMPLETIONS = 64


def _dense_table(t: Tree) -> np.ndarray:
    """The responding cluster of every service node at every discrete point (on demand)."""
    if t.dense is None:
        sizes = [len(d.values) for d in t.space.dims]
        nodes = t.all_services()
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
        t.dense = table.reshape(-1, len(nodes))
    return t.dense


def _shared_match(t: Tree, node: Node, p: Point) -> Cluster | None:
    if t.mode == "multi":
        return t.index[node.id].lookup(p.codes)
    for cluster in node.clusters:
        if cluster.matches(p):
            return cluster
    return None


def shared_search_missing(t: Tree, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
    """The shared answer where readings are missing: the services the tree proposes
    whatever they are — at every completion of the missing features by one of their bins
    (a reading inside it) or values, at most :data:`COMPLETIONS` of them; beyond, none.
    Known (not unknown) where every completion is."""
    features = t.home.features
    axes = [range(len(features[j].values)) for j in sorted(p.missing)]
    if math.prod(len(a) for a in axes) > COMPLETIONS:
        return [], False
    common: dict[int, tuple[Node, Cluster]] | None = None
    known = True
    for combo in itertools.product(*axes):
        codes, readings = list(p.codes), list(p.readings)
        for j, k in zip(sorted(p.missing), combo, strict=True):
            codes[j] = k
            bins = features[j].bins
            readings[j] = None if bins is None else bin_reading(bins[k])
        hits, idle = shared_search(t, Point(tuple(codes), tuple(readings)))
        known &= idle or bool(hits)
        found = {node.service: (node, c) for node, c in hits}
        common = found if common is None else {a: h for a, h in common.items() if a in found}
    chosen = list((common or {}).values())
    return ordered(t, chosen), known


def shared_search(t: Tree, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
    if t.dense_ok:
        return _dense_search(t, p)
    index = _group_index(t) if t.mode == "multi" else None
    hits = _group_hits(t, index, p) if index is not None else _walk_search(t, p)
    return ordered(t, hits), False if hits else _idle_responds(t, p)


def _dense_search(t: Tree, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
    """:meth:`_shared_search` in the dense table of every context's answer."""
    hits: list[tuple[Node, Cluster]] = []
    idle = False
    row = _dense_table(t)[sum(map(operator.mul, p.codes, t.strides))].tolist()
    for node, i in zip(t.all_services(), row, strict=True):
        if i >= 0:
            if node is t.idle:
                idle = True
            else:
                hits.append((node, node.clusters[i]))
    return ordered(t, hits), idle


def _walk_search(t: Tree, p: Point) -> list[tuple[Node, Cluster]]:
    """The services whose clusters respond to ``p``, down the tree (unordered, idle aside)."""
    hits: list[tuple[Node, Cluster]] = []
    for category in t.root.children:
        # a category is searched when its cluster responds (paper); in multi mode a
        # category keeps no cluster of its own and every category is searched
        if t.mode == "paper" and category.clusters and not category.clusters[0].matches(p):
            continue
        for node in category.children:
            if node is t.idle:
                continue  # asked only when no service answers
            cluster = _shared_match(t, node, p)
            if cluster is not None:
                hits.append((node, cluster))
    return hits


def relevant_features(t: Tree, a: int) -> frozenset[int]:
    """The context features that matter to service ``a`` in the shared tree: those that at
    least half of its clusters (weighed by what they learned) constrain."""
    clusters = t.services[a].clusters
    total = sum(max(c.count, 1) for c in clusters)
    weight = [0.0] * t.space.n_features
    for c in clusters:
        for j in c.conditions:
            if j < len(weight):
                weight[j] += max(c.count, 1)
    return frozenset(j for j, w in enumerate(weight) if total and w * 2 >= total)


def _idle_responds(t: Tree, p: Point) -> bool:
    """Whether "nothing to do" answers a context (its category's cluster too, in paper mode)."""
    category = t.idle.parent
    assert category is not None
    if t.mode == "paper" and category.clusters and not category.clusters[0].matches(p):
        return False
    return _shared_match(t, t.idle, p) is not None


def _group_index(t: Tree) -> GroupIndex | None:
    """The group tables of a large multi tree (built on first use), or None where they do not
    fit (:mod:`homecog.knowledge.group_index`)."""
    if t.gindex is None:
        fits = GroupIndex.size(t.home) <= GROUP_INDEX_BYTES
        t.gindex = GroupIndex(t.home, t.services) if fits else False
    return t.gindex or None


def _group_hits(t: Tree, index: GroupIndex, p: Point) -> list[tuple[Node, Cluster]]:
    services, found = index.responding(p.codes)
    chosen: dict[int, Cluster] = {}
    for a, i in zip(services.tolist(), found.tolist(), strict=True):
        chosen[a] = t.services[a].clusters[i]
    for a in index.outside:
        cluster = _shared_match(t, t.services[a], p)
        if cluster is not None:
            chosen[a] = cluster
    return [(t.services[a], c) for a, c in sorted(chosen.items())]


def ordered(t: Tree, hits: list[tuple[Node, Cluster]]) -> list[tuple[Node, Cluster]]:
    """By priority (mean position), except that a service the learned sequences always put
    before another (it clears the way: close the window, then cool) goes first."""
    if len(hits) < 2:
        return hits
    multi = t.mode == "multi"
    rest = sorted(
        hits, key=lambda h: ((h[1].priority if multi and h[1].count else h[0].priority), h[0].service)
    )
    if t.before is None:
        prec = t.precedence
        # b must precede a when it came first in (nearly) every sequence with both
        must = (prec.T > 0) & (prec * 100 <= prec.T)
        t.before = [set(np.flatnonzero(must[a]).tolist()) for a in range(len(prec))]
    before = t.before
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


def priority(t: Tree, node: Node, cluster: Cluster) -> float:
    return cluster.priority if t.mode == "multi" and cluster.count else node.priority
