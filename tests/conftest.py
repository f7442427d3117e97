"""Shared fixtures: the built-in paper home, a small studio home, and a private data directory."""

from __future__ import annotations

from pathlib import Path

import pytest

from homecog.environment.core import Core
from homecog.home import Home, load_home

HOMES = Path(__file__).parent / "homes"


@pytest.fixture(autouse=True)
def _private_data_dir(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch) -> None:
    """Never write into the user's data directory."""
    monkeypatch.setenv("HOMECOG_DATA", str(tmp_path_factory.getbasetemp() / "data"))


@pytest.fixture(scope="session")
def paper() -> Home:
    return load_home("paper")


@pytest.fixture(scope="session")
def paper_core(paper: Home) -> Core:
    return Core(paper)


@pytest.fixture(scope="session")
def studio() -> Home:
    return load_home(HOMES / "studio.yaml")


@pytest.fixture(scope="session")
def studio_core(studio: Home) -> Core:
    return Core(studio)
