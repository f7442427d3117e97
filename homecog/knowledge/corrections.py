"""Corrections by the household's members (SPEC §7): a layer of clusters per user.

A correction (context, the services the user wants, user) compares the wanted services with
what the robot would do *for that user*: missing ones are added (+), surplus ones rejected (−),
as clusters of that user and service. The shared tree is never changed by a correction, so
another user's answers stay as they were; a user's most specific matching cluster (ties: the
latest) overrides the shared answer.

A new cluster covers the dimensions of the shared cluster of that service nearest to the
context (they are what matters to it), with the context's values; it is narrowed where it would
cover one of the user's opposite examples, opposite clusters covering the new context are
narrowed in turn (or dropped when made from the very same context: the latest word wins), and
two same-label clusters one dimension away merge unless the union would cover an opposite
example.

>>> from homecog.knowledge.model import Cluster
>>> from homecog.home.codec import Point
>>> layers = UserLayers(n_dims=3)
>>> shared = [Cluster(id=1, conditions={0: frozenset({1}), 2: frozenset({0})})]
>>> layers.add_example("ann", 4, Point((1, 0, 1), (None,) * 3), -1, shared, new_id=100)
>>> layers.match("ann", 4, Point((1, 2, 1), (None,) * 3)).polarity   # the second dimension does not matter
-1
>>> layers.match("kim", 4, Point((1, 2, 1), (None,) * 3)) is None
True
"""

from __future__ import annotations

from collections.abc import Iterator

from homecog.home.codec import Point
from homecog.knowledge.model import Cluster, Condition, Numeric, covers


class UserLayers:
    """Every user's corrections: per user, per service position, their clusters in seq order."""

    def __init__(self, n_dims: int) -> None:
        self.n_dims = n_dims
        self._users: dict[str, dict[int, list[Cluster]]] = {}

    @property
    def users(self) -> list[str]:
        return sorted(self._users)

    def layer(self, user: str) -> dict[int, list[Cluster]]:
        """A user's clusters per service (empty for a user without corrections)."""
        return self._users.get(user, {})

    def set_layer(self, user: str, layer: dict[int, list[Cluster]]) -> None:
        """Replace a user's layer (the store, when another process corrected)."""
        if layer:
            self._users[user] = layer
        else:
            self._users.pop(user, None)

    def add_cluster(self, user: str, service: int, cluster: Cluster) -> None:
        """Append a stored cluster to a user's layer (the store, loading)."""
        self._users.setdefault(user, {}).setdefault(service, []).append(cluster)

    def n_clusters(self, user: str) -> int:
        return sum(len(v) for v in self._users.get(user, {}).values())

    def items(self) -> Iterator[tuple[str, dict[int, list[Cluster]]]]:
        return iter(sorted(self._users.items()))

    def match(self, user: str | None, a: int, p: Point) -> Cluster | None:
        """The user's most specific cluster of service ``a`` matching ``p`` (ties: the latest)."""
        if user is None:
            return None
        best = None
        for cluster in self._users.get(user, {}).get(a, []):
            if cluster.matches(p) and (
                best is None or (len(cluster.conditions), cluster.seq) > (len(best.conditions), best.seq)
            ):
                best = cluster
        return best

    def add_example(
        self, user: str, a: int, p: Point, polarity: int, shared: list[Cluster], *, new_id: int
    ) -> None:
        """Add a user's example of service ``a`` (+1 wanted, −1 not) at ``p`` to their layer,
        generalized where the shared clusters of that service say it may be; ``new_id`` is the
        id a new cluster takes."""
        clusters = self._users.setdefault(user, {}).setdefault(a, [])
        codes = p.codes
        # 1. the features that matter: those of the shared cluster nearest to this context
        dims = self._relevant_dims(shared, p)
        box = {j: frozenset([codes[j]]) for j in dims}
        # 2. never cover an example of the opposite label: add a dimension where they differ
        for other in clusters:
            if other.polarity != polarity and other.seed is not None and covers(box, other.seed):
                box = self._specialize(box, codes, other.seed)
        # 3. clusters of the opposite label that cover this context give way
        for other in list(clusters):
            if other.polarity != polarity and covers(other.conditions, codes):
                if other.seed is None or other.seed == codes:
                    clusters.remove(other)
                else:
                    other.conditions = self._specialize(dict(other.conditions), other.seed, codes)
        # 4. merge with a same-label cluster one dimension away, if nothing opposite falls inside
        seq = 1 + max((c.seq for cs in self._users.get(user, {}).values() for c in cs), default=0)
        new = Cluster(
            id=new_id,
            conditions=box,
            count=1,
            user=user,
            polarity=polarity,  # type: ignore[arg-type]
            seed=codes,
            seq=seq,
        )
        opposite = [o.seed for o in clusters if o.polarity != polarity and o.seed is not None]
        for other in clusters:
            if other.polarity != polarity or other.conditions.keys() != new.conditions.keys():
                continue
            differ = [j for j in new.conditions if new.conditions[j] != other.conditions[j]]
            if len(differ) == 1:
                merged = {j: new.conditions[j] | other.conditions[j] for j in new.conditions}  # type: ignore[operator]
                if not any(covers(merged, s) for s in opposite):
                    other.conditions = merged
                    other.count += 1
                    other.seq = new.seq
                    # keep the list in seq order, the order the store loads a layer in
                    clusters.remove(other)
                    clusters.append(other)
                    return
        clusters.append(new)

    def _relevant_dims(self, shared: list[Cluster], p: Point) -> list[int]:
        best: Cluster | None = None
        best_agree = -1
        for cluster in shared:
            if any(isinstance(c, Numeric) for c in cluster.conditions.values()):
                agree = sum(
                    1 for j, c in cluster.conditions.items() if not isinstance(c, Numeric) and p.codes[j] in c
                )
            else:
                agree = sum(1 for j, c in cluster.conditions.items() if p.codes[j] in c)  # type: ignore[operator]
            if agree > best_agree or (
                agree == best_agree and best is not None and len(cluster.conditions) < len(best.conditions)
            ):
                best, best_agree = cluster, agree
        if best is None or not best.conditions:
            return list(range(self.n_dims))
        return sorted(best.conditions)

    def _specialize(
        self, box: dict[int, Condition], keep: tuple[int, ...], drop: tuple[int, ...]
    ) -> dict[int, Condition]:
        """Narrow ``box`` (made around ``keep``) so that it no longer covers ``drop``."""
        free = [j for j in range(self.n_dims) if j not in box and keep[j] != drop[j]]
        if free:
            box[free[0]] = frozenset([keep[free[0]]])
            return box
        for j, cond in box.items():  # a related dimension with a value set: shrink it
            if drop[j] in cond and keep[j] != drop[j]:  # type: ignore[operator]
                box[j] = cond - {drop[j]}  # type: ignore[operator]
                return box
        return box
