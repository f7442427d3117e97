"""What a home learned: one Q table per independent group of devices, or the paper's one
joint table, in one file tagged with the home's content hash.

Each group's table is a :class:`~homecog.learning.qtable.QTable` of the group's projection
(:func:`homecog.home.groups.project`): states (context, the group's devices, the group's
pending needs) × the group's services. The paper's joint table is the special case of one
group holding every device and service.

The file is a zip of ``.npy`` members (``meta.npy`` and ``q<i>.npy``, readable by
``numpy.load``), written member by member to a temporary file that is renamed into place,
so neither memory nor a crash mid-way costs more than one group. Group tables are stored as
float16 (see :func:`round_q`); the joint table keeps float32 and its tried marks, as before.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from homecog.errors import QTableError
from homecog.home.groups import Group, device_groups, whole
from homecog.home.model import Home
from homecog.learning.members import read_array, read_meta
from homecog.learning.qtable import MadeFor, QTable, check_made_for
from homecog.learning.size import exact_states
from homecog.paths import atomic_write, reading

FORMAT = 3  # 3: group tables over the groups' classes of contexts; 2 had every context


def round_q(q: np.ndarray) -> np.ndarray:
    """A group's Q values rounded to float16, in place (the array stays float32).

    The values are bounded by the reward's magnitude over (1 − γ), and what the policy reads
    of them is which service is best in a state: with the paper's rewards a right service is
    worth at least 1 and a wrong one at most −0.6, far beyond float16's resolution (1/128
    around 10). Rounding as soon as a group is learned makes the stored table exactly the one
    that the rate, the samples and every later stage use.
    """
    q[...] = q.astype(np.float16)
    return q


@dataclass
class Policy(MadeFor):
    """The Q tables of a home: ``tables[i]`` belongs to ``groups[i]``."""

    joint: bool
    groups: tuple[Group, ...]
    tables: list[QTable]
    greedy_optimal_rate: float | None = None
    config: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0

    @property
    def episodes(self) -> int:
        return sum(t.episodes for t in self.tables)

    @property
    def steps(self) -> int:
        return sum(t.steps for t in self.tables)

    def q(self, i: int) -> np.ndarray:
        """Group ``i``'s Q values as float32, the kernels' type."""
        q = self.tables[i].q
        return q if q.dtype == np.float32 else q.astype(np.float32)

    @classmethod
    def joint_from(cls, home: Home, table: QTable) -> Policy:
        """The paper's single table as a policy of one group."""
        return cls(
            home_name=table.home_name,
            home_hash=table.home_hash,
            joint=True,
            groups=(whole(home),),
            tables=[table],
            greedy_optimal_rate=table.greedy_optimal_rate,
            config=dict(table.config),
        )

    # -- the file ----------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write the policy to ``path`` atomically and return the path."""
        path = Path(path)
        meta = self.meta(FORMAT, "joint", "greedy_optimal_rate", "config", "seconds") | {
            "groups": [
                {
                    "devices": list(g.devices),
                    "services": list(g.services),
                    "episodes": t.episodes,
                    "steps": t.steps,
                    "rate": t.greedy_optimal_rate,
                    "rng": int(t.rng[0]),
                }
                for g, t in zip(self.groups, self.tables, strict=True)
            ],
        }
        with (
            atomic_write(path, QTableError) as f,
            zipfile.ZipFile(f, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as z,
        ):
            _write(z, "meta", np.array(json.dumps(meta)))
            for i, t in enumerate(self.tables):
                _write(z, f"q{i}", t.q if self.joint else t.q.astype(np.float16))
                if self.joint:
                    _write(z, f"tried{i}", t.tried)
        return path

    @classmethod
    def load(cls, path: str | Path, home: Home) -> Policy:
        """Read a policy (or a joint Q table of the earlier format) made for ``home``."""
        path = Path(path)
        with reading(path, QTableError, "a homecog Q table"), zipfile.ZipFile(path) as z:
            meta = read_meta(z, str(path))
            if meta.get("format") == 1:
                return cls.joint_from(home, QTable.load(path, home))
            if meta.get("format") == 2:
                raise QTableError(f"{path}: a Q table of an earlier homecog (format 2); train again")
            if meta.get("format") != FORMAT:
                raise QTableError(f"{path}: not a homecog Q table (format {meta.get('format')!r})")
            policy = cls._from_meta(meta, home, path)
            for i, (g, t) in enumerate(zip(policy.groups, policy.tables, strict=True)):
                # each array's header checked against the home before it is read (members.py)
                shape = (exact_states(home, g, joint=policy.joint), len(g.services))
                if policy.joint:
                    t.q = read_array(z, f"q{i}", shape, np.float32, str(path), "the joint table")
                    words = (shape[1] + 31) // 32
                    marks = "the joint table's tried marks"
                    t.tried = read_array(z, f"tried{i}", (shape[0], words), np.int64, str(path), marks)
                else:
                    t.q = read_array(z, f"q{i}", shape, np.float16, str(path), f"group {i}'s table")
        return policy

    @classmethod
    def _from_meta(cls, meta: dict[str, Any], home: Home, path: Path) -> Policy:
        check_made_for(meta["home_name"], meta["home_hash"], home, str(path))
        groups = (whole(home),) if meta["joint"] else device_groups(home)
        try:
            stored = [(tuple(g["devices"]), tuple(g["services"])) for g in meta["groups"]]
        except (TypeError, KeyError):
            raise QTableError(f"{path}: not a homecog Q table (its groups are no list)") from None
        if stored != [(g.devices, g.services) for g in groups]:
            raise QTableError(f"{path}: its groups are not this home's groups; train again")
        tables = [
            QTable(
                home_name=f"{meta['home_name']}[{i}]",
                home_hash=f"{meta['home_hash']}/{i}",
                q=np.zeros((0, 0), dtype=np.float32),
                tried=np.zeros((0, 1), dtype=np.int64),
                episodes=g["episodes"],
                steps=g["steps"],
                greedy_optimal_rate=g["rate"],
                config=meta["config"],
                rng=np.array([g["rng"]], dtype=np.int64),
            )
            for i, g in enumerate(meta["groups"])
        ]
        return cls.restore(
            meta,
            "joint",
            "greedy_optimal_rate",
            "config",
            groups=groups,
            tables=tables,
            seconds=meta.get("seconds", 0.0),
        )


def _write(z: zipfile.ZipFile, name: str, array: np.ndarray) -> None:
    with z.open(f"{name}.npy", "w", force_zip64=True) as f:
        np.lib.format.write_array(f, np.asanyarray(array), allow_pickle=False)
