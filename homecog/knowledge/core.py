"""The knowledge core: a correction as one unit of work.

Every edge (the HTTP API, ``homecog correct``, an event file, the running robot) builds a
:class:`~homecog.knowledge.correction.Correction` and hands it here unchanged. :func:`correct`
runs one transaction: it locks the user's row, brings the tree's copy of that user's corrections
up to what is committed (another process may have corrected meanwhile), judges the correction
on the tree (what it adds and rejects; nothing changes), writes its row, and commits. Only then
is it applied to the tree. A failed write leaves the tree as it was: nothing to undo.

The store persists rows and reads them; it never drives the learner. The tree learns; it never
touches SQL. This module is where the two meet: corrections, a build stored with the log's
corrections learned into it (:func:`save_build`), the tree made again from the log alone
(:func:`rebuild`), and a tree brought up to what other processes committed (:func:`refresh`).

>>> from homecog.home import load_home
>>> from homecog.knowledge.ihdr import IHDRTree
>>> from homecog.knowledge.store import Store
>>> home = load_home("paper")
>>> store = Store.open("sqlite://", home)
>>> tree = IHDRTree(home)
>>> point = tree.space.point({"time": "07:00", "temperature": 25, "illumination": 100,
...     "location": "bed", "posture": "lie", "behavior": "sleep", "window": "off", "curtain": "off",
...     "tv_living": "off", "tv_bedroom": "off", "ac_living": "off", "ac_bedroom": "off",
...     "lamp": "off", "ceiling_light": "off"})
>>> outcome = correct(store, tree, Correction.change("kim", point, add=["SendDrinks"]))
>>> outcome.number, outcome.added, tree.predict_one(point, "kim")
(1, ('SendDrinks',), ['SendDrinks'])
>>> correct(store, tree, Correction.change("kim", point, add=["Fly"]))
Traceback (most recent call last):
...
homecog.errors.ContextError: unknown service 'Fly'; expected some of ...
>>> tree.n_clusters("kim"), store.read_user("kim")[0]   # nothing stored, nothing learned
(1, 1)
"""

from __future__ import annotations

import random
import threading
import time
from collections.abc import Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager, nullcontext
from typing import Any

from homecog.errors import ConflictError
from homecog.home.codec import Point
from homecog.knowledge.correction import Correction, Outcome, point_of_row
from homecog.knowledge.corrections import Example
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.model import Cognition
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.store import Store

#: attempts of a transaction that the server aborts for a deadlock between concurrent corrections
CONFLICT_RETRIES = 50
#: no lock: a tree nobody else reads meanwhile
NO_LOCK = nullcontext()


@contextmanager
def reading(tree: IHDRTree, lock: AbstractContextManager[Any], user: str | None) -> Iterator[IHDRTree]:
    """``tree``, to answer for ``user``: their layer learned first, under their lock alone (other
    users' answers never wait on it), then held with ``lock``, the robot's. A correction learns
    under the user's lock alone, so only that user's answers wait on it."""
    tree.prepare(user)
    with tree.user_lock(user), lock:
        yield tree


def answer_now(tree: IHDRTree, lock: threading.Lock, p: Point, user: str | None) -> Cognition | None:
    """The answer for ``user`` at ``p`` where it need not wait, else None: the user's layer not
    learned yet, or their lock or ``lock`` held."""
    mine = tree.user_lock(user)
    if not tree.ready(user) or not mine.acquire(blocking=False):
        return None
    try:
        if not lock.acquire(blocking=False):
            return None
        try:
            return tree.explain_one(p, user=user)
        finally:
            lock.release()
    finally:
        mine.release()


def correct(
    store: Store, tree: IHDRTree, c: Correction, lock: AbstractContextManager[Any] = NO_LOCK
) -> Outcome:
    """Commit correction ``c`` to the log, then learn it into ``tree``. A transaction the server
    aborts for a deadlock (MariaDB's locks on the users and experiences indexes) runs again.

    ``lock`` guards the tree where others read it (the running robot's cognition): it is held
    while the tree is read or changed, never while the database writes or commits, so a
    cognition never waits on a commit. One user's corrections in one process run one at a time
    (:meth:`Store.user_lock`); other processes' are told apart by the user's version."""
    with store.user_lock(c.user):
        tree.prepare(c.user)  # the user's layer learned before the lock is taken, if it must be
        for attempt in range(CONFLICT_RETRIES):
            try:
                with store.transaction() as conn:
                    version, examples = store.lock_user(conn, c.user, tree.n_clusters(c.user))
                    with tree.user_lock(c.user), lock:
                        _take(store, tree, c.user, version, examples)
                        added, rejected = tree.judge(c)
                        context = tree.space.context(c.point)
                    store.log_correction(conn, c.user, c.row(context, added, rejected))
                break
            except ConflictError:
                if attempt == CONFLICT_RETRIES - 1:
                    raise
                time.sleep(random.uniform(0, 0.01 * (attempt + 1)))
        with tree.user_lock(c.user):  # only the user's own answers wait while it learns
            tree.apply(c)
            store.holds(c.user, version + 1)
            number = tree.n_clusters(c.user)
    return Outcome(c, number, added, rejected)


