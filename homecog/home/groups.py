"""Independent groups of devices, from the robot's own action model.

Two devices are in one group when one service sets both, or when a prohibited rule of a
service that sets one names the other's state. A service belongs to the group of the
devices it sets; an interaction service is a group of its own unless a prohibited rule ties
it to a device. The comfort and needs rules — the reward the robot is learning — never
decide a group. A scene (:mod:`homecog.home.scenes`: a service that sets several devices,
each as a service of one device also does) ties nothing: it belongs to the group that holds
all its devices, and where they lie in several groups it belongs to none, and each group
learns its part of it as the group's own services.

No service of one group changes, or is forbidden by, the devices of another, so each group
is a small environment of its own over (context, the group's devices, the group's pending
needs): learning, the greedy roll-out and the ground truth all split along the groups, and
their cost grows with the number of devices instead of with 2^devices.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> [(g.devices, len(g.services)) for g in device_groups(home)][:3]
[(('window', 'ac_living', 'ac_bedroom'), 6), (('curtain',), 2), (('tv_living',), 2)]
>>> [g.services for g in device_groups(home) if not g.devices]
[('SendDrinks',), ('CallToWakeup',), ('RemindToSleep',), ('ChargeItSelf',)]
>>> sub = project(home, device_groups(home)[0])
>>> sub.device_names, sub.service_names[:2]
(('window', 'ac_living', 'ac_bedroom'), ('OpenWindow', 'TurnOnACL'))
"""

from __future__ import annotations

from dataclasses import dataclass

from homecog.home.classes import group_classes
from homecog.home.model import ComfortRule, Condition, Feature, Home, Service


@dataclass(frozen=True)
class Group:
    """Devices and services that act on each other, and on nothing else.

    ``device_index`` and ``service_index`` are their positions in the whole home.
    """

    index: int
    devices: tuple[str, ...]
    services: tuple[str, ...]
    device_index: tuple[int, ...]
    service_index: tuple[int, ...]

    @property
    def label(self) -> str:
        """How messages name the group: its devices, or its service when it has none."""
        names = self.devices or self.services
        shown = ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")
        return f"group {self.index} ({shown})"


def _named_devices(cond: Condition) -> set[int]:
    return {d for d, _ in cond.devices}


_CACHE: dict[str, tuple[Group, ...]] = {}


def device_groups(home: Home) -> tuple[Group, ...]:
    """The home's independent groups, in the order of their first device (then service).

    Devices that no service sets or names form groups without services: nothing can change
    them. Union-find over devices and services; remembered per content hash.
    """
    key = home.content_hash
    if key and key in _CACHE:
        return _CACHE[key]
    groups = _find_groups(home)
    if key:
        if len(_CACHE) >= 64:
            _CACHE.clear()
        _CACHE[key] = groups
    return groups


class _UnionFind:
    """Disjoint sets over ``0 .. n−1``; a set's root is its smallest member."""

    def __init__(self, n: int) -> None:
        self.parent = list(range(n))

    def find(self, x: int) -> int:
        parent = self.parent
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    def union(self, x: int, y: int) -> None:
        rx, ry = self.find(x), self.find(y)
        if rx != ry:
            self.parent[max(rx, ry)] = min(rx, ry)


def _touched(home: Home, a: int) -> set[int]:
    """The devices service ``a`` sets or its prohibited rules name."""
    touched = {home.device_index(d) for d, _ in home.services[a].sets}
    for cond in home.prohibited[a]:
        touched |= _named_devices(cond)
    return touched


def _find_groups(home: Home) -> tuple[Group, ...]:
    from homecog.home.scenes import scene_candidates

    n_d = len(home.devices)
    sets = _UnionFind(n_d + len(home.services))  # devices, then services at n_d + a
    scenes = set(scene_candidates(home))
    for a in range(len(home.services)):
        if a not in scenes:
            for d in _touched(home, a):
                sets.union(n_d + a, d)
    spread = set()
    for a in scenes:
        roots = {sets.find(home.device_index(d)) for d, _ in home.services[a].sets}
        if len(roots) == 1:
            sets.union(n_d + a, roots.pop())
        else:
            spread.add(a)
    members: dict[int, list[int]] = {}
    for x in range(len(sets.parent)):
        if x - n_d not in spread:
            members.setdefault(sets.find(x), []).append(x)
    return tuple(_group(home, i, members[root]) for i, root in enumerate(sorted(members)))


