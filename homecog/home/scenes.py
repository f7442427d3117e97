"""Scenes: one service that sets many devices at once, across rooms (all lights off, leaving,
good night), as a shortcut for the services of one device each that make it up.

A *scene* is a service that sets two or more devices, each to a state that some service of one
device also sets it to, and whose prohibited rules name no device state. It ties nothing: the
groups of :mod:`homecog.home.groups` come from the other services, and each group learns the
scene's part of it as the services of the group that do the same. A scene whose devices all lie
in one group is an ordinary service of that group.

A plan — the services the groups' roll-outs (or their knowledge) chose — becomes the home's plan
by :func:`compose`: a scene takes the place of the planned services it does the work of, where

1. it is not prohibited in the context;
2. every device it switches ends as the plan leaves it (so it switches nothing against the
   wishes, and nothing the household does not care about); a device it sets as it already is
   may still be switched later in the plan;
3. no other planned service also switches a device it switches, and, with the scenes done
   first, the other planned services of each group still have an order in which none is
   prohibited;
4. it does the work of two services or more; two scenes that set a device differently are
   never taken together.

Among the scenes that qualify, the fewest services win (then the fewest devices set, then the
scenes' order in the home), so the optimum is reached in the fewest services; the scenes come
first in the plan. The same function turns the groups' ground truth into the home's, the groups'
roll-outs into the home's roll-out and the tree's answers into the robot's: each is exact when
its groups are.

In the den of ``tests/homes/den.yaml`` the hood and the speaker are wanted off, the lamp on when
someone is there; AllQuiet switches the hood and the speaker off at once:

>>> from homecog.home import load_home
>>> home = load_home("tests/homes/den.yaml")
>>> [home.services[a].name for a in scene_services(home)]
['AllQuiet']
>>> names = lambda plan: [home.services[a].name for a in plan]
>>> names(compose(home, (1,), (True, True, False), [0, 1, 2]))       # hood, speaker on; lamp off
['AllQuiet', 'LampOn']
>>> names(compose(home, (1,), (True, False, False), [0, 2]))         # one service's work: no scene
['HoodOff', 'LampOn']
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

from homecog.home.groups import group_of_service
from homecog.home.model import Home

#: Candidate scenes of one connected set searched exhaustively; beyond, one at a time, best first.
EXACT_LIMIT = 12
#: Most services of one group whose orders are searched (a group's plan is a few services).
ORDER_LIMIT = 16

_CACHE: dict[str, tuple[int, ...]] = {}
_POSITIONS: dict[str, dict[str, int]] = {}


def device_positions(home: Home) -> dict[str, int]:
    """Device name -> position in the home, made once per home."""
    key = home.content_hash or str(id(home))
    if key not in _POSITIONS:
        if len(_POSITIONS) >= 64:
            _POSITIONS.clear()
        _POSITIONS[key] = {d.name: i for i, d in enumerate(home.devices)}
    return _POSITIONS[key]


def scene_candidates(home: Home) -> tuple[int, ...]:
    """Services that are scenes by their own action model (before the groups are known): two or
    more devices, each set to a state a one-device service also sets, no device-state rule."""
    singles = {pair for s in home.services if len(s.sets) == 1 for pair in s.sets}
    return tuple(
        a
        for a, s in enumerate(home.services)
        if len(s.sets) >= 2
        and all(pair in singles for pair in s.sets)
        and not any(cond.devices for cond in home.prohibited[a])
    )


def scene_services(home: Home) -> tuple[int, ...]:
    """Positions of the home's scenes: the candidates whose devices lie in more than one group."""
    key = home.content_hash
    if key and key in _CACHE:
        return _CACHE[key]
    owner = group_of_service(home)
    found = tuple(a for a in scene_candidates(home) if owner[a] < 0)
    if key:
        if len(_CACHE) >= 64:
            _CACHE.clear()
        _CACHE[key] = found
    return found


@dataclass(frozen=True)
class _Option:
    scene: int
    switches: dict[int, bool]  # devices it switches, to what
    sets: dict[int, bool]  # every device it sets
    work: frozenset[int]  # planned services it takes the place of
    on: int  # the devices it sets on, as bits
    off: int  # the devices it sets off, as bits


