"""Cognition in the knowledge tree: the shared answer (:mod:`homecog.knowledge.lookup`), scenes
in the place of the services they do the work of, a user's corrections over that, and why.

Functions over the tree's data (:class:`~homecog.knowledge.tree.Tree`) and the users' layers
(:class:`~homecog.knowledge.corrections.UserLayers`); :class:`~homecog.knowledge.ihdr.IHDRTree`
answers with them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from homecog.home.clock import format_clock
from homecog.home.codec import Point
from homecog.home.model import format_number
from homecog.home.scenes import composition, scene_services
from homecog.knowledge.layer_explain import layer_evidence
from homecog.knowledge.lookup import ordered, priority, shared_search, shared_search_missing
from homecog.knowledge.model import Cluster, Cognition, Condition, Explanation, Node, Numeric

if TYPE_CHECKING:
    from homecog.knowledge.corrections import UserLayers
    from homecog.knowledge.tree import Tree


def search(
    t: Tree, layers: UserLayers, p: Point, user: str | None
) -> tuple[list[tuple[Node, Cluster]], bool, dict[int, list[str]]]:
    """Algorithm 3: the service nodes whose clusters respond, and whether Idle responded;
    scenes in the place of the services they do the work of (and per scene those
    services); then the user's evidence over that answer — the services the robot would
    propose, scenes included. A service that would change nothing is left out."""
    hits, idle = shared_search_missing(t, p) if p.missing else shared_search(t, p)
    changes = layers.changes
    if any(not changes(node.service, p.codes) for node, _ in hits):
        hits = [(node, c) for node, c in hits if changes(node.service, p.codes)]
    hits, replaced = _with_scenes(t, hits, p)
    if user is None or not layers.n_examples(user):
        return hits, idle, replaced
    chosen = {node.service: (node, c) for node, c in hits}
    shared = frozenset(chosen)
    for a, decision in layers.decisions(user, p, shared):
        idle = True  # the user's evidence answered: the context is not unknown
        if decision.sign > 0:
            chosen[a] = (t.services[a], Cluster(id=-1, conditions={}, user=user, evidence=decision))
        else:
            chosen.pop(a, None)
            replaced.pop(a, None)
    for a in layers.covered(frozenset(chosen)):
        chosen.pop(a, None)  # a scene taken does its work
    if chosen.keys() == {n.service for n, _ in hits}:  # the same services: in the same order
        return [chosen[n.service] for n, _ in hits], idle, replaced
    return ordered(t, [chosen[a] for a in sorted(chosen)]), idle, replaced


def shared_services(t: Tree, layers: UserLayers, p: Point) -> frozenset[int]:
    """The services the shared tree proposes at ``p`` (what a user's layer takes as prior)."""
    return frozenset(node.service for node, _ in search(t, layers, p, None)[0])


def _with_scenes(
    t: Tree, hits: list[tuple[Node, Cluster]], p: Point
) -> tuple[list[tuple[Node, Cluster]], dict[int, list[str]]]:
    """The answer with scenes in the place of the services they do the work of
    (:func:`homecog.home.scenes.composition`), and per scene those services."""
    if len(hits) < 2 or not scene_services(t.home):
        return hits, {}
    n_f = t.space.n_features
    plan = [node.service for node, _ in hits]
    done, work = composition(t.home, p.codes[:n_f], [bool(c) for c in p.codes[n_f:]], plan)
    if not work:
        return hits, {}
    by_service = dict(zip(plan, hits, strict=True))
    out = [by_service.get(a) or (t.services[a], Cluster(id=-1, conditions={})) for a in done]
    names = t.home.service_names
    return out, {x: [names[a] for a in replaced] for x, replaced in work.items()}


def explain(t: Tree, layers: UserLayers, p: Point, user: str | None = None) -> Cognition:
    """Services for a context, ordered by priority, with why (Algorithm 3); a scene says
    which services it does the work of."""
    hits, idle, replaced = search(t, layers, p, user)
    explanations = []
    for node, cluster in hits:
        if node.service in replaced:
            conditions, evidence = {"instead of": ", ".join(replaced[node.service])}, None
        elif cluster.evidence is not None:
            conditions, evidence = layer_evidence(layers, cluster.user, node.service, cluster.evidence)
        else:
            conditions, evidence = describe(t, cluster), None
        explanations.append(
            Explanation(
                service=node.name,
                category=node.parent.name if node.parent else "",
                priority=round(priority(t, node, cluster), 3),
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


def describe(t: Tree, cluster: Cluster) -> dict[str, str]:
    """A cluster's conditions as text, per related dimension.

    Conditions on codes alone (frozensets, which never change) are described once and
    remembered: explanations are on the path of every ``POST /api/cognize``.
    """
    items = sorted(cluster.conditions.items())
    key = tuple(items)
    try:
        return dict(t.described[key])
    except TypeError:  # a numeric condition: its mean moves with what it learns
        pass
    except KeyError:
        if len(t.described) >= 100_000:
            t.described.clear()
        t.described[key] = _describe(t, items)
        return dict(t.described[key])
    return _describe(t, items)


def _describe(t: Tree, items: list[tuple[int, Condition]]) -> dict[str, str]:
    labels = _labels(t)
    out = {}
    for j, cond in items:
        dim = t.space.dims[j]
        if isinstance(cond, Numeric):
            fmt = format_clock if dim.kind == "clock" else (lambda v: format_number(round(v, 2)))
            out[dim.name] = f"{fmt(cond.mean)} ± {format_number(round(cond.range, 2))}"
        else:
            out[dim.name] = ", ".join([labels[j][k] for k in sorted(cond)])
    return out


def _labels(t: Tree) -> list[list[str]]:
    """Per dimension, each code's text in explanations ("high (≥ 28 °C)", "on"); made once,
    since explanations are on the path of every ``POST /api/cognize``."""
    if t.label_table is None:
        table = []
        for j, dim in enumerate(t.space.dims):
            if dim.numeric:
                feature = t.home.features[j]
                table.append([f"{v} {feature.describe_bin(k)}" for k, v in enumerate(feature.values)])
            else:
                table.append(list(dim.values))
        t.label_table = table
    return t.label_table
