"""The knowledge store: the IHDR tree and the experience log in a SQL database.

SQLAlchemy 2 over SQLite (the default: a file under the user's data directory),
MariaDB/MySQL (PyMySQL) or PostgreSQL (psycopg 3). Nodes are rows with a parent; clusters
are rows of a node; a build's samples (replacing the previous build's) and every correction
are written to ``experiences`` in the same transaction as the tree update, and the tree
rebuilt from that log answers identically.
The schema is created and changed by Alembic migrations (``homecog/knowledge/migrations``).

A correction locks its user's row (``SELECT … FOR UPDATE``; SQLite takes the database's
write lock), reloads that user's layer if another process changed it, applies the
correction and writes it back, so concurrent corrections lose nothing.

One database holds many homes: every row is under its home's name, and a Store is
one home's view of the database. The home's row has a version that moves on every write (a
build, a correction), so a server that keeps a tree in memory sees cheaply whether it is stale
(:meth:`Store.home_version`).

The learner never touches SQL: this module maps the tree to rows and back; the log's reading
(counts, the rebuild from the log) is in :mod:`homecog.knowledge.store_log`.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import delete, func, insert, select, update
from sqlalchemy.engine import Connection, Engine
from sqlalchemy.exc import DBAPIError, OperationalError, SQLAlchemyError

from homecog.errors import ConflictError, NameProblemError, StoreError
from homecog.home.model import Home
from homecog.knowledge.corrections import Example
from homecog.knowledge.database import (
    READ_ONLY,
    db_message,
    default_url,
    is_conflict,
    make_engine,
    migrate,
    redact,
)
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.rows import (
    cluster_from_row,
    cluster_rows,
    example_from_payload,
    log_rows,
    node_rows,
    sample_rows,
)
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.schema import ClusterRow, ExperienceRow, HomeRow, NodeRow, UserRow
from homecog.knowledge.snapshots import LayerSnapshots
from homecog.knowledge.state import COUNTERS, NodeState, TreeState
from homecog.knowledge.statements import (
    BUMP_HOME,
    BUMP_USER,
    LOG_CORRECTION,
    USER_VERSION,
    USER_VERSION_LOCKED,
)
from homecog.knowledge.store_log import BUILD_SAMPLES, StoreLog
from homecog.names import user_name_problem
from homecog.paths import data_file

SAMPLES_PER_ROW = 32768


class Store(StoreLog):
    """The knowledge of one home in one database.

    >>> from homecog.home import load_home
    >>> store = Store.open("sqlite://", load_home("paper"))   # in memory
    >>> store.has_tree()
    False
    """

    def __init__(self, url: str, home: Home, engine: Engine, *, own_engine: bool) -> None:
        """A store over ``engine`` as it is (``own_engine``: closed with the store); :meth:`open`
        makes one ready to use."""
        self.home = home
        self.url = url
        self._own_engine = own_engine
        self.engine = engine
        self._versions: dict[str, int] = {}
        self._known_users: set[str] = set()
        self._user_locks: dict[str, threading.Lock] = {}
        self._locks_lock = threading.Lock()
        self._build = 0  # the build of the tree last loaded

    @classmethod
    def open(
        cls, url: str | None, home: Home, *, engine: Engine | None = None, replace: bool = False
    ) -> Store:
        """The store of ``home`` in the database at ``url`` (default: a file under the user's data
        directory), its schema migrated and the home it holds checked against ``home``.

        ``engine``: one shared by the stores of many homes, its schema already migrated
        (:func:`migrate`); it is not closed with the store. ``replace``: a home stored under the
        same name from another home file is replaced by the next build, not refused."""
        url = url or default_url(home, create=True)
        store = cls(url, home, make_engine(url) if engine is None else engine, own_engine=engine is None)
        try:
            if store._own_engine:
                migrate(store.engine)
            if not replace:
                store._check_home()
        except StoreError:
            store.close()
            raise
        except (SQLAlchemyError, DBAPIError, OSError) as e:
            store.close()
            raise StoreError(db_message(url, e)) from None
        return store

    # -- schema ---------------------------------------------------------------------------------
    def _check_home(self) -> None:
        with self.engine.begin() as conn:
            row = conn.execute(select(HomeRow.content_hash).where(HomeRow.name == self.home.name)).first()
            if row is not None and row.content_hash != self.home.content_hash:
                raise StoreError(
                    f"database {redact(self.url)}: holds the knowledge of home '{self.home.name}' "
                    f"({row.content_hash[:12]}), not of this file's home '{self.home.name}' "
                    f"({self.home.content_hash[:12]}); name the home otherwise or use another database"
                )

    @contextmanager
    def _tx(self, *, read: bool = False) -> Iterator[Connection]:
        """A transaction; ``read``: one that only reads (on SQLite it then takes no write lock,
        so it neither waits behind a correction nor holds one up)."""
        try:
            with self.engine.connect() as conn:
                if read:
                    conn.execution_options(**{READ_ONLY: True})
                with conn.begin():
                    yield conn
        except StoreError:
            raise
        except (OperationalError, DBAPIError) as e:
            if is_conflict(e):
                raise ConflictError(db_message(self.url, e)) from None
            raise StoreError(db_message(self.url, e)) from None

    def close(self) -> None:
        if self._own_engine:
            self.engine.dispose()

    # -- reading --------------------------------------------------------------------------------
    def has_tree(self) -> bool:
        with self._tx(read=True) as conn:
            row = conn.execute(select(HomeRow.built_at).where(HomeRow.name == self.home.name)).first()
            return row is not None and row[0] is not None

    def mode(self) -> str | None:
        with self._tx(read=True) as conn:
            row = conn.execute(select(HomeRow.mode).where(HomeRow.name == self.home.name)).first()
            return None if row is None else row[0]

    def load_tree(self) -> IHDRTree:
        """The tree as stored: shared nodes and clusters, and every user's layer."""
        h = self.home.name
        with self._tx(read=True) as conn:
            home_row = conn.execute(select(HomeRow).where(HomeRow.name == h)).first()
            if home_row is None or home_row.built_at is None:
                raise StoreError(f"database {redact(self.url)}: no knowledge tree yet; run homecog build")
            counters = json.loads(home_row.state or "{}")
            state = TreeState(
                mode=home_row.mode,
                nodes=[
                    NodeState(r.id, r.parent_id, r.name, r.kind, r.service, r.count, r.position_sum)
                    for r in conn.execute(select(NodeRow).where(NodeRow.home == h).order_by(NodeRow.id))
                ],
                shared=[],
                **{name: value for name, value in counters.items() if name in COUNTERS},
            )
            for row in conn.execute(
                select(ClusterRow)
                .where(ClusterRow.home == h, ClusterRow.user.is_(None))
                .order_by(ClusterRow.node_id, ClusterRow.seq, ClusterRow.id)
            ):
                state.shared.append((row.node_id, cluster_from_row(row)))
            # a user's layer is made from their corrections (user clusters of older databases
            # are left unread)
            for row in conn.execute(
                select(ExperienceRow.user, ExperienceRow.payload)
                .where(ExperienceRow.home == h, ExperienceRow.kind == "correction")
                .order_by(ExperienceRow.id)
            ):
                state.users.setdefault(row.user or "default", []).append(
                    example_from_payload(self.home, json.loads(row.payload))
                )
            try:
                tree = IHDRTree.from_state(self.home, state)
            except (ValueError, KeyError):
                raise StoreError(
                    f"database {redact(self.url)}: the stored tree does not fit the home"
                ) from None
            self._versions = {}
            for row in conn.execute(select(UserRow.name, UserRow.version).where(UserRow.home == h)):
                self._versions[row.name] = row.version
            self._build = home_row.build
            tree.layers.snapshots = self._snapshots(
                f"{home_row.build}/{home_row.built_at}/{tree.data.version}"
            )
            return tree

    def _snapshots(self, build: str) -> LayerSnapshots | None:
        """Where the users' learned layers of this database and build are kept (none for a
        database in memory)."""
        if self.url.startswith("sqlite://") and self.url.removeprefix("sqlite://") in ("", "/:memory:"):
            return None
        where = hashlib.sha256(redact(self.url).encode()).hexdigest()[:16]
        return LayerSnapshots(data_file("layers", self.home, f"-{where}"), build)

    def read_user(self, user: str) -> tuple[int, list[Example]]:
        """A user's version and corrections as committed (what a tree should hold of them)."""
        with self._tx(read=True) as conn:
            version = conn.execute(USER_VERSION, {"h": self.home.name, "u": user}).scalar_one_or_none()
            return version or 0, self._examples(conn, user)

    def _examples(self, conn: Connection, user: str, after: int = 0) -> list[Example]:
        """A user's corrections in commit order, past the first ``after`` (a user's rows are
        appended in the order their transactions commit: their row lock orders them)."""
        rows = conn.execute(
            select(ExperienceRow.payload)
            .where(
                ExperienceRow.home == self.home.name,
                ExperienceRow.kind == "correction",
                ExperienceRow.user == user,
            )
            .order_by(ExperienceRow.id)
            .offset(after)
        )
        return [example_from_payload(self.home, json.loads(p)) for (p,) in rows]

    def user_lock(self, user: str) -> threading.Lock:
        """This process's lock on ``user``'s corrections: one at a time from commit to the tree."""
        with self._locks_lock:
            return self._user_locks.setdefault(user, threading.Lock())

    def holds(self, user: str, version: int) -> None:
        """The tree this store serves holds ``user``'s corrections as of ``version``."""
        self._versions[user] = version
        self._known_users.add(user)

    # -- writing --------------------------------------------------------------------------------
    def save_build(
        self,
        tree: IHDRTree,
        samples: SampleSet | SampleLog,
        *,
        seconds: float | None = None,
        source: str | None = None,
        policy: bytes | None = None,
    ) -> None:
        """Store a freshly built tree and its samples, in one transaction, with the home file
        (``source``) and the Q tables (``policy``, the ``.npz`` bytes) it was built from.

        ``samples`` is a build's :class:`~homecog.knowledge.sample_log.SampleLog` (compact), or
        one sample set stored with its codes and readings. The users' corrections already in
        the log are kept; :func:`homecog.knowledge.core.save_build` learns them into the new
        tree first, so a rebuild (another mode, a retrained Q table) loses none of them. The
        samples replace those of the previous build in the log, so building again from the
        same Q table and seed changes neither the log nor the tree. A home stored from another
        home file (a store opened with ``replace``) is replaced whole: its log, users and
        corrections go with it.
        """
        h = self.home.name
        replaced = self.holds_other_home()
        with self._tx() as conn:
            now = datetime.now(UTC).replace(tzinfo=None)
            if replaced:
                for table in (ExperienceRow, UserRow):
                    conn.execute(delete(table).where(table.home == h))
            build_id = (conn.execute(select(func.max(ExperienceRow.id))).scalar_one() or 0) + 1
            # the log keeps the samples the tree is built from: an earlier build's go, so that
            # building again from the same samples leaves the log as it was
            conn.execute(
                delete(ExperienceRow).where(ExperienceRow.home == h, ExperienceRow.kind == "samples")
            )
            conn.execute(delete(ClusterRow).where(ClusterRow.home == h))
            conn.execute(update(NodeRow).where(NodeRow.home == h).values(parent_id=None))
            conn.execute(delete(NodeRow).where(NodeRow.home == h))
            state = tree.to_state()
            counters = {**state.counters(), BUILD_SAMPLES: len(samples)}
            values = {
                "content_hash": self.home.content_hash,
                "mode": tree.mode,
                "built_at": now,
                "state": json.dumps(counters),
                "source": source,
                "policy": policy,
            }
            moved = conn.execute(
                update(HomeRow)
                .where(HomeRow.name == h)
                .values(**values, version=HomeRow.version + 1, build=HomeRow.build + 1)
            ).rowcount
            if not moved:
                conn.execute(insert(HomeRow), [{**values, "name": h, "version": 1, "build": 1}])
            conn.execute(insert(NodeRow), _keyed(node_rows(state), h))
            self._write_clusters(conn, tree)
            if isinstance(samples, SampleLog):
                rows = log_rows(samples, build_id, tree.mode, seconds, now)
            else:
                rows = sample_rows(samples, build_id, tree.mode, seconds, now)
            conn.execute(insert(ExperienceRow), _keyed(rows, h))
            for user in tree.users:
                self._ensure_user(conn, user)
                conn.execute(
                    update(UserRow)
                    .where(UserRow.home == h, UserRow.name == user)
                    .values(version=UserRow.version + 1)
                )
        self._versions = {}
        self._build = -1  # a tree loaded earlier is not this build's

    def _write_clusters(self, conn: Connection, tree: IHDRTree) -> None:
        """Insert the shared clusters (a user's layer is their corrections in the log)."""
        pairs = [(node.id, c) for node, c in tree.shared_clusters()]
        if pairs:
            conn.execute(insert(ClusterRow), _keyed(cluster_rows(pairs, None), self.home.name))

    def _ensure_user(self, conn: Connection, user: str) -> None:
        dialect = conn.dialect.name
        values = {"home": self.home.name, "name": user, "version": 0, "corrections": 0}
        if dialect == "postgresql":
            from sqlalchemy.dialects.postgresql import insert as pg_insert

            conn.execute(pg_insert(UserRow).values(values).on_conflict_do_nothing())
        elif dialect in ("mysql", "mariadb"):
            conn.execute(insert(UserRow).values(values).prefix_with("IGNORE"))
        else:
            from sqlalchemy.dialects.sqlite import insert as sqlite_insert

            conn.execute(sqlite_insert(UserRow).values(values).on_conflict_do_nothing())

    # -- a correction's transaction (the core runs it: :mod:`homecog.knowledge.core`) ------------
    @contextmanager
    def transaction(self) -> Iterator[Connection]:
        """One transaction: committed when the block ends, rolled back when it raises
        (:class:`ConflictError` where the server aborted it for a deadlock: run it again)."""
        with self._tx() as conn:
            yield conn

    def lock_user(self, conn: Connection, user: str, have: int = 0) -> tuple[int, list[Example] | None]:
        """Lock ``user``'s row for the transaction (``SELECT … FOR UPDATE``; SQLite's write lock)
        and read their version; with it, where another process has corrected since this store's
        tree read them, their corrections committed after the first ``have`` (else ``None``)."""
        problem = user_name_problem(user)  # a key of the database: every edge checked it already
        if problem is not None:
            raise NameProblemError(problem)
        if user not in self._known_users:  # a row, once: the lock the correction takes
            self._ensure_user(conn, user)
        query = USER_VERSION_LOCKED if conn.dialect.name != "sqlite" else USER_VERSION
        version = conn.execute(query, {"h": self.home.name, "u": user}).scalar_one_or_none() or 0
        stale = version != self._versions.get(user, 0)
        return version, self._examples(conn, user, have) if stale else None

    def log_correction(self, conn: Connection, user: str, payload: dict[str, Any]) -> None:
        """Append a correction's row to the log and move its user's and home's versions on."""
        keys = {"h": self.home.name, "u": user}
        now = datetime.now(UTC).replace(tzinfo=None)
        conn.execute(LOG_CORRECTION, {**keys, "t": now, "p": json.dumps(payload)})
        conn.execute(BUMP_USER, keys)
        conn.execute(BUMP_HOME, keys)  # servers holding this home's tree see it move


def _keyed(rows: list[dict[str, Any]], home: str) -> list[dict[str, Any]]:
    """Rows under their home's name."""
    return [{**row, "home": home} for row in rows]