class _Plan:
    """A plan's services with what each does from the start state, for :func:`compose`."""

    def __init__(self, home: Home, codes: Sequence[int], states: Sequence[bool], plan: Sequence[int]) -> None:
        self.home, self.codes, self.states, self.plan = home, codes, states, list(plan)
        index = device_positions(home)
        self.index = index
        self.effects = {a: [(index[d], v) for d, v in home.services[a].sets] for a in self.plan}
        self.final: dict[int, bool | None] = {}
        for a in self.plan:
            for d, v in self.effects[a]:
                if states[d] != v:
                    self.final[d] = v if self.final.get(d, v) == v else None  # both ways: unknown
        self.changes = {a: frozenset(d for d, v in self.effects[a] if states[d] != v) for a in self.plan}
        self.reads = {a: frozenset(d for c in home.prohibited[a] for d, _ in c.devices) for a in self.plan}
        self.changer: dict[int, list[int]] = {}  # device -> the planned services that switch it
        for a in self.plan:
            for d in self.changes[a]:
                self.changer.setdefault(d, []).append(a)

    def option(self, x: int) -> _Option | None:
        home = self.home
        if x in self.effects or any(cond.matches(self.codes) for cond in home.prohibited[x]):
            return None
        sets = {self.index[d]: v for d, v in home.services[x].sets}
        switches = {d: v for d, v in sets.items() if self.states[d] != v}
        if any(self.final.get(d, self.states[d]) != v for d, v in switches.items()):
            return None  # rule 2
        touching = {a for d in switches for a in self.changer.get(d, ())}
        work = frozenset(a for a in touching if self.changes[a] <= switches.keys())
        if len(work) < 2 or len(work) < len(touching):
            return None  # rules 4 and 3: two services' work or more, and no other switching its devices
        on = sum(1 << d for d, v in sets.items() if v)
        off = sum(1 << d for d, v in sets.items() if not v)
        return _Option(scene=x, switches=switches, sets=sets, work=work, on=on, off=off)

    def order(self, chosen: Sequence[_Option]) -> list[int] | None:
        """The plan with ``chosen`` first, then the rest in the plan's order, except in the groups
        whose services' prohibited rules name a device the scenes switch: those in the first
        order (the plan's own where it can) in which none is prohibited; None where one of them
        has none."""
        done = frozenset().union(*(o.work for o in chosen))
        rest = [a for a in self.plan if a not in done]
        switched = frozenset().union(*(o.switches.keys() for o in chosen))
        state = list(self.states)
        for o in chosen:
            for d, v in o.switches.items():
                state[d] = v
        owner = group_of_service(self.home)
        touched = {owner[a] for a in rest if self.reads[a] & switched}
        for g in touched:
            mine = [a for a in rest if owner[a] == g]
            ordered = _valid_order(self.home, self.codes, state, mine, self.effects)
            if ordered is None:
                return None
            slots = iter(ordered)
            rest = [next(slots) if owner[a] == g else a for a in rest]
        return [o.scene for o in sorted(chosen, key=lambda o: o.scene)] + rest


def compose(home: Home, codes: Sequence[int], states: Sequence[bool], plan: Sequence[int]) -> list[int]:
    """The plan with scenes in the place of the services they do the work of (see the module),
    the scenes first."""
    return composition(home, codes, states, plan)[0]


def composition(
    home: Home, codes: Sequence[int], states: Sequence[bool], plan: Sequence[int]
) -> tuple[list[int], dict[int, tuple[int, ...]]]:
    """:func:`compose`, and per scene taken the planned services it takes the place of."""
    scenes = scene_services(home)
    if not scenes or len(plan) < 2:
        return list(plan), {}
    view = _Plan(home, codes, states, plan)
    options = [o for o in (view.option(x) for x in scenes) if o is not None]
    chosen = _best(view, options) if options else []
    if not chosen:
        return list(plan), {}
    order = view.order(chosen)
    assert order is not None  # _best keeps only scenes that fit
    done: set[int] = set()
    work = {}
    for o in sorted(chosen, key=lambda o: o.scene):
        work[o.scene] = tuple(a for a in plan if a in o.work and a not in done)
        done |= o.work
    return order, work


def _clash(a: _Option, b: _Option) -> bool:
    return bool((a.on & b.off) | (a.off & b.on))


