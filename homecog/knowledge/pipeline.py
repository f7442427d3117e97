"""From a home to a ready knowledge tree: find what earlier runs made, or make it.

Commands that need a Q table or a tree find the ones earlier commands made for the same
home (cached under the data directory by the home's content hash) or make them (SPEC §11).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from homecog.environment.core import Core
from homecog.errors import QTableError
from homecog.home.model import Home
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.samples import make_samples
from homecog.knowledge.store import Store
from homecog.learning.qtable import QTable
from homecog.learning.sarsa import SarsaConfig, train
from homecog.paths import q_table_path

Progress = Callable[[str], None]


def _say(progress: Progress | None, message: str) -> None:
    if progress is not None:
        progress(message)


def ensure_q_table(
    home: Home, path: Path | None = None, *, core: Core | None = None, progress: Progress | None = None
) -> QTable:
    """The Q table at ``path`` (refused if made for another home), or the cached one, trained
    with default settings if there is none yet."""
    if path is not None:
        return QTable.load(path, home)
    cached = q_table_path(home)
    if cached.exists():
        try:
            return QTable.load(cached, home)
        except QTableError:
            pass  # a damaged cache is made again
    _say(progress, f"training Sarsa on {home.name} (no Q table cached yet) ...")
    result = train(home, SarsaConfig(), core=core)
    result.q_table.save(cached)
    return result.q_table


@dataclass
class BuildResult:
    tree: IHDRTree
    samples: int
    seconds: float


def build(
    home: Home,
    store: Store,
    *,
    q_path: Path | None = None,
    mode: str = "multi",
    seed: int = 0,
    progress: Progress | None = None,
) -> BuildResult:
    """Samples from the Q table, the tree from the samples, both into the store."""
    start = time.perf_counter()
    core = Core(home)
    q = ensure_q_table(home, q_path, core=core, progress=progress)
    _say(progress, f"making samples from every start state ({core.n_start_states():,}) ...")
    samples = make_samples(core, q.q, seed=seed)
    _say(progress, f"building the {mode} tree ...")
    tree = IHDRTree(home, mode=mode)
    tree.learn_many(samples)
    _say(progress, "storing the tree and the samples ...")
    seconds = time.perf_counter() - start
    store.save_build(tree, samples, seconds=seconds)
    return BuildResult(tree=tree, samples=len(samples), seconds=time.perf_counter() - start)


def open_tree(home: Home, store: Store, *, progress: Progress | None = None) -> IHDRTree:
    """The stored tree, built first if the database has none yet."""
    if not store.has_tree():
        _say(progress, "no knowledge tree in the database yet: building it ...")
        return build(home, store, progress=progress).tree
    return store.load_tree()
