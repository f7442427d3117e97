"""The rules of a home as NumPy tables, evaluated over every context once.

Per context: the devices a comfort rule cares about and their wanted states, the position of
each need; per service: the devices it sets; prohibited rules as a context mask and device
bits. The kernels (:mod:`homecog.environment.kernels`) read nothing else.

>>> from homecog.home import load_home
>>> t = build_tables(load_home("paper"))
>>> t.n_devices, len(t.care), int(t.offsets[-1])
(8, 2592, 1410048)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from homecog.home.model import Condition, Home


class Tables(NamedTuple):
    """The rules of a home as arrays, for the kernels."""

    n_devices: int
    need_count: np.ndarray  # int64[C]: number of needs of each context
    offsets: np.ndarray  # int64[C + 1]: first state index of each context
    care: np.ndarray  # int64[C]: bit d set when a comfort rule cares about device d
    want: np.ndarray  # int64[C]: wanted device bits (where cared)
    need_pos: np.ndarray  # int64[C, A]: local need bit of service a in context c, or -1
    set_mask: np.ndarray  # int64[A]: devices a service sets
    set_val: np.ndarray  # int64[A]: the states it sets them to
    prohibited_ctx: np.ndarray  # bool[C, A]: prohibited whatever the devices
    rule_start: np.ndarray  # int64[A + 1]: device-state prohibited rules of service a
    rule_ctx: np.ndarray  # bool[R, C]: the context part of each rule matches
    rule_mask: np.ndarray  # int64[R]: devices the rule constrains
    rule_val: np.ndarray  # int64[R]: the states it requires
    weights: np.ndarray  # float64[4]: terminal, progress, prohibited weights; magnitude


def condition_contexts(codes: np.ndarray, cond: Condition) -> np.ndarray:
    """Boolean mask over all contexts where the feature part of a condition matches."""
    match = np.ones(len(codes), dtype=bool)
    for f, allowed in cond.features:
        match &= np.isin(codes[:, f], sorted(allowed))
    return match


def _device_bits(cond: Condition) -> tuple[int, int]:
    """(mask, value) of the devices a condition pins to one state."""
    mask = val = 0
    for d, allowed in cond.devices:
        if len(allowed) == 1:
            mask |= 1 << d
            if True in allowed:
                val |= 1 << d
    return mask, val


def build_tables(home: Home) -> Tables:
    """Evaluate every rule of a home over all its contexts."""
    n_contexts = home.context_count
    radix = [f.radix for f in home.features]
    codes = np.stack(np.unravel_index(np.arange(n_contexts), radix), axis=1).astype(np.int64)
    care, want = _comfort(home, codes)
    need_pos, need_count = _needs(home, codes)
    set_mask, set_val = _settings(home)
    prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val = _prohibitions(home, codes)
    per_context = (np.int64(1) << len(home.devices)) << need_count
    offsets = np.concatenate([[0], np.cumsum(per_context)]).astype(np.int64)
    return Tables(
        n_devices=len(home.devices),
        need_count=need_count,
        offsets=offsets,
        care=care,
        want=want,
        need_pos=need_pos,
        set_mask=set_mask,
        set_val=set_val,
        prohibited_ctx=prohibited_ctx,
        rule_start=rule_start,
        rule_ctx=rule_ctx,
        rule_mask=rule_mask,
        rule_val=rule_val,
        weights=np.array(home.rewards.as_list(), dtype=np.float64),
    )


def _comfort(home: Home, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per context, the devices a comfort rule cares about and their wanted states (the first
    rule of a device that matches decides)."""
    care = np.zeros(len(codes), dtype=np.int64)
    want = np.zeros(len(codes), dtype=np.int64)
    for d, rules in enumerate(home.comfort):
        decided = np.zeros(len(codes), dtype=bool)
        for rule in rules:
            hit = condition_contexts(codes, rule.when) & ~decided
            care[hit] |= 1 << d
            if rule.want:
                want[hit] |= 1 << d
            decided |= hit
    return care, want


def _needs(home: Home, codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per context and service, the need bit of the service there (−1: not needed); per context,
    how many needs it has."""
    need_pos = np.full((len(codes), len(home.services)), -1, dtype=np.int64)
    need_count = np.zeros(len(codes), dtype=np.int64)
    for a, rules in enumerate(home.needs):
        needed = np.zeros(len(codes), dtype=bool)
        for cond in rules:
            needed |= condition_contexts(codes, cond)
        need_pos[needed, a] = need_count[needed]
        need_count[needed] += 1
    return need_pos, need_count


def _settings(home: Home) -> tuple[np.ndarray, np.ndarray]:
    """Per service, the devices it sets and the states it sets them to, as bits."""
    set_mask = np.zeros(len(home.services), dtype=np.int64)
    set_val = np.zeros(len(home.services), dtype=np.int64)
    for a, service in enumerate(home.services):
        for device, state in service.sets:
            d = home.device_index(device)
            set_mask[a] |= 1 << d
            if state:
                set_val[a] |= 1 << d
    return set_mask, set_val


def _prohibitions(home: Home, codes: np.ndarray) -> tuple[np.ndarray, ...]:
    """The prohibited rules: (prohibited_ctx, rule_start, rule_ctx, rule_mask, rule_val) of
    :class:`Tables`."""
    n_contexts = len(codes)
    prohibited_ctx = np.zeros((n_contexts, len(home.services)), dtype=bool)
    rule_start, rule_ctx, rule_mask, rule_val = [0], [], [], []
    for a, rules in enumerate(home.prohibited):
        for cond in rules:
            ctx = condition_contexts(codes, cond)
            mask, val = _device_bits(cond)
            if mask == 0:
                prohibited_ctx[ctx, a] = True
            else:
                rule_ctx.append(ctx)
                rule_mask.append(mask)
                rule_val.append(val)
        rule_start.append(len(rule_mask))
    return (
        prohibited_ctx,
        np.asarray(rule_start, dtype=np.int64),
        np.asarray(rule_ctx, dtype=bool).reshape(len(rule_mask), n_contexts),
        np.asarray(rule_mask, dtype=np.int64),
        np.asarray(rule_val, dtype=np.int64),
    )
