"""Contexts a group cannot tell apart are one context for that group.

A group (:mod:`homecog.home.groups`) is rewarded by the comfort rules of its devices and the
needs of its services, and restricted by its services' prohibited rules; nothing else of the
home reaches it. Two values of a feature that every one of those rules treats alike (each rule
allows both or neither) give the group the same rewards and the same moves in every state, so
the group learns them as one value: a *class*. In a home with a ``location`` value per room, a
room's devices tell their own room from the others, and the other rooms are one class; so a
group's table has a row per class of context, and stops growing with the number of rooms.

The classes are read off the rules the environment applies — which contexts give the group
identical rewards and transitions — not guessed, so learning on them is learning the group
exactly; every stage that meets a real context maps it to its class first.

>>> from homecog.home import load_home
>>> from homecog.home.groups import device_groups
>>> home = load_home("paper")
>>> tv = device_groups(home)[2]                  # the living-room TV
>>> classes = group_classes(home, tv)
>>> [len(m) for m in classes.members]           # classes of each feature for this group
[1, 1, 1, 2, 1, 3]
>>> classes.members[3]                           # location: in bed, or anywhere else
((0, 1, 3), (2,))
>>> classes.count, home.context_count
(6, 2592)
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from homecog.home.model import Condition, Home

_CACHE: dict[tuple[str, tuple[int, ...], tuple[int, ...]], Classes] = {}


@dataclass(frozen=True)
class Classes:
    """Per feature, the class of each of its values (``of``) and the values of each class
    (``members``); classes are numbered in the order of their first value."""

    of: tuple[tuple[int, ...], ...]
    members: tuple[tuple[tuple[int, ...], ...], ...]

    @property
    def radices(self) -> tuple[int, ...]:
        return tuple(len(m) for m in self.members)

    @property
    def count(self) -> int:
        """Contexts of the group: the product of the features' numbers of classes."""
        return int(np.prod(self.radices, dtype=np.int64))

    @property
    def trivial(self) -> bool:
        """Whether every class is one value (the group tells every context apart)."""
        return all(len(m) == len(o) for m, o in zip(self.members, self.of, strict=True))

    def index(self, codes: Sequence[int]) -> int:
        """The class context (mixed radix, first feature most significant) of the home's codes."""
        out = 0
        for f, k in enumerate(codes[: len(self.of)]):
            out = out * len(self.members[f]) + self.of[f][k]
        return out

    def indices(self, codes: np.ndarray) -> np.ndarray:
        """:meth:`index` of many rows of the home's feature codes at once."""
        out = np.zeros(len(codes), dtype=np.int64)
        for f, of in enumerate(self.of):
            out = out * len(self.members[f]) + np.asarray(of, dtype=np.int64)[codes[:, f]]
        return out

    def weights(self) -> np.ndarray:
        """Per class context, how many of the home's contexts it stands for."""
        out = np.ones(1, dtype=np.int64)
        for members in self.members:
            out = np.outer(out, [len(m) for m in members]).reshape(-1)
        return out

    def of_contexts(self, home: Home) -> np.ndarray:
        """The class context of each of the home's contexts, in the home's context order."""
        radix = [f.radix for f in home.features]
        codes = np.stack(np.unravel_index(np.arange(home.context_count), radix), axis=1)
        return self.indices(codes)

    def condition(self, cond: Condition) -> Condition:
        """A condition of the home over the classes (each allowed set is a union of classes)."""
        return Condition(
            features=tuple((f, frozenset(self.of[f][k] for k in allowed)) for f, allowed in cond.features),
            devices=cond.devices,
        )


def _conditions(home: Home, devices: Iterable[int], services: Iterable[int]) -> list[Condition]:
    out = [rule.when for d in devices for rule in home.comfort[d]]
    for a in services:
        out += list(home.needs[a]) + list(home.prohibited[a])
    return out


def classes_of(home: Home, devices: Sequence[int], services: Sequence[int]) -> Classes:
    """The classes of the contexts for the rules of these devices and services (see the module)."""
    devices, services = tuple(devices), tuple(services)
    key = (home.content_hash, devices, services)
    if home.content_hash and key in _CACHE:
        return _CACHE[key]
    signature: list[list[list[bool]]] = [[[] for _ in f.values] for f in home.features]
    for cond in _conditions(home, devices, services):
        for f, allowed in cond.features:
            for k in range(home.features[f].radix):
                signature[f][k].append(k in allowed)
    of, members = [], []
    for per_value in signature:
        seen: dict[tuple[bool, ...], int] = {}
        codes = [seen.setdefault(tuple(s), len(seen)) for s in per_value]
        of.append(tuple(codes))
        members.append(tuple(tuple(k for k, c in enumerate(codes) if c == i) for i in range(len(seen))))
    found = Classes(of=tuple(of), members=tuple(members))
    if home.content_hash:
        if len(_CACHE) >= 4096:
            _CACHE.clear()
        _CACHE[key] = found
    return found


def home_classes(home: Home) -> Classes:
    """The classes of contexts no rule of the home tells apart: every group's classes are unions
    of them, so what holds per group can be summed over them instead of over every context."""
    return classes_of(home, range(len(home.devices)), range(len(home.services)))


def representatives(classes: Classes) -> np.ndarray:
    """The home's codes of the first context of each class context, in class-context order."""
    codes = np.stack(np.unravel_index(np.arange(classes.count), classes.radices), axis=1)
    firsts = [np.array([m[0] for m in members], dtype=np.int64) for members in classes.members]
    return np.stack([firsts[f][codes[:, f]] for f in range(len(firsts))], axis=1).reshape(-1, len(firsts))


def group_classes(home: Home, group: object) -> Classes:
    """:func:`classes_of` a group (its devices and services, as positions in the home)."""
    return classes_of(home, group.device_index, group.service_index)  # type: ignore[attr-defined]
