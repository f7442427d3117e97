"""Cognition in the knowledge tree (the paper's Algorithm 3): the service nodes whose
clusters respond to a context, a user's corrections over them, the order of the answer, and why.

:class:`TreeSearch` is the half of :class:`~homecog.knowledge.ihdr.IHDRTree` that answers; the
other half learns. Three ways find the responding clusters, fastest first: a dense table of the
responding cluster of every node at every point (small homes, multi mode), a table per group of
devices (large homes, :mod:`homecog.knowledge.group_index`), and asking every node's clusters.
They give the same answers (tests check it).
"""

from __future__ import annotations

import itertools
import math
import operator
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from homecog.home.clock import format_clock
from homecog.home.codec import Point, bin_reading
from homecog.home.model import format_number
from homecog.home.scenes import composition, scene_services
from homecog.knowledge.group_index import LIMIT_BYTES as GROUP_INDEX_BYTES
from homecog.knowledge.group_index import GroupIndex
from homecog.knowledge.model import Cluster, Cognition, Condition, Explanation, Node, Numeric

#: the most completions of a context's missing readings the shared tree is asked at
COMPLETIONS = 64

if TYPE_CHECKING:
    from homecog.home.codec import Space
    from homecog.home.model import Home
    from homecog.knowledge.box_index import BoxIndex
    from homecog.knowledge.corrections import UserLayers


