"""``homecog correct --events FILE``: a household's event file learned as corrections.

The whole file is read and checked before anything is stored: a wrong header, an unknown
service or value, an unparsable row is one error naming the file, the line and the column, and
nothing is learned from a file that is refused. Then every row is learned, in order, as a
correction through the knowledge core — the same path as ``homecog correct --context`` and the HMI —
with ``batch`` corrections to a transaction: each batch is stored whole or not at all.

A row's user is its ``user`` column where the file has one and the cell is not empty, else the
``--user`` of the command.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from homecog.errors import EvaluationError
from homecog.home.model import Home
from homecog.home.recent import RecentPast
from homecog.home.scenario_file import load_scenarios
from homecog.knowledge import core
from homecog.knowledge.correction import Correction
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.store import Store
from homecog.names import user_name_problem

#: Corrections to a transaction.
BATCH = 100


@dataclass
class EventsLearned:
    """What learning an event file did."""

    events: int
    added: int = 0  # services added, over all corrections
    rejected: int = 0
    changed: int = 0  # corrections that added or rejected something
    users: dict[str, int] = field(default_factory=dict)  # corrections per user
    batches: int = 0
    experiences: int = 0
    seconds: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "seconds": round(self.seconds, 3)}


def read_corrections(path: Path, home: Home, user: str) -> list[Correction]:
    """Every row of an event file as a correction of the whole set wanted there, all checked
    before any is learned; each with the recent past of the household's stream, in the file's
    order, as a replay has it. A user the home's household does not know refuses the file."""
    problem = user_name_problem(user)
    if problem is not None:
        raise EvaluationError(problem)
    order = {name: a for a, name in enumerate(home.service_names)}
    past = RecentPast(home)
    out = []
    for r in load_scenarios(path, home, home, corrections=True):
        point = replace(r.point, recent=past.at(r.timestamp, r.context))
        past.learn(r.timestamp, r.context, r.truth)
        who = r.user or user
        if not home.household.knows(who):
            raise EvaluationError(
                f"{path.name}: user {who!r} is not one of the household ({home.household.names()})"
            )
        out.append(Correction.whole(who, point, sorted(r.truth, key=order.__getitem__)))
    return out


def learn_corrections(
    store: Store,
    tree: IHDRTree,
    corrections: Sequence[Correction],
    *,
    batch: int = BATCH,
    progress: Callable[[int, int], None] | None = None,
) -> EventsLearned:
    """Learn the corrections in order, ``batch`` to a transaction."""
    if batch < 1:
        raise ValueError(f"batch must be at least 1, got {batch}")
    start = time.perf_counter()
    out = EventsLearned(events=len(corrections))
    for first in range(0, len(corrections), batch):
        chunk = corrections[first : first + batch]
        for outcome in core.correct_many(store, tree, chunk):
            out.added += len(outcome.added)
            out.rejected += len(outcome.rejected)
            out.changed += bool(outcome.added or outcome.rejected)
            user = outcome.correction.user
            out.users[user] = out.users.get(user, 0) + 1
        out.batches += 1
        if progress:
            progress(first + len(chunk), len(corrections))
    for user in out.users:  # a long history is kept learned: a restart need not learn it again
        tree.layers.keep(user)
    out.experiences = store.experience_count()
    out.seconds = time.perf_counter() - start
    return out
