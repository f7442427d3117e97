"""Small generated homes for the fleet tests (one room of six devices: a second to learn), and
helpers to look at a fleet's database."""

from __future__ import annotations

import sys
from pathlib import Path

from sqlalchemy import func, select

sys.path.insert(0, str(Path(__file__).parent.parent / "benchmarks"))
from homes import home_text

from homecog.home import Home, load_home_text
from homecog.knowledge.database import make_engine
from homecog.knowledge.schema import ClusterRow, ExperienceRow, HomeRow, NodeRow


def write_homes(folder: Path, n: int, *, rooms: int = 1, prefix: str = "home") -> list[Home]:
    """``n`` home files ``<prefix><i>.yaml`` in ``folder``; the homes."""
    folder.mkdir(parents=True, exist_ok=True)
    homes = []
    for i in range(n):
        text = home_text(rooms, name=f"{prefix}{i}")
        (folder / f"{prefix}{i}.yaml").write_text(text)
        homes.append(load_home_text(text, f"{prefix}{i}.yaml"))
    return homes


def home_rows(url: str) -> dict[str, dict[str, int]]:
    """Per home of the database: its built flag, version and build, and its rows per table."""
    engine = make_engine(url)
    try:
        with engine.connect() as conn:
            out = {}
            for name, built_at, version, build in conn.execute(
                select(HomeRow.name, HomeRow.built_at, HomeRow.version, HomeRow.build)
            ):
                out[name] = {"built": int(built_at is not None), "version": version, "build": build}
                for key, table in (
                    ("nodes", NodeRow),
                    ("clusters", ClusterRow),
                    ("experiences", ExperienceRow),
                ):
                    query = select(func.count()).select_from(table).where(table.home == name)
                    out[name][key] = conn.execute(query).scalar_one()
            return out
    finally:
        engine.dispose()
