"""A stream's answer: the keys' cells mixed by their posterior weights, sleeping experts.

In a stream the probability that a service is wanted is averaged over the keys by their
posterior weights (each key's prequential log loss), each key saying its cell's share (with
half an example of each label). A key whose cell here holds no example has nothing to say and
sleeps: the keys that know the cell share the weight, in proportion to theirs (sleeping experts,
Freund et al., "Using and combining predictors that specialize", STOC 1997), so a key that never
saw this moment does not pull the answer to ½; where no key knows it (no example yet), ½. The
key of the most weight among those awake and its cell explain it.

>>> keys, cells = [(), (0,)], [lambda a: (), lambda a: a[:1]]
>>> tables = [{(): [3, 1, 1]}, {("sofa",): [3, 0, 1]}]
>>> d = mixed(keys, tables, cells, [2.0, 1.0], [1, 0], ("sofa",), 0.5)
>>> d.sign, d.key, round(d.share, 3)
(1, (0,), 0.828)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from homecog.knowledge.cuts import kt_share
from homecog.knowledge.keys import Atom, Decision, Key, sign_of


def mixed(
    keys: Sequence[Key],
    tables: Sequence[dict[tuple[Atom, ...], list[int]]],
    cell_of: Sequence[Callable[[tuple[Atom, ...]], tuple[Atom, ...]]],
    preq: Sequence[float],
    ranked: Sequence[int],
    atoms: tuple[Atom, ...],
    threshold: float,
) -> Decision:
    """The mixed answer at ``atoms``: ``ranked`` are the keys' positions, the most weight
    (least prequential loss ``preq``) first; ``tables`` their cells' counts [wanted, unwanted,
    latest]."""
    first, explain, total, share = 0.0, None, 0.0, 0.0
    for k, i in enumerate(ranked):
        # the keys left weigh at most exp(first − their loss) each: once all of them together
        # could not move the answer by 10⁻⁹, they are not read
        if explain is not None and (len(ranked) - k) * math.exp(first - preq[i] + 1e-6) < 1e-9 * total:
            break
        counts = tables[i].get(cell_of[i](atoms))
        if counts is None:
            continue
        if explain is None:
            first, explain = preq[i], (i, counts)
        w = math.exp(first - preq[i])
        total += w
        share += w * kt_share(counts)
    if explain is None:
        return Decision(sign_of(0.5, threshold, 0), (), (), 0, 0, threshold)
    i, (p, n, last) = explain
    share /= total
    return Decision(sign_of(share, threshold, last), keys[i], cell_of[i](atoms), p, n, threshold, share)