def correct_many(store: Store, tree: IHDRTree, corrections: Sequence[Correction]) -> list[Outcome]:
    """Corrections in one transaction, in order: all of them are stored and learned, or none.

    Each is judged on the tree that holds the ones before it, so they are learned as they are
    judged; where the transaction fails, the tree's copy of their users is read again from what
    is committed (what the database holds is what memory holds)."""
    out: list[Outcome] = []
    try:
        with store.transaction() as conn:
            for c in corrections:
                version, examples = store.lock_user(conn, c.user, tree.n_clusters(c.user))
                _take(store, tree, c.user, version, examples)
                added, rejected = tree.judge(c)
                store.log_correction(conn, c.user, c.row(tree.space.context(c.point), added, rejected))
                tree.apply(c)
                store.holds(c.user, version + 1)
                out.append(Outcome(c, tree.n_clusters(c.user), added, rejected))
    except BaseException:
        reload_users(store, tree, {c.user for c in corrections})
        raise
    return out


def reload_users(store: Store, tree: IHDRTree, users: Iterable[str]) -> None:
    """The tree's copy of ``users``' corrections made again from what is committed."""
    for user in sorted(users):
        version, examples = store.read_user(user)
        tree.set_user_examples(user, examples)
        store.holds(user, version)


def refresh(store: Store, tree: IHDRTree, lock: AbstractContextManager[Any] = NO_LOCK) -> IHDRTree:
    """``tree`` brought up to the database: the corrections another process made since it was
    read learned on top, or the whole tree loaded again after another build (the caller puts
    the tree returned in its place). ``lock`` as for :func:`correct`: held while the tree is
    read or changed, never while the database is (a database that locks its readers, as SQLite
    does here, would otherwise wait on a correction that waits on the lock)."""
    stale = store.stale_users()
    if stale is None:
        return store.load_tree()
    for user in stale:
        with store.user_lock(user):
            tree.prepare(user)
            with lock:
                have = tree.n_clusters(user)
            version, more = store.user_after(user, have)
            with tree.user_lock(user), lock:
                _take(store, tree, user, version, more)
    return tree


def save_build(store: Store, tree: IHDRTree, samples: SampleSet | SampleLog, **stored: Any) -> None:
    """Store a freshly built tree (:meth:`Store.save_build`, ``stored`` its other arguments),
    the single samples and corrections of the log learned into it first, so that a new build
    (another mode, a retrained Q table) loses none of them; a home stored from another home
    file is replaced whole, its log with it."""
    if not store.holds_other_home():
        for kind, user, payload in store.singles():
            replay(tree, kind, user, payload)
    store.save_build(tree, samples, **stored)


def rebuild(store: Store) -> IHDRTree:
    """The tree made again from the experience log alone: the last build's samples, then every
    single sample and correction in the order they were committed. It answers as the stored
    tree does (tests check it)."""
    mode, parts = store.last_build()
    tree = IHDRTree(store.home, mode=mode)
    for samples in parts:
        tree.learn_many(samples)
    for kind, user, payload in store.singles():
        replay(tree, kind, user, payload)
    return tree


def replay(tree: IHDRTree, kind: str, user: str | None, payload: dict[str, Any]) -> None:
    """Learn a logged single sample or correction into ``tree`` again."""
    if kind == "correction":
        tree.apply(Correction.from_row(user, payload))
        return
    tree.learn_one(point_of_row(payload), payload["services"], relevant=payload.get("relevant"))


def _take(store: Store, tree: IHDRTree, user: str, version: int, more: list[Example] | None) -> None:
    """A user's corrections another process committed after those the tree holds (``None``:
    none) learned into ``tree``: the cost of those alone, not of the user's whole history."""
    if more is not None:
        tree.extend_user_examples(user, more)
        store.holds(user, version)