def _cost(chosen: Sequence[_Option]) -> tuple[int, int, tuple[int, ...]]:
    covered = frozenset().union(*(o.work for o in chosen))
    return (
        len(chosen) - len(covered),
        sum(len(o.sets) for o in chosen),
        tuple(sorted(o.scene for o in chosen)),
    )


def _best(view: _Plan, options: list[_Option]) -> list[_Option]:
    """The composed plan of the best scenes: exhaustively over the sets of options that share
    work (up to :data:`EXACT_LIMIT` options each), else one at a time by the most work saved."""
    chosen: list[_Option] = []
    for part in _connected(options):
        if len(part) <= EXACT_LIMIT:
            subsets = [c for r in range(1, len(part) + 1) for c in itertools.combinations(part, r)]
            for c in sorted(subsets, key=lambda c: _cost(c)):
                if _cost(c)[0] >= 0:
                    break
                if _fits(view, [*chosen, *c]):
                    chosen += c
                    break
            continue
        for o in sorted(part, key=lambda o: (-len(o.work), len(o.sets), o.scene)):
            if _cost([*chosen, o]) < _cost(chosen) and _fits(view, [*chosen, o]):
                chosen.append(o)
    return chosen


def _fits(view: _Plan, chosen: Sequence[_Option]) -> bool:
    """No two set a device differently, each changes something the others leave, and the rest
    of the plan still has an order."""
    if any(_clash(a, b) for a, b in itertools.combinations(chosen, 2)):
        return False
    for o in chosen:
        others = frozenset().union(*(p.work for p in chosen if p is not o))
        if o.work <= others:
            return False
    return view.order(chosen) is not None


def _valid_order(
    home: Home,
    codes: Sequence[int],
    state: list[bool],
    rest: list[int],
    effects: dict[int, list[tuple[int, bool]]],
) -> list[int] | None:
    """``rest`` (one group's services) in its own order if none is prohibited so, else the first
    order (depth first over what is done) in which none is; None where there is none, or where
    more than :data:`ORDER_LIMIT` services would have to be searched."""
    st: Sequence[bool] | None = state
    for a in rest:
        st = _after(home, codes, st, a, effects) if st is not None else None
    if st is not None:
        return list(rest)
    if len(rest) > ORDER_LIMIT:
        return None
    return _search_order(home, codes, tuple(state), tuple(rest), effects, set())


def _after(
    home: Home,
    codes: Sequence[int],
    state: Sequence[bool],
    a: int,
    effects: dict[int, list[tuple[int, bool]]],
) -> list[bool] | None:
    """The device states after service ``a``; None where it is prohibited in ``state``."""
    if home.prohibited[a] and home.is_prohibited(a, codes, state):
        return None
    after = list(state)
    for d, v in effects[a]:
        after[d] = v
    return after


def _search_order(
    home: Home,
    codes: Sequence[int],
    state: tuple[bool, ...],
    left: tuple[int, ...],
    effects: dict[int, list[tuple[int, bool]]],
    dead: set[frozenset[int]],
) -> list[int] | None:
    """The first order of ``left`` in which none is prohibited, depth first; ``dead`` holds
    the sets of services left found to have none."""
    if not left:
        return []
    key = frozenset(left)
    if key in dead:
        return None
    for i, a in enumerate(left):
        after = _after(home, codes, state, a, effects)
        if after is None:
            continue
        found = _search_order(home, codes, tuple(after), left[:i] + left[i + 1 :], effects, dead)
        if found is not None:
            return [a, *found]
    dead.add(key)
    return None


def _connected(options: list[_Option]) -> list[list[_Option]]:
    parts: list[list[_Option]] = []
    for o in options:
        joined = [p for p in parts if any(o.work & q.work or _clash(o, q) for q in p)]
        merged = [o, *(q for p in joined for q in p)]
        parts = [p for p in parts if p not in joined] + [sorted(merged, key=lambda q: q.scene)]
    return parts


def covered_by(home: Home) -> dict[str, frozenset[str]]:
    """Per service, the scenes that set each of its devices as it does (what a scene can do the
    work of): for choosing, among several optimal ways, the one an answer with scenes meant."""
    out: dict[str, frozenset[str]] = {}
    scenes = [home.services[x] for x in scene_services(home)]
    for s in home.services:
        if s.sets:
            out[s.name] = frozenset(x.name for x in scenes if set(s.sets) <= set(x.sets))
    return out
