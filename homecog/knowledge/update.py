"""How one sample row changes the clusters of a service node (the paper's Algorithm 2).

``paper`` mode: one cluster per node, updated exactly as Algorithm 2 (a sample that marks a
dimension unrelated makes it unrelated for good; values collect; readings update mean and
range). ``multi`` mode: the node keeps boxes; a row joins a box that covers it, or merges with a
box one dimension away (their union is a box), or starts a box.

Functions over the tree's data (:class:`~homecog.knowledge.tree.Tree`); ``learn_one`` and
``learn_many`` of :class:`~homecog.knowledge.ihdr.IHDRTree` decide which rows to learn.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from homecog.knowledge.model import Condition, Node, Numeric, bits, box_size

if TYPE_CHECKING:
    from homecog.knowledge.tree import Tree


class SampleRow(NamedTuple):
    """A sample row as a service node learns it: ``codes`` on the dimensions of ``mask`` (or, on
    a dimension of ``sets``, multi mode, every value of its set), the ``readings``, how many
    samples it stands for (``n``) and the sum of the service's positions in them (``pos_sum``);
    ``stats``, per numeric dimension, the sum, least and greatest reading of those samples
    (``None``: one sample, its ``readings``)."""

    mask: int
    codes: tuple[int, ...]
    readings: tuple[float | None, ...]
    n: int
    pos_sum: float
    stats: dict[int, tuple[float, float, float]] | None = None
    sets: dict[int, frozenset[int]] | None = None


def learn_row(t: Tree, a: int, row: SampleRow) -> None:
    """Learn a sample row into service ``a``."""
    node = t.all_services()[a]
    t.version += 1  # what users' layers take as prior may change
    for target in (node, node.parent):
        assert target is not None
        target.count += row.n
        target.position_sum += row.pos_sum
    if t.mode == "paper":
        for target in (node, node.parent):
            _algorithm2(t, target, row)  # type: ignore[arg-type]
    else:
        _merge_box(t, node, row)


def _algorithm2(t: Tree, node: Node, row: SampleRow) -> None:
    """Algorithm 2, step 3: update the node's one cluster with a sample row."""
    dims = t.space.dims
    if not node.clusters:  # step 1: the first sample makes the cluster
        conditions: dict[int, Condition] = {}
        for j in range(len(dims)):
            if row.mask >> j & 1:
                conditions[j] = _numeric(j, row) if dims[j].numeric else frozenset([row.codes[j]])
        node.clusters.append(t.new_cluster(conditions))
    else:
        cluster = node.clusters[0]
        for j in list(cluster.conditions):
            cond = cluster.conditions[j]
            if not row.mask >> j & 1:  # step 3.3: unrelated in this sample: unrelated for good
                del cluster.conditions[j]
            elif isinstance(cond, Numeric):  # step 3.4
                if row.stats is not None and j in row.stats:
                    total, low, high = row.stats[j]
                    cond.add(float(row.readings[j] or 0.0), row.n, total, low, high)
                else:
                    cond.add(float(row.readings[j]))  # type: ignore[arg-type]
            else:  # step 3.5
                cluster.conditions[j] = cond | {row.codes[j]}
    node.clusters[0].count += row.n


def _numeric(j: int, row: SampleRow) -> Numeric:
    if row.stats is not None and j in row.stats:
        total, low, high = row.stats[j]
        return Numeric(count=row.n, total=float(total), low=float(low), high=float(high))
    x = float(row.readings[j])  # type: ignore[arg-type]
    return Numeric(count=1, total=x, low=x, high=x)


def _merge_box(t: Tree, node: Node, row: SampleRow) -> None:
    """Multi mode: join a covering box, merge with a box one dimension away, or start one."""
    mask, codes, n, pos_sum, sets = row.mask, row.codes, row.n, row.pos_sum, row.sets or {}
    index = t.index[node.id]
    dims = bits(mask)
    values = [sets.get(j) or frozenset([codes[j]]) for j in dims]
    hit = index.covering_box(mask, values) if sets else index.covering(mask, tuple(codes[j] for j in dims))
    if hit is not None:
        hit.count += n
        hit.position_sum += pos_sum
        return
    box = t.new_cluster(dict(zip(dims, values, strict=True)), count=n, position_sum=pos_sum)
    index.point_to(box, box.conditions, mask)
    while True:
        keys = index.partner_keys(box, mask)
        partner = index.partner(box, keys)
        if partner is None:
            break
        index.unlink(partner)
        node.clusters.remove(partner)
        merged = {j: box.conditions[j] | partner.conditions[j] for j in box.conditions}  # type: ignore[operator]
        # the union takes the partner's identity; of the two objects, the one with more
        # points keeps them, and only the other's points are pointed at it
        keep, other = (partner, box) if box_size(partner) >= box_size(box) else (box, partner)
        index.point_to(keep, other.conditions, mask)
        keep.id, keep.seq = partner.id, partner.seq
        keep.conditions = merged
        keep.count = box.count + partner.count
        keep.position_sum = box.position_sum + partner.position_sum
        box = keep
    node.clusters.append(box)
    index.link(box, keys)
    t.changed()
