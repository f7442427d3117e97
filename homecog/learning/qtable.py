"""The Q table and its file: the learned values, tagged with the home's content hash.

A Q table is refused for another home: loading checks the hash of what learning
depends on (:func:`homecog.home.content_hash`). Files are written atomically, so a
failed or interrupted save leaves the previous file as it was.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Self

import numpy as np

from homecog.errors import QTableError
from homecog.home.groups import whole
from homecog.home.model import Home
from homecog.learning.members import read_array, read_meta
from homecog.learning.size import exact_states
from homecog.paths import atomic_write, reading

if TYPE_CHECKING:
    from homecog.environment.core import Core

FORMAT = 1


def check_made_for(name: str, content_hash: str, home: Home, source: str) -> None:
    """Raise :class:`QTableError`, naming both homes, unless ``content_hash`` is ``home``'s."""
    if content_hash != home.content_hash:
        raise QTableError(
            f"{source} was made for home '{name}' ({content_hash[:12]}), not for "
            f"home '{home.name}' ({home.content_hash[:12]}); train again for this home"
        )


@dataclass
class MadeFor:
    """What a learned file was made for: a home's name and content hash."""

    home_name: str
    home_hash: str

    def check_home(self, home: Home, source: str = "the Q table") -> None:
        """Raise :class:`QTableError` unless this was learned for ``home``."""
        check_made_for(self.home_name, self.home_hash, home, source)

    def meta(self, file_format: int, *names: str) -> dict[str, Any]:
        """The file's metadata: its format, the home it was made for, then the attributes
        ``names`` as they are."""
        tag = {"format": file_format, "home_name": self.home_name, "home_hash": self.home_hash}
        return tag | {name: getattr(self, name) for name in names}

    @classmethod
    def restore(cls, meta: dict[str, Any], *names: str, **values: Any) -> Self:
        """The inverse of :meth:`meta`: made for the home ``meta`` names, with the attributes
        ``names`` as ``meta`` holds them and the rest from ``values``."""
        return cls(
            home_name=meta["home_name"], home_hash=meta["home_hash"], **{n: meta[n] for n in names}, **values
        )


@dataclass
class QTable(MadeFor):
    """Q values ``q[state, service]`` (float32), which pairs were tried, and the run's record.

    ``tried[state, w]`` holds the tried marks of services ``32w .. 32w+31`` as bits.
    """

    q: np.ndarray
    tried: np.ndarray
    episodes: int = 0
    steps: int = 0
    greedy_optimal_rate: float | None = None
    config: dict[str, Any] = field(default_factory=dict)
    rng: np.ndarray = field(default_factory=lambda: np.array([1], dtype=np.int64))

    @classmethod
    def empty(cls, core: Core, config: dict[str, Any] | None = None) -> QTable:
        """An all-zero table for a home, nothing tried."""
        shape = (core.n_states, core.n_services)
        words = (core.n_services + 31) // 32
        return cls(
            home_name=core.home.name,
            home_hash=core.home.content_hash,
            q=np.zeros(shape, dtype=np.float32),
            tried=np.zeros((core.n_states, words), dtype=np.int64),
            config=dict(config or {}),
        )

    def save(self, path: str | Path) -> Path:
        """Write the table to ``path`` (.npz) atomically and return the path."""
        path = Path(path)
        meta = self.meta(FORMAT, "episodes", "steps", "greedy_optimal_rate", "config")
        meta["rng"] = int(self.rng[0])
        with atomic_write(path, QTableError) as f:
            np.savez_compressed(f, q=self.q, tried=self.tried, meta=np.array(json.dumps(meta)))
        return path

    @classmethod
    def load(cls, path: str | Path, home: Home) -> QTable:
        """Read a table made for ``home``, refused unless it was made for that home and its arrays
        are of the home's shape (checked from their headers, before anything is allocated)."""
        path = Path(path)
        rows, services = exact_states(home, whole(home), joint=True), len(home.services)
        with reading(path, QTableError, "a homecog Q table"), zipfile.ZipFile(path) as z:
            meta = read_meta(z, str(path))
            if meta.get("format") != FORMAT:
                raise QTableError(f"{path}: not a homecog Q table (format {meta.get('format')!r})")
            check_made_for(meta["home_name"], meta["home_hash"], home, str(path))
            q = read_array(z, "q", (rows, services), np.float32, str(path), "the table")
            words = (services + 31) // 32
            tried = read_array(z, "tried", (rows, words), np.int64, str(path), "the table's tried marks")
            return cls.restore(
                meta,
                "episodes",
                "steps",
                "greedy_optimal_rate",
                "config",
                q=q,
                tried=tried,
                rng=np.array([meta["rng"]], dtype=np.int64),
            )
