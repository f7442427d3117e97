"""Where homecog keeps what it makes: Q tables (and later the knowledge database).

Under the user's data directory (``~/.local/share/homecog`` on Linux), or
``$HOMECOG_DATA`` when set. Files are named by the home's content hash, so a home that
changes gets new ones and a Q table is never used for another home.
"""

from __future__ import annotations

import os
from pathlib import Path

from platformdirs import user_data_path

from homecog.home.model import Home


def data_dir() -> Path:
    """The data directory (not created here)."""
    env = os.environ.get("HOMECOG_DATA")
    return Path(env).expanduser() if env else user_data_path("homecog", appauthor=False)


def q_table_path(home: Home, *, joint: bool = False) -> Path:
    """The cached Q tables of a home: learned group by group, or (``joint``) as one table."""
    suffix = "-joint" if joint else ""
    return data_dir() / "qtables" / f"{home.name}-{home.content_hash[:16]}{suffix}.npz"
