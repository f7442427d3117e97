"""Database URLs and engines for the knowledge store: SQLite by default (a file per home under
the data directory), MariaDB/MySQL (PyMySQL) and PostgreSQL (psycopg 3).

>>> redact("postgresql+psycopg://robot:secret@db.local/homes")
'postgresql+psycopg://robot:***@db.local/homes'
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from sqlalchemy import create_engine, event, inspect
from sqlalchemy.engine import Connection, Engine, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError

from homecog.errors import StoreError
from homecog.home.model import Home
from homecog.paths import create_private_file, data_file, make_private_dirs

CONNECT_TIMEOUT = 10  # seconds to wait for a database server (unless the URL says connect_timeout)


#: an execution option of a connection whose transaction only reads
READ_ONLY = "homecog_read_only"


def is_conflict(e: DBAPIError) -> bool:
    """Whether a database error is a deadlock or serialization failure (worth a retry)."""
    orig = e.orig
    code = orig.args[0] if orig is not None and orig.args else None
    # MySQL/MariaDB 1213: deadlock; PostgreSQL 40P01: deadlock, 40001: serialization failure
    return code == 1213 or getattr(orig, "sqlstate", None) in ("40P01", "40001")


def default_url(home: Home, *, create: bool = False) -> str:
    """``$HOMECOG_DB`` or a SQLite file under the data directory, one per home; ``create``:
    make its folder (the data directory's own, the only folder homecog makes for a database)."""
    env = os.environ.get("HOMECOG_DB")
    if env:
        return env
    path = data_file("knowledge", home, ".sqlite")
    if create:
        try:
            make_private_dirs(path.parent)
        except OSError as e:
            raise StoreError(f"{path.parent}: cannot make the data directory: {e.strerror}") from None
    return f"sqlite:///{path}"


def redact(url: str) -> str:
    """A URL without its password, for messages."""
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        return url


def server_connect_args(url: str) -> dict[str, Any]:
    """The connection arguments for a database server's URL: a ``connect_timeout`` of
    :data:`CONNECT_TIMEOUT` seconds unless the URL says one (a server that drops packets must not
    hang a command: libpq waits forever by default).

    >>> server_connect_args("postgresql://db/x"), server_connect_args("mysql://db/x?connect_timeout=3")
    ({'connect_timeout': 10}, {})
    """
    parsed = make_url(url)
    if (
        parsed.get_backend_name() in ("postgresql", "mysql", "mariadb")
        and "connect_timeout" not in parsed.query
    ):
        return {"connect_timeout": CONNECT_TIMEOUT}
    return {}


def make_engine(url: str) -> Engine:
    """An engine for a URL; SQLite gets WAL, a busy timeout and immediate write transactions."""
    try:
        if url.startswith("sqlite"):
            path = url.split("///", 1)[1].split("?", 1)[0] if "///" in url else ""
            if path and path != ":memory:" and not path.startswith("file:"):
                folder = Path(path).parent
                if not folder.is_dir():  # made by whoever chose it, never here (nor /nonexist/)
                    raise StoreError(f"database {redact(url)}: no folder {folder}; make it first")
                create_private_file(Path(path))  # 0600; its -wal and -shm files take its mode
            engine = create_engine(url, connect_args={"timeout": 60})

            @event.listens_for(engine, "connect")
            def _connect(dbapi_connection: Any, _: Any) -> None:
                dbapi_connection.isolation_level = None  # we issue BEGIN ourselves
                cursor = dbapi_connection.cursor()
                cursor.execute("PRAGMA journal_mode=WAL")
                # WAL with synchronous=NORMAL: a commit survives a crash of the program (the
                # SIGKILL test), only a power cut may lose the last ones; the file never corrupts
                cursor.execute("PRAGMA synchronous=NORMAL")
                cursor.execute("PRAGMA foreign_keys=ON")
                cursor.close()

            @event.listens_for(engine, "begin")
            def _begin(conn: Connection) -> None:
                # a reader takes no lock (WAL: it reads the last commit); a writer the write lock
                # at once, so two never deadlock upgrading a read to a write
                read = conn.get_execution_options().get(READ_ONLY)
                conn.exec_driver_sql("BEGIN" if read else "BEGIN IMMEDIATE")

            return engine
        return create_engine(url, pool_pre_ping=True, connect_args=server_connect_args(url))
    except (ArgumentError, NoSuchModuleError, ValueError) as e:
        raise StoreError(f"database {redact(url)}: not a database URL ({e})") from None
    except ImportError as e:
        raise StoreError(f"database {redact(url)}: driver missing ({e.name}); install it with pip") from None
    except OSError as e:
        raise StoreError(f"database {redact(url)}: {e.strerror}") from None


def db_message(url: str, e: BaseException) -> str:
    orig = getattr(e, "orig", None) or e
    text_ = str(orig).strip().splitlines()[0] if str(orig).strip() else type(orig).__name__
    return f"database {redact(url)}: cannot use the database: {text_}"


def migrate(engine: Engine) -> None:
    """Make or migrate the schema of a database to the latest (Alembic's ``upgrade head``)."""
    from alembic import command
    from alembic.config import Config
    from alembic.util.exc import CommandError

    _check_own(engine)
    cfg = Config()
    cfg.set_main_option("script_location", str(Path(__file__).parent / "migrations"))
    try:
        with engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")
    except CommandError as e:  # a revision we do not know: a newer homecog made the database
        url = redact(engine.url.render_as_string(hide_password=False))
        raise StoreError(
            f"database {url}: a database of a schema this homecog does not know ({e}); "
            "use the homecog that made it, or a newer one"
        ) from None


def _check_own(engine: Engine) -> None:
    """Refuse a database that holds another application's tables and was never homecog's (no
    ``alembic_version``): homecog would add its tables beside theirs."""
    from homecog.knowledge.schema import Base

    with engine.connect() as conn:
        names = set(inspect(conn).get_table_names())
    foreign = sorted(names - set(Base.metadata.tables))
    if foreign and "alembic_version" not in names:
        url = redact(engine.url.render_as_string(hide_password=False))
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise StoreError(
            f"database {url}: holds another application's tables ({shown}), not homecog's; "
            "give homecog a database of its own"
        )


# -- encoding the tree -------------------------------------------------------------------------