class TreeSearch:
    """Algorithm 3 and the explanations, over the attributes an IHDRTree has."""

    home: Home
    mode: str
    root: Node
    _space: Space
    _services: list[Node]
    _idle: Node
    _index: dict[int, BoxIndex]
    _layers: UserLayers
    _precedence: np.ndarray
    _dense: np.ndarray | None
    _gindex: GroupIndex | bool | None
    _before: list[set[int]] | None
    _label_table: list[list[str]] | None
    _described: dict[tuple[Any, ...], dict[str, str]]
    _strides: tuple[int, ...]
    _dense_ok: bool
    _shared_version: int

    def point(self, x: Mapping[str, object] | Point) -> Point:
        raise NotImplementedError

    def _all_services(self) -> list[Node]:
        raise NotImplementedError

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

    def _search(
        self, p: Point, user: str | None
    ) -> tuple[list[tuple[Node, Cluster]], bool, dict[int, list[str]]]:
        """Algorithm 3: the service nodes whose clusters respond, and whether Idle responded;
        scenes in the place of the services they do the work of (and per scene those
        services); then the user's evidence over that answer — the services the robot would
        propose, scenes included. A service that would change nothing is left out."""
        hits, idle = self._shared_search_missing(p) if p.missing else self._shared_search(p)
        changes = self._layers.changes
        if any(not changes(node.service, p.codes) for node, _ in hits):
            hits = [(node, c) for node, c in hits if changes(node.service, p.codes)]
        hits, replaced = self._with_scenes(hits, p)
        if user is None or not self._layers.n_examples(user):
            return hits, idle, replaced
        chosen = {node.service: (node, c) for node, c in hits}
        shared = frozenset(chosen)
        for a, decision in self._layers.decisions(user, p, shared):
            idle = True  # the user's evidence answered: the context is not unknown
            if decision.sign > 0:
                chosen[a] = (self._services[a], Cluster(id=-1, conditions={}, user=user, evidence=decision))
            else:
                chosen.pop(a, None)
                replaced.pop(a, None)
        for a in self._layers.covered(frozenset(chosen)):
            chosen.pop(a, None)  # a scene taken does its work
        if chosen.keys() == {n.service for n, _ in hits}:  # the same services: in the same order
            return [chosen[n.service] for n, _ in hits], idle, replaced
        return self._ordered([chosen[a] for a in sorted(chosen)]), idle, replaced

    def _shared_search_missing(self, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
        """The shared answer where readings are missing: the services the tree proposes
        whatever they are — at every completion of the missing features by one of their bins
        (a reading inside it) or values, at most :data:`COMPLETIONS` of them; beyond, none.
        Known (not unknown) where every completion is."""
        features = self.home.features
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
            hits, idle = self._shared_search(Point(tuple(codes), tuple(readings)))
            known &= idle or bool(hits)
            found = {node.service: (node, c) for node, c in hits}
            common = found if common is None else {a: h for a, h in common.items() if a in found}
        chosen = list((common or {}).values())
        return self._ordered(chosen), known

    def _shared_search(self, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
        if self._dense_ok:
            return self._dense_search(p)
        index = self._group_index() if self.mode == "multi" else None
        hits = self._group_hits(index, p) if index is not None else self._walk_search(p)
        return self._ordered(hits), False if hits else self._idle_responds(p)

    def _dense_search(self, p: Point) -> tuple[list[tuple[Node, Cluster]], bool]:
        """:meth:`_shared_search` in the dense table of every context's answer."""
        hits: list[tuple[Node, Cluster]] = []
        idle = False
        row = self._dense_table()[sum(map(operator.mul, p.codes, self._strides))].tolist()
        for node, i in zip(self._all_services(), row, strict=True):
            if i >= 0:
                if node is self._idle:
                    idle = True
                else:
                    hits.append((node, node.clusters[i]))
        return self._ordered(hits), idle

    def _walk_search(self, p: Point) -> list[tuple[Node, Cluster]]:
        """The services whose clusters respond to ``p``, down the tree (unordered, idle aside)."""
        hits: list[tuple[Node, Cluster]] = []
        for category in self.root.children:
            # a category is searched when its cluster responds (paper); in multi mode a
            # category keeps no cluster of its own and every category is searched
            if self.mode == "paper" and category.clusters and not category.clusters[0].matches(p):
                continue
            for node in category.children:
                if node is self._idle:
                    continue  # asked only when no service answers
                cluster = self._shared_match(node, p)
                if cluster is not None:
                    hits.append((node, cluster))
        return hits

    def _shared_state_version(self) -> int:
        return self._shared_version

    def _relevant_features(self, a: int) -> frozenset[int]:
        """The context features that matter to service ``a`` in the shared tree: those that at
        least half of its clusters (weighed by what they learned) constrain."""
        clusters = self._services[a].clusters
        total = sum(max(c.count, 1) for c in clusters)
        weight = [0.0] * self._space.n_features
        for c in clusters:
            for j in c.conditions:
                if j < len(weight):
                    weight[j] += max(c.count, 1)
        return frozenset(j for j, w in enumerate(weight) if total and w * 2 >= total)

    def _shared_services(self, p: Point) -> frozenset[int]:
        """The services the shared tree proposes at ``p`` (what a user's layer takes as prior)."""
        return frozenset(node.service for node, _ in self._search(p, None)[0])

    def _idle_responds(self, p: Point) -> bool:
        """Whether "nothing to do" answers a context (its category's cluster too, in paper mode)."""
        category = self._idle.parent
        assert category is not None
        if self.mode == "paper" and category.clusters and not category.clusters[0].matches(p):
            return False
        return self._shared_match(self._idle, p) is not None

    def _group_index(self) -> GroupIndex | None:
        """The group tables of a large multi tree (built on first use), or None where they do not
        fit (:mod:`homecog.knowledge.group_index`)."""
        if self._gindex is None:
            fits = GroupIndex.size(self.home) <= GROUP_INDEX_BYTES
            self._gindex = GroupIndex(self.home, self._services) if fits else False
        return self._gindex or None

    def _group_hits(self, index: GroupIndex, p: Point) -> list[tuple[Node, Cluster]]:
        services, found = index.responding(p.codes)
        chosen: dict[int, Cluster] = {}
        for a, i in zip(services.tolist(), found.tolist(), strict=True):
            chosen[a] = self._services[a].clusters[i]
        for a in index.outside:
            cluster = self._shared_match(self._services[a], p)
            if cluster is not None:
                chosen[a] = cluster
        return [(self._services[a], c) for a, c in sorted(chosen.items())]

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

    def _with_scenes(
        self, hits: list[tuple[Node, Cluster]], p: Point
    ) -> tuple[list[tuple[Node, Cluster]], dict[int, list[str]]]:
        """The answer with scenes in the place of the services they do the work of
        (:func:`homecog.home.scenes.composition`), and per scene those services."""
        if len(hits) < 2 or not scene_services(self.home):
            return hits, {}
        n_f = self._space.n_features
        plan = [node.service for node, _ in hits]
        done, work = composition(self.home, p.codes[:n_f], [bool(c) for c in p.codes[n_f:]], plan)
        if not work:
            return hits, {}
        by_service = dict(zip(plan, hits, strict=True))
        out = [by_service.get(a) or (self._services[a], Cluster(id=-1, conditions={})) for a in done]
        names = self.home.service_names
        return out, {x: [names[a] for a in replaced] for x, replaced in work.items()}

    def explain_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> Cognition:
        """Services for a context, ordered by priority, with why (Algorithm 3); a scene says
        which services it does the work of."""
        p = self.point(x)
        hits, idle, replaced = self._search(p, user)
        explanations = []
        for node, cluster in hits:
            if node.service in replaced:
                conditions, evidence = {"instead of": ", ".join(replaced[node.service])}, None
            elif cluster.evidence is not None:
                conditions, evidence = self._layers.explain(cluster.user, node.service, cluster.evidence)
            else:
                conditions, evidence = self.describe(cluster), None
            explanations.append(
                Explanation(
                    service=node.name,
                    category=node.parent.name if node.parent else "",
                    priority=round(self._priority(node, cluster), 3),
                    cluster=cluster.id,
                    user=cluster.user,
                    conditions=conditions,
                    evidence=evidence,
                )
            )
        return Cognition(
            services=[e.service for e in explanations],
            unknown=not hits and not idle,
            explanations=explanations,
        )

    def predict_one(self, x: Mapping[str, object] | Point, user: str | None = None) -> list[str]:
        """The services the user needs in context ``x``, in priority order."""
        p = self.point(x)
        return [node.name for node, _ in self._search(p, user)[0]]

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
