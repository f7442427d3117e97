"""Database servers for the tests: a fresh database per test, dropped afterwards.

PostgreSQL and MariaDB are reached at the URLs below (or ``$HOMECOG_TEST_POSTGRES_URL`` /
``$HOMECOG_TEST_MARIADB_URL``); where a server cannot be reached, the tests that need it are
skipped with the URL and the error. ``.ci/servers.sh`` starts (or installs) both on CI.

The worker functions at the end run in other processes (``multiprocessing`` with ``spawn``,
or ``python -c``): they open their own store and make corrections, as clients of a shared
database would.
"""

from __future__ import annotations

import os
import random
import secrets
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from sqlalchemy import create_engine, text
from sqlalchemy.engine import URL, Engine, make_url
from sqlalchemy.pool import NullPool

HOMES = Path(__file__).parent / "homes"
STUDIO = HOMES / "studio.yaml"

SERVERS = {
    "postgresql": ("HOMECOG_TEST_POSTGRES_URL", "postgresql+psycopg://postgres@127.0.0.1:5432/test"),
    "mariadb": ("HOMECOG_TEST_MARIADB_URL", "mysql+pymysql://root@127.0.0.1:3306/test"),
}
CONNECT_TIMEOUT = 5  # seconds to wait for a server before skipping its tests
PREFIX = "homecog_t_"

_unreachable: dict[str, str] = {}  # kind -> skip reason, so a dead server costs one timeout


def server_url(kind: str) -> str:
    """The URL of a server's admin database (any database the user may connect to)."""
    env, default = SERVERS[kind]
    return os.environ.get(env) or default


def _admin_engine(url: URL) -> Engine:
    return create_engine(
        url,
        isolation_level="AUTOCOMMIT",
        connect_args={"connect_timeout": CONNECT_TIMEOUT},
        poolclass=NullPool,
    )


@contextmanager
def fresh_database(kind: str) -> Iterator[str]:
    """A new, empty database on a server (``homecog_t_<hex>``), its URL, dropped at the end.

    Skips the calling test when the server cannot be reached.
    """
    admin = make_url(server_url(kind))
    shown = admin.render_as_string(hide_password=True)
    if kind in _unreachable:
        pytest.skip(_unreachable[kind])
    name = PREFIX + secrets.token_hex(6)
    engine = _admin_engine(admin)
    try:
        with engine.connect() as conn:
            conn.execute(text(f"CREATE DATABASE {name}"))
    except Exception as e:  # any failure to reach or use the server: skip, saying why
        engine.dispose()
        orig = getattr(e, "orig", None) or e
        first = (str(orig).strip().splitlines() or [type(orig).__name__])[0]
        reason = f"{kind} server {shown} not usable: {first}"
        print(f"\nSKIP {reason}", file=sys.stderr)
        _unreachable[kind] = reason
        pytest.skip(reason)
    try:
        yield admin.set(database=name).render_as_string(hide_password=False)
    finally:
        try:
            with engine.connect() as conn:
                if kind == "postgresql":
                    # WITH (FORCE): connections left by killed clients must not keep it alive
                    conn.execute(text(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)"))
                else:
                    conn.execute(text("SET SESSION lock_wait_timeout = 60"))
                    conn.execute(text(f"DROP DATABASE IF EXISTS {name}"))
        finally:
            engine.dispose()


def databases_left(kind: str) -> list[str]:
    """The test databases that exist on a server now (to check that tests leave none)."""
    engine = _admin_engine(make_url(server_url(kind)))
    try:
        with engine.connect() as conn:
            if kind == "postgresql":
                rows = conn.execute(text("SELECT datname FROM pg_database"))
            else:
                rows = conn.execute(text("SHOW DATABASES"))
            return sorted(r[0] for r in rows if r[0].startswith(PREFIX))
    finally:
        engine.dispose()


# -- contexts of the studio home --------------------------------------------------------------
def studio_context(rng: random.Random) -> dict[str, object]:
    """A random full context of the studio home (tests/homes/studio.yaml)."""
    return {
        "time": f"{rng.randrange(24)}:{rng.choice(['00', '15', '30', '45'])}",
        "light": rng.choice([20, 80, 150, 300, 800]),
        "activity": rng.choice(["work", "relax", "sleep"]),
        "blind": rng.choice(["on", "off"]),
        "desk_lamp": rng.choice(["on", "off"]),
        "radio": rng.choice(["on", "off"]),
    }


def varied_want(rng: random.Random, predicted: list[str], services: list[str]) -> list[str]:
    """What a user wants instead of ``predicted``: one service added or one dropped (or both)."""
    want = list(predicted)
    move = rng.random()
    missing = [s for s in services if s not in want]
    if move < 0.4 and missing:
        want.append(rng.choice(missing))
    elif move < 0.8 and want:
        want.remove(rng.choice(want))
    else:
        if missing:
            want.append(rng.choice(missing))
        if len(want) > 1:
            want.remove(want[0])
    return want


# -- workers in other processes -----------------------------------------------------------------
def correction_worker(url: str, user: str, n: int, seed: int) -> list[tuple[list[str], list[str]]]:
    """Open a store of the studio home and commit ``n`` corrections by ``user``."""
    from homecog.home import load_home
    from homecog.knowledge import core
    from homecog.knowledge.correction import Correction
    from homecog.knowledge.store import Store

    home = load_home(STUDIO)
    store = Store.open(url, home)
    try:
        tree = store.load_tree()
        rng = random.Random(seed)
        names = list(home.service_names)
        out = []
        for _ in range(n):
            point = tree.point(studio_context(rng))
            tree = core.refresh(store, tree)
            want = varied_want(rng, tree.predict_one(point, user), names)
            outcome = core.correct(store, tree, Correction.whole(user, point, want))
            out.append((list(outcome.added), list(outcome.rejected)))
        return out
    finally:
        store.close()


def correct_forever(url: str, user: str, seed: int) -> None:
    """Commit corrections by ``user`` until killed, printing ``committed N`` after each."""
    from homecog.home import load_home
    from homecog.knowledge import core
    from homecog.knowledge.correction import Correction
    from homecog.knowledge.store import Store

    home = load_home(STUDIO)
    store = Store.open(url, home)
    tree = store.load_tree()
    rng = random.Random(seed)
    names = list(home.service_names)
    done = 0
    while True:
        point = tree.point(studio_context(rng))
        want = varied_want(rng, tree.predict_one(point, user), names)
        core.correct(store, tree, Correction.whole(user, point, want))
        done += 1
        print(f"committed {done}", flush=True)
