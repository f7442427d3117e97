"""Context encoding: the paper's Table 1 coding and a collision-free context index.

The k-th of n values (1-based) is coded k and normalized (k-1)/(n-1):

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> coded(home.feature("location"), 3)            # dining_table: the 4th of 4
(4, 1.0)
>>> coded(home.feature("temperature"), 1)         # suitable: the 2nd of 3
(2, 0.5)

Discrete contexts are numbered by a mixed-radix code over the features (first
feature most significant), so every context has exactly one index:

>>> codes = (5, 0, 1, 2, 0, 0)
>>> context_index(home, codes), context_codes(home, context_index(home, codes)) == codes
(2232, True)

The paper's Eq. 2, ``sum((num[i] - 1) * 2**i)``, weights every digit by a power of two
although most features have more than two values, so distinct contexts collide
(see docs/design.md).
"""

from __future__ import annotations

from collections.abc import Sequence

from homecog.home.model import Feature, Home


def coded(feature: Feature, k: int) -> tuple[int, float]:
    """The paper's code of the value at 0-based position ``k``: (k+1, k/(n-1))."""
    if not 0 <= k < feature.radix:
        raise ValueError(f"{feature.name}: code {k} out of range 0..{feature.radix - 1}")
    n = feature.radix
    return k + 1, (k / (n - 1) if n > 1 else 0.0)


def radices(home: Home) -> tuple[int, ...]:
    """Number of values of each feature, in feature order."""
    return tuple(f.radix for f in home.features)


def context_index(home: Home, codes: Sequence[int]) -> int:
    """Mixed-radix index of a discrete context, in ``range(home.context_count)``."""
    index = 0
    for radix, k in zip(radices(home), codes, strict=True):
        if not 0 <= k < radix:
            raise ValueError(f"code {k} out of range 0..{radix - 1}")
        index = index * radix + k
    return index


def context_codes(home: Home, index: int) -> tuple[int, ...]:
    """Inverse of :func:`context_index`."""
    if not 0 <= index < home.context_count:
        raise ValueError(f"context index {index} out of range 0..{home.context_count - 1}")
    codes = []
    for radix in reversed(radices(home)):
        index, k = divmod(index, radix)
        codes.append(k)
    return tuple(reversed(codes))


def hardware_code(states: Sequence[bool]) -> str:
    """Device states in the paper's notation: 1 = on/open, 2 = off/closed (Table 4).

    >>> hardware_code([False, True, False, False, True, False, False, False])
    '21221222'
    """
    return "".join("1" if s else "2" for s in states)