def _group(home: Home, i: int, nodes: list[int]) -> Group:
    """Group ``i`` of the devices and services (at ``n_devices + a``) ``nodes``."""
    n_d = len(home.devices)
    devs = tuple(x for x in nodes if x < n_d)
    svcs = tuple(x - n_d for x in nodes if x >= n_d)
    return Group(
        index=i,
        devices=tuple(home.devices[d].name for d in devs),
        services=tuple(home.services[a].name for a in svcs),
        device_index=devs,
        service_index=svcs,
    )


_OWNERS: dict[str, tuple[int, ...]] = {}


def group_of_service(home: Home) -> tuple[int, ...]:
    """Per service (in home order), the index of its group (−1: a scene across groups)."""
    key = home.content_hash
    if key and key in _OWNERS:
        return _OWNERS[key]
    out = [-1] * len(home.services)
    for g in device_groups(home):
        for a in g.service_index:
            out[a] = g.index
    if key:
        if len(_OWNERS) >= 64:
            _OWNERS.clear()
        _OWNERS[key] = tuple(out)
    return tuple(out)


def project(home: Home, group: Group, *, classes: bool = True) -> Home:
    """The home seen by one group: the context features, the group's devices and services,
    their comfort, needs and prohibited rules (device conditions renumbered), the rewards.

    Learning the projection is learning the group: its optimum is the home's optimum on the
    group's devices and needs, and its distance is the group's share of the home's distance.
    With ``classes`` (the default) each feature's values are the group's classes of them
    (:mod:`homecog.home.classes`): values no rule of the group tells apart are one value,
    named by its values joined with ``+``.
    """
    local = {d: i for i, d in enumerate(group.device_index)}
    cls = group_classes(home, group) if classes else None
    features = home.features
    if cls is not None:
        features = tuple(
            Feature(
                name=f.name, kind="categorical", values=tuple("+".join(f.values[k] for k in m) for m in ms)
            )
            if len(ms) < f.radix
            else f
            for f, ms in zip(home.features, cls.members, strict=True)
        )

    def renumber(cond: Condition) -> Condition:
        cond = cls.condition(cond) if cls is not None else cond
        return Condition(
            features=cond.features,
            devices=tuple((local[d], allowed) for d, allowed in cond.devices),
        )

    comfort = tuple(
        tuple(ComfortRule(when=renumber(r.when), want=r.want) for r in home.comfort[d])
        for d in group.device_index
    )
    services = tuple(
        Service(name=s.name, category=s.category, sets=s.sets, description=s.description)
        for s in (home.services[a] for a in group.service_index)
    )
    projected = Home(
        name=f"{home.name}[{group.index}]",
        features=features,
        devices=tuple(home.devices[d] for d in group.device_index),
        services=services,
        comfort=comfort,
        needs=tuple(tuple(renumber(c) for c in home.needs[a]) for a in group.service_index),
        prohibited=tuple(tuple(renumber(c) for c in home.prohibited[a]) for a in group.service_index),
        rewards=home.rewards,
        description=f"{group.label} of {home.name}",
        source=home.source,
    )
    tag = "" if cls is None or cls.trivial else "c"
    object.__setattr__(projected, "content_hash", f"{home.content_hash}/{group.index}{tag}")
    return projected


def whole(home: Home) -> Group:
    """The whole home as one group: the paper's single joint table (``train --joint``)."""
    return Group(
        index=0,
        devices=home.device_names,
        services=home.service_names,
        device_index=tuple(range(len(home.devices))),
        service_index=tuple(range(len(home.services))),
    )
