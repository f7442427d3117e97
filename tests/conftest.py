"""Shared fixtures: the built-in paper home, a small studio home, and a private data directory."""

from __future__ import annotations

import fcntl
import os
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from servers import fresh_database

from homecog.environment.core import Core
from homecog.home import Home, load_home, load_home_text
from homecog.knowledge.pipeline import ensure_policy

HOMES = Path(__file__).parent / "homes"


@pytest.fixture(scope="session", autouse=True)
def _paper_q_table_once(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The paper's Q table learned once per test session, not once per xdist worker: the first
    worker learns it into a directory the workers share (under a lock), every worker copies it
    into its own data directory, where ``ensure_policy`` and the commands find it cached."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    before = os.environ.get("HOMECOG_DATA")
    with open(shared / "paper-q-table.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        os.environ["HOMECOG_DATA"] = str(shared / "shared-data")
        try:
            ensure_policy(load_home("paper"))
        finally:
            if before is None:
                os.environ.pop("HOMECOG_DATA", None)
            else:
                os.environ["HOMECOG_DATA"] = before
    shutil.copytree(shared / "shared-data" / "qtables", base / "data" / "qtables", dirs_exist_ok=True)


@pytest.fixture(autouse=True)
def _private_data_dir(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """Never write into the user's data directory; and no progress lines on stderr, which come
    by the clock (a busy machine would add them to what a test reads there): the tests of
    progress turn them on."""
    monkeypatch.setenv("HOMECOG_DATA", str(tmp_path_factory.getbasetemp() / "data"))
    monkeypatch.setenv("HOMECOG_PROGRESS_SECONDS", "0")


@pytest.fixture(scope="session")
def paper() -> Home:
    return load_home("paper")


@pytest.fixture(scope="session")
def paper_core(paper: Home) -> Core:
    return Core(paper)


@pytest.fixture(scope="session")
def rooms8() -> Home:
    """A home of 8 rooms of 6 devices (48 devices), from the scale benchmark's generator."""
    sys.path.insert(0, str(Path(__file__).parent.parent / "benchmarks"))
    from homes import home_text

    return load_home_text(home_text(8), "rooms8.yaml")


@pytest.fixture(scope="session")
def studio() -> Home:
    return load_home(HOMES / "studio.yaml")


@pytest.fixture(scope="session")
def studio_core(studio: Home) -> Core:
    return Core(studio)


# -- databases ------------------------------------------------------------------------------------
@pytest.fixture(params=["sqlite", "postgresql", "mariadb"])
def db_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """A fresh, empty database per test: a SQLite file, or a new database on a server, dropped
    afterwards (skipped, saying why, where the server cannot be reached)."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'homecog.sqlite'}"
        return
    with fresh_database(request.param) as url:
        yield url


@pytest.fixture(scope="session")
def studio_build(studio: Home, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A Q table of the studio home (20,000 episodes), saved once per session: with it
    ``homecog.knowledge.pipeline.build(studio, store, q_path=studio_build)`` takes a second."""
    from homecog.learning.sarsa import SarsaConfig, train

    result = train(studio, SarsaConfig(episodes=20_000, seed=0))
    return result.q_table.save(tmp_path_factory.mktemp("studio") / "studio-q.npz")
