"""The ground truth of a context: the sets of services that take it to its
optimum in the fewest services — the services of a sequence in which each service is progress
(the distance falls, and no device that was as wanted is switched away from it) and none is
prohibited.

No service of one independent group (:mod:`homecog.home.groups`) changes another group's
devices or needs, or is forbidden by them, so a set is optimal exactly when its part in every
group is optimal for that group: the search runs group by group and its cost grows with the
number of devices, not with 2^devices. The optimal sets of the home are the products of the
groups' sets, with scenes in the place of the services they do the work of
(:func:`homecog.home.scenes.compose`).

In the den of ``tests/homes/den.yaml`` (the example of :mod:`homecog.home.scenes`), with someone
there, the hood and the speaker on and the lamp off:

>>> from homecog.home import load_home
>>> home = load_home("tests/homes/den.yaml")
>>> codes, states = home.discretize({"who": "someone", "hood": "on", "speaker": "on", "lamp": "off"})
>>> [sorted(s) for s in optimal_service_sets(home, codes, states)]
[['AllQuiet', 'LampOn']]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from homecog.home.groups import Group, device_groups
from homecog.home.model import Home
from homecog.home.scenes import compose, covered_by, device_positions

Choice = tuple[frozenset[int], ...]  # a group's optimal sets of service positions, best first


def _key(home: Home, chosen: frozenset[int]) -> tuple[int, int, tuple[int, ...]]:
    return (len(chosen), sum(len(home.services[a].sets) for a in chosen), tuple(sorted(chosen)))


def group_choices(
    home: Home,
    group: Group,
    codes: Sequence[int],
    states: Sequence[bool],
    limit: int = 256,
    *,
    wanted: Sequence[bool | None] | None = None,
    needed: Sequence[int] | None = None,
) -> Choice:
    """The optimal sets of one group's services: the smallest (then fewest devices set, then
    service order first); where the rules leave no way, one setter per wrong device, without
    order. ``wanted`` and ``needed`` (the home's, for this context) are computed when not given."""
    wanted = home.wanted(codes) if wanted is None else wanted
    needed = home.needs_of(codes) if needed is None else needed
    needs = frozenset(a for a in needed if a in group.service_index)
    mine = group.device_index  # the search runs over the group's devices only
    local = {d: k for k, d in enumerate(mine)}
    index = device_positions(home)
    search = _Search(
        want=[wanted[d] for d in mine],
        effects={
            a: tuple((local[index[d]], v) for d, v in home.services[a].sets) for a in group.service_index
        },
        # each service's prohibited rules: those whose context part matches, as (device, allowed) pairs
        rules={
            a: [
                tuple((local[d], allowed) for d, allowed in cond.devices)
                for cond in home.prohibited[a]
                if all(codes[f] in allowed for f, allowed in cond.features)
            ]
            for a in group.service_index
        },
        limit=limit,
    )
    start = tuple(bool(states[d]) for d in mine)
    found = search.paths(start, needs) or search.fallback(start, needs)
    fewest = min(len(c) for c in found)
    return tuple(sorted((c for c in found if len(c) == fewest), key=lambda c: _key(home, c)))


Effect = tuple[tuple[int, bool], ...]  # (device, state) pairs, by the group's device positions


@dataclass
class _Search:
    """The search for one group's optimal sets in one context: every sequence of services in
    which each is progress, none is prohibited and the needed ones are done, as sets."""

    want: list[bool | None]
    effects: dict[int, Effect]
    rules: dict[int, list[tuple[tuple[int, Any], ...]]]
    limit: int
    memo: dict[tuple[tuple[bool, ...], frozenset[int]], set[frozenset[int]]] = field(default_factory=dict)

    def forbidden(self, a: int, st: tuple[bool, ...]) -> bool:
        return any(all(st[k] in allowed for k, allowed in rule) for rule in self.rules[a])

    def distance(self, st: tuple[bool, ...], pending: frozenset[int]) -> int:
        return sum(1 for k, w in enumerate(self.want) if w is not None and st[k] != w) + len(pending)

    def paths(self, st: tuple[bool, ...], pending: frozenset[int]) -> set[frozenset[int]]:
        """The sets that take ``st`` to the optimum with the ``pending`` needs done."""
        key = (st, pending)
        if key in self.memo:
            return self.memo[key]
        d = self.distance(st, pending)
        out: set[frozenset[int]] = {frozenset()} if d == 0 else set()
        for a, effect in self.effects.items():
            if d == 0 or len(out) >= self.limit or self.forbidden(a, st):
                continue
            st2, pend2 = _apply(st, pending, a, effect)
            # every device switched must have been wrong (see kernels.progressed)
            broke = any(y != x and (w is None or x == w) for x, y, w in zip(st, st2, self.want, strict=True))
            if self.distance(st2, pend2) < d and not broke:
                out |= {rest | {a} for rest in self.paths(st2, pend2)}
        self.memo[key] = out
        return out

    def fallback(self, start: tuple[bool, ...], needs: frozenset[int]) -> set[frozenset[int]]:
        """Where conflicting rules leave no way: one setter per wrong device, no order."""
        chosen = set(needs)
        for k, w in enumerate(self.want):
            if w is not None and start[k] != w:
                setter = next((a for a, e in self.effects.items() if (k, w) in e), None)
                if setter is not None:
                    chosen.add(setter)
        return {frozenset(chosen)}


def _apply(
    st: tuple[bool, ...], pending: frozenset[int], a: int, effect: Effect
) -> tuple[tuple[bool, ...], frozenset[int]]:
    """The states and pending needs after service ``a``: it switches, or it is a need done."""
    if not effect:
        return st, pending - {a}
    nxt = list(st)
    for k, value in effect:
        nxt[k] = value
    return tuple(nxt), pending


def choices(home: Home, codes: Sequence[int], states: Sequence[bool], limit: int = 256) -> list[Choice]:
    """:func:`group_choices` of every group with services, in group order."""
    wanted, needed = home.wanted(codes), home.needs_of(codes)
    return [
        group_choices(home, g, codes, states, limit, wanted=wanted, needed=needed)
        for g in device_groups(home)
        if g.services
    ]


def composed(
    home: Home, codes: Sequence[int], states: Sequence[bool], chosen: frozenset[int]
) -> frozenset[int]:
    """A union of the groups' optimal sets with scenes in the place of the services they do the
    work of (:func:`homecog.home.scenes.compose`)."""
    return frozenset(compose(home, codes, states, sorted(chosen)))


def optimal_service_sets(
    home: Home, codes: Sequence[int], states: Sequence[bool], limit: int = 256
) -> list[frozenset[str]]:
    """Every optimal set of the home (at most ``limit``), best first as in :func:`group_choices`:
    the groups' sets combined, scenes composed, the fewest services kept."""
    per_group = choices(home, codes, states, limit)
    fixed = frozenset().union(*(c[0] for c in per_group if len(c) == 1))
    open_ = [c for c in per_group if len(c) > 1]
    combos = {
        composed(home, codes, states, fixed.union(*parts))
        for parts in itertools.islice(itertools.product(*open_), limit)
    }
    fewest = min(len(c) for c in combos)
    ranked = sorted((c for c in combos if len(c) == fewest), key=lambda c: _key(home, c))
    return [frozenset(home.services[a].name for a in c) for c in ranked]


@dataclass(frozen=True)
class TruthChoices:
    """A context's optimal sets where more than one is optimal: per group with several, its
    sets (the canonical first); and the canonical union of every group's, before scenes.
    :meth:`pick` gives the optimal set that agrees best with an answer — most services in
    common, then fewest differences — over every combination of the groups' sets with the
    scenes composed (where there are at most 256; beyond, group by group, a scene of the answer
    counting for the services it does)."""

    home: Home
    codes: tuple[int, ...]
    states: tuple[bool, ...]
    groups: tuple[tuple[frozenset[int], ...], ...]
    base: frozenset[int]

    def pick(self, predicted: Sequence[str]) -> frozenset[str]:
        names = self.home.service_names
        said = set(predicted)

        def agreement(t: frozenset[str]) -> tuple[int, int]:
            return len(said & t), -len(t ^ said)

        combos = math.prod(len(options) for options in self.groups)
        if combos <= 256:  # every combination, scenes composed: the best exactly
            best = max(
                (
                    frozenset(
                        names[a] for a in composed(self.home, self.codes, self.states, self._union(parts))
                    )
                    for parts in itertools.product(*self.groups)
                ),
                key=agreement,
            )
            return best
        covered = covered_by(self.home)
        said |= {s for s in covered if covered[s] & said}
        out = set(self.base)
        for options in self.groups:
            named = [frozenset(names[a] for a in t) for t in options]
            best_i = max(range(len(options)), key=lambda i: agreement(named[i]))
            out = (out - options[0]) | options[best_i]
        return frozenset(names[a] for a in composed(self.home, self.codes, self.states, frozenset(out)))

    def _union(self, parts: Sequence[frozenset[int]]) -> frozenset[int]:
        out = set(self.base)
        for options, part in zip(self.groups, parts, strict=True):
            out = (out - options[0]) | part
        return frozenset(out)


def truth_with_choices(
    home: Home, codes: Sequence[int], states: Sequence[bool]
) -> tuple[frozenset[str], TruthChoices | tuple[()]]:
    """The canonical optimal set of a context and, where several are optimal, the choices."""
    per_group = choices(home, codes, states)
    base = frozenset().union(*(c[0] for c in per_group)) if per_group else frozenset()
    chosen = composed(home, codes, states, base)
    truth = frozenset(home.services[a].name for a in chosen)
    several = tuple(c for c in per_group if len(c) > 1)
    if not several:
        return truth, ()
    return truth, TruthChoices(home, tuple(codes), tuple(bool(x) for x in states), several, base)
