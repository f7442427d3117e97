"""From a home to a ready knowledge tree: find what earlier runs made, or make it.

Commands that need a Q table or a tree find the ones earlier commands made for the same
home (cached under the data directory by the home's content hash) or make them.
A home is learned group by group by default; ``joint`` asks for the paper's one table.
Whenever it learns or builds on its own, it says so, and where it keeps what it makes, on the
``homecog.notice`` logger (the command line prints it on stderr): a user who points
``$HOMECOG_DATA`` or ``--db`` elsewhere sees that the robot starts from nothing there.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from homecog.errors import QTableError
from homecog.home.model import Home
from homecog.knowledge import core
from homecog.knowledge.database import redact
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import policy_samples
from homecog.knowledge.store import Store
from homecog.learning.grouped import train_policy
from homecog.learning.policy import Policy
from homecog.learning.sarsa import SarsaConfig
from homecog.learning.size import check_size
from homecog.paths import data_dir, q_table_path

Progress = Callable[[str], None]
notices = logging.getLogger("homecog.notice")


def _say(progress: Progress | None, message: str) -> None:
    if progress is not None:
        progress(message)


def ensure_policy(
    home: Home, path: Path | None = None, *, joint: bool = False, progress: Progress | None = None
) -> Policy:
    """The policy at ``path`` (refused if made for another home), or the cached one, learned
    with default settings if there is none yet (grouped, or ``joint``)."""
    if path is not None:
        return Policy.load(path, home)
    check_size(home, joint=joint)
    cached = q_table_path(home, joint=joint)
    why = f"no Q table of {home.name} in {data_dir()} yet"
    if cached.exists():
        try:
            policy = Policy.load(cached, home)
            if policy.joint == joint:
                return policy
        except QTableError as e:  # a damaged or outdated cache is made again
            why = f"the cached Q table of {home.name} cannot be used ({e})"
    how = "as one joint table" if joint else "group by group"
    notices.info("%s: training one %s, kept at %s", why, how, cached)
    _say(progress, f"training Sarsa on {home.name} {how} (no Q table cached yet) ...")
    policy = train_policy(home, SarsaConfig(), joint=joint).policy
    policy.save(cached)
    return policy


@dataclass
class BuildResult:
    tree: IHDRTree
    samples: int
    seconds: float


def learn_policy(
    home: Home, policy: Policy, tree: IHDRTree, *, seed: int = 0, log: SampleLog | None = None
) -> int:
    """Learn the samples of every group of a policy into ``tree`` (one group's samples in memory
    at a time), logging them compactly into ``log``; returns how many there were."""
    count = 0
    groups = [i for i, g in enumerate(policy.groups) if g.services]
    for i, samples in zip(groups, policy_samples(home, policy, seed=seed), strict=True):
        tree.learn_many(samples)
        count += len(samples)
        if log is not None:
            log.add(samples, i)
    return count


def build(
    home: Home,
    store: Store,
    *,
    q_path: Path | None = None,
    mode: str = "multi",
    seed: int = 0,
    joint: bool = False,
    progress: Progress | None = None,
) -> BuildResult:
    """Samples from the policy, the tree from the samples, both into the store."""
    start = time.perf_counter()
    policy = ensure_policy(home, q_path, joint=joint, progress=progress)
    return build_from(home, policy, store, start=start, mode=mode, seed=seed, progress=progress)


def build_from(
    home: Home,
    policy: Policy,
    store: Store,
    *,
    start: float,
    mode: str = "multi",
    seed: int = 0,
    progress: Progress | None = None,
    source: str | None = None,
    policy_file: bytes | None = None,
) -> BuildResult:
    """The tree of a policy's samples, saved with them into the store in one transaction
    (with the home file's ``source`` and the policy's ``.npz`` bytes, where given). ``start``:
    the :func:`time.perf_counter` at which the build began (its training included)."""
    _say(progress, f"making samples and the {mode} tree, {len(policy.groups)} group(s) ...")
    tree = IHDRTree(home, mode=mode)
    log = SampleLog(seed=seed, joint=policy.joint)
    count = learn_policy(home, policy, tree, seed=seed, log=log)
    _say(progress, "storing the tree and the samples ...")
    seconds = time.perf_counter() - start
    core.save_build(store, tree, log, seconds=seconds, source=source, policy=policy_file)
    return BuildResult(tree=tree, samples=count, seconds=time.perf_counter() - start)


def open_tree(home: Home, store: Store, *, progress: Progress | None = None) -> IHDRTree:
    """The stored tree, built first if the database has none yet."""
    if not store.has_tree():
        check_size(home)  # a home too large is refused before anything is said or made
        notices.info("no knowledge tree of %s in %s yet: building it there", home.name, redact(store.url))
        _say(progress, "no knowledge tree in the database yet: building it ...")
        return build(home, store, progress=progress).tree
    return store.load_tree()
