"""A plain reference of the environment, written from the Home model's rule methods only.

The vectorized core is checked against it: they share no code but the Home.
"""

from __future__ import annotations

from homecog.home import Home


def reference_step(
    home: Home, codes: tuple[int, ...], states: tuple[bool, ...], pending: frozenset[str], service: str
) -> tuple[tuple[bool, ...], frozenset[str], float, bool]:
    """(states', pending', reward, terminated): Eq. 1, where progress means the distance fell
    and every device switched was not as wanted, and a step that brings the distance to 0
    without being progress earns no terminal reward."""
    wanted = home.wanted(codes)

    def dist(st: tuple[bool, ...], pend: frozenset[str]) -> int:
        return sum(1 for s, w in zip(st, wanted, strict=True) if w is not None and s != w) + len(pend)

    svc = home.services[home.service_index(service)]
    new_states = list(states)
    for device, value in svc.sets:
        new_states[home.device_index(device)] = value
    new_pending = pending - {service}
    before, after = dist(states, pending), dist(tuple(new_states), new_pending)
    switched = [d for d, (a, b) in enumerate(zip(states, new_states, strict=True)) if a != b]
    progress = after < before and all(wanted[d] is not None and states[d] != wanted[d] for d in switched)
    w, m = home.rewards.weights, home.rewards.magnitude
    reward = w.progress * (m if progress else -m)
    if after == 0 and (progress or before == 0):
        reward += w.terminal * m
    if home.is_prohibited(home.service_index(service), codes, states):
        reward -= w.prohibited * m
    return tuple(new_states), new_pending, reward, after == 0


def reference_distance(
    home: Home, codes: tuple[int, ...], states: tuple[bool, ...], pending: frozenset[str]
) -> int:
    wanted = home.wanted(codes)
    return sum(1 for s, w in zip(states, wanted, strict=True) if w is not None and s != w) + len(pending)


def parse_hardware_code(code: str) -> tuple[bool, ...]:
    """Device states from the paper's notation (1 = on/open, 2 = off/closed, Table 4): the
    inverse of :func:`homecog.home.encoding.hardware_code`."""
    if any(ch not in "12" for ch in code):
        raise ValueError(f"hardware code {code!r} must consist of 1 (on) and 2 (off)")
    return tuple(ch == "1" for ch in code)
