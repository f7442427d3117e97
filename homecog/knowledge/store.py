"""The knowledge store: the IHDR tree and the experience log in a SQL database (SPEC §6).

SQLAlchemy 2 over SQLite (the default: a file under the user's data directory),
MariaDB/MySQL (PyMySQL) or PostgreSQL (psycopg 3). Nodes are rows with a parent; clusters
are rows of a node; every sample and correction is appended to ``experiences`` in the same
transaction as the tree update, and the tree rebuilt from that log answers identically.
The schema is created and changed by Alembic migrations (``homecog/knowledge/migrations``).

A correction locks its user's row (``SELECT … FOR UPDATE``; SQLite takes the database's
write lock), reloads that user's layer if another process changed it, applies the
correction and writes it back, so concurrent corrections lose nothing.

The learner never touches SQL: this module maps the tree to rows and back.
"""

from __future__ import annotations

import json
import os
import random
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import (
    BigInteger,
    DateTime,
    Double,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    create_engine,
    delete,
    event,
    func,
    insert,
    select,
    text,
    update,
)
from sqlalchemy.dialects import mysql
from sqlalchemy.engine import Connection, Engine, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError, OperationalError, SQLAlchemyError
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from homecog.errors import HomecogError
from homecog.home.model import Home
from homecog.knowledge import sample_log
from homecog.knowledge.ihdr import IHDRTree
from homecog.knowledge.model import Cluster, Numeric
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.space import Point
from homecog.knowledge.state import NodeState, TreeState
from homecog.paths import data_dir

SCHEMA_VERSION = "0001"
_LongBlob = LargeBinary().with_variant(mysql.LONGBLOB(), "mysql", "mariadb")
_LongText = Text().with_variant(mysql.LONGTEXT(), "mysql", "mariadb")
SAMPLES_PER_ROW = 32768
CONFLICT_RETRIES = 50  # attempts of a correction that the server aborts for a deadlock
CONNECT_TIMEOUT = 10  # seconds to wait for a database server (unless the URL says connect_timeout)


class StoreError(HomecogError):
    """A database that cannot be reached, or that holds knowledge of another home."""


class _ConflictError(StoreError):
    """A transaction the server aborted for a deadlock or a serialization failure: retry it."""


def _is_conflict(e: DBAPIError) -> bool:
    orig = e.orig
    code = orig.args[0] if orig is not None and orig.args else None
    # MySQL/MariaDB 1213: deadlock; PostgreSQL 40P01: deadlock, 40001: serialization failure
    return code == 1213 or getattr(orig, "sqlstate", None) in ("40P01", "40001")


class Base(DeclarativeBase):
    pass


class HomeRow(Base):
    """The home this database is made for (one per database)."""

    __tablename__ = "homes"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    content_hash: Mapped[str] = mapped_column(String(64))
    mode: Mapped[str] = mapped_column(String(16))
    built_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)
    state: Mapped[str | None] = mapped_column(_LongText, nullable=True)  # JSON: precedence, counters


class NodeRow(Base):
    """A node of the tree: root, category or service, with its parent."""

    __tablename__ = "nodes"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    parent_id: Mapped[int | None] = mapped_column(ForeignKey("nodes.id"), nullable=True)
    name: Mapped[str] = mapped_column(String(200))
    kind: Mapped[str] = mapped_column(String(16))
    service: Mapped[int] = mapped_column(Integer)
    count: Mapped[int] = mapped_column(BigInteger)
    position_sum: Mapped[float] = mapped_column(Double)


class ClusterRow(Base):
    """A cluster of a node; ``user`` is NULL for the shared tree, else the user's layer."""

    __tablename__ = "clusters"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    node_id: Mapped[int] = mapped_column(ForeignKey("nodes.id"), index=True)
    user: Mapped[str | None] = mapped_column(String(200), nullable=True, index=True)
    tree_id: Mapped[int] = mapped_column(BigInteger)
    polarity: Mapped[int] = mapped_column(Integer)
    conditions: Mapped[str] = mapped_column(_LongText)
    count: Mapped[int] = mapped_column(BigInteger)
    position_sum: Mapped[float] = mapped_column(Double)
    seq: Mapped[int] = mapped_column(BigInteger)
    seed: Mapped[str | None] = mapped_column(Text, nullable=True)


class UserRow(Base):
    """A household member: the lock their corrections take, and a version for caches."""

    __tablename__ = "users"
    name: Mapped[str] = mapped_column(String(200), primary_key=True)
    version: Mapped[int] = mapped_column(BigInteger, default=0)
    corrections: Mapped[int] = mapped_column(BigInteger, default=0)


class ExperienceRow(Base):
    """The append-only experience log: sample batches, single samples and corrections."""

    __tablename__ = "experiences"
    __table_args__ = (Index("ix_experiences_kind_user_id", "kind", "user", "id"),)  # the history
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    kind: Mapped[str] = mapped_column(String(16))
    user: Mapped[str | None] = mapped_column(String(200), nullable=True)
    created_at: Mapped[datetime] = mapped_column(DateTime)
    payload: Mapped[str | None] = mapped_column(_LongText, nullable=True)
    data: Mapped[bytes | None] = mapped_column(_LongBlob, nullable=True)


# -- urls and engines ---------------------------------------------------------------------------
def default_url(home: Home) -> str:
    """``$HOMECOG_DB`` or a SQLite file under the data directory, one per home."""
    env = os.environ.get("HOMECOG_DB")
    if env:
        return env
    path = data_dir() / "knowledge" / f"{home.name}-{home.content_hash[:16]}.sqlite"
    return f"sqlite:///{path}"


def redact(url: str) -> str:
    """A URL without its password, for messages."""
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        return url


def make_engine(url: str) -> Engine:
    """An engine for a URL; SQLite gets WAL, a busy timeout and immediate write transactions."""
    try:
        if url.startswith("sqlite"):
            path = url.split("///", 1)[1] if "///" in url else ""
            if path and path != ":memory:":
                Path(path).parent.mkdir(parents=True, exist_ok=True)
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
                conn.exec_driver_sql("BEGIN IMMEDIATE")

            return engine
        # a server that drops packets must not hang a command: libpq waits forever by default
        parsed = make_url(url)
        connect_args: dict[str, Any] = {}
        if (
            parsed.get_backend_name() in ("postgresql", "mysql", "mariadb")
            and "connect_timeout" not in parsed.query
        ):
            connect_args["connect_timeout"] = CONNECT_TIMEOUT
        return create_engine(url, pool_pre_ping=True, connect_args=connect_args)
    except (ArgumentError, NoSuchModuleError, ValueError) as e:
        raise StoreError(f"--db {redact(url)}: not a database URL ({e})") from None
    except ImportError as e:
        raise StoreError(f"--db {redact(url)}: driver missing ({e.name}); install it with pip") from None
    except OSError as e:
        raise StoreError(f"--db {redact(url)}: {e.strerror}") from None


def _db_message(url: str, e: BaseException) -> str:
    orig = getattr(e, "orig", None) or e
    text_ = str(orig).strip().splitlines()[0] if str(orig).strip() else type(orig).__name__
    return f"--db {redact(url)}: cannot use the database: {text_}"


# -- encoding the tree -------------------------------------------------------------------------
def _encode_conditions(conditions: dict[int, Any]) -> str:
    out = {}
    for j, cond in sorted(conditions.items()):
        if isinstance(cond, Numeric):
            out[str(j)] = {"n": cond.count, "sum": cond.total, "low": cond.low, "high": cond.high}
        else:
            out[str(j)] = sorted(cond)
    return json.dumps(out, separators=(",", ":"))


def _decode_conditions(text_: str) -> dict[int, Any]:
    out: dict[int, Any] = {}
    for j, cond in json.loads(text_).items():
        if isinstance(cond, dict):
            out[int(j)] = Numeric(count=cond["n"], total=cond["sum"], low=cond["low"], high=cond["high"])
        else:
            out[int(j)] = frozenset(cond)
    return out


class Store:
    """The knowledge of one home in one database.

    >>> from homecog.home import load_home
    >>> store = Store("sqlite://", load_home("paper"))   # in memory
    >>> store.has_tree()
    False
    """

    def __init__(self, url: str | None, home: Home) -> None:
        self.home = home
        self.url = url or default_url(home)
        self.engine = make_engine(self.url)
        self._versions: dict[str, int] = {}
        self._known_users: set[str] = set()
        try:
            self._migrate()
            self._check_home()
        except StoreError:
            self.engine.dispose()
            raise
        except (SQLAlchemyError, DBAPIError, OSError) as e:
            self.engine.dispose()
            raise StoreError(_db_message(self.url, e)) from None

    # -- schema ---------------------------------------------------------------------------------
    def _migrate(self) -> None:
        from alembic import command
        from alembic.config import Config

        cfg = Config()
        cfg.set_main_option("script_location", str(Path(__file__).parent / "migrations"))
        with self.engine.begin() as conn:
            cfg.attributes["connection"] = conn
            command.upgrade(cfg, "head")

    def _check_home(self) -> None:
        with self.engine.begin() as conn:
            row = conn.execute(select(HomeRow).where(HomeRow.id == 1)).first()
            if row is None:
                return
            if row.content_hash != self.home.content_hash:
                raise StoreError(
                    f"--db {redact(self.url)}: holds the knowledge of home '{row.name}' "
                    f"({row.content_hash[:12]}), not of home '{self.home.name}' "
                    f"({self.home.content_hash[:12]}); use another database"
                )

    @contextmanager
    def _tx(self) -> Iterator[Connection]:
        try:
            with self.engine.begin() as conn:
                yield conn
        except StoreError:
            raise
        except (OperationalError, DBAPIError) as e:
            if _is_conflict(e):
                raise _ConflictError(_db_message(self.url, e)) from None
            raise StoreError(_db_message(self.url, e)) from None

    def close(self) -> None:
        self.engine.dispose()

    # -- reading --------------------------------------------------------------------------------
    def has_tree(self) -> bool:
        with self._tx() as conn:
            row = conn.execute(select(HomeRow.built_at).where(HomeRow.id == 1)).first()
            return row is not None and row[0] is not None

    def mode(self) -> str | None:
        with self._tx() as conn:
            row = conn.execute(select(HomeRow.mode).where(HomeRow.id == 1)).first()
            return None if row is None else row[0]

    def counts(self) -> dict[str, int]:
        """Rows per table: nodes, clusters (shared and per user), experiences, users."""
        with self._tx() as conn:
            return {
                "nodes": conn.execute(select(func.count()).select_from(NodeRow)).scalar_one(),
                "clusters": conn.execute(
                    select(func.count()).select_from(ClusterRow).where(ClusterRow.user.is_(None))
                ).scalar_one(),
                "user_clusters": conn.execute(
                    select(func.count()).select_from(ClusterRow).where(ClusterRow.user.is_not(None))
                ).scalar_one(),
                "experiences": conn.execute(select(func.count()).select_from(ExperienceRow)).scalar_one(),
                "corrections": conn.execute(
                    select(func.count()).select_from(ExperienceRow).where(ExperienceRow.kind == "correction")
                ).scalar_one(),
                "users": conn.execute(select(func.count()).select_from(UserRow)).scalar_one(),
            }

    def experience_count(self) -> int:
        """Experiences in the log: every sample of every build, every single sample and correction."""
        with self._tx() as conn:
            rows = conn.execute(select(ExperienceRow.kind, ExperienceRow.payload))
            return sum(json.loads(p).get("count", 0) if k == "samples" else 1 for k, p in rows)

    def load_tree(self) -> IHDRTree:
        """The tree as stored: shared nodes and clusters, and every user's layer."""
        with self._tx() as conn:
            home_row = conn.execute(select(HomeRow).where(HomeRow.id == 1)).first()
            if home_row is None or home_row.built_at is None:
                raise StoreError(f"--db {redact(self.url)}: no knowledge tree yet; run homecog build")
            counters = json.loads(home_row.state or "{}")
            state = TreeState(
                mode=home_row.mode,
                nodes=[
                    NodeState(r.id, r.parent_id, r.name, r.kind, r.service, r.count, r.position_sum)
                    for r in conn.execute(select(NodeRow).order_by(NodeRow.id))
                ],
                shared=[],
                precedence=counters.get("precedence", []),
                next_id=counters.get("next_id", 0),
                seq=counters.get("seq", 0),
                n_experiences=counters.get("n_experiences", 0),
            )
            service_of = {n.id: n.service for n in state.nodes}
            for row in conn.execute(
                select(ClusterRow).order_by(
                    ClusterRow.user, ClusterRow.node_id, ClusterRow.seq, ClusterRow.id
                )
            ):
                cluster = self._cluster(row)
                if row.user is None:
                    state.shared.append((row.node_id, cluster))
                else:
                    state.users.setdefault(row.user, {}).setdefault(service_of[row.node_id], []).append(
                        cluster
                    )
            try:
                tree = IHDRTree.from_state(self.home, state)
            except (ValueError, KeyError):
                raise StoreError(f"--db {redact(self.url)}: the stored tree does not fit the home") from None
            for row in conn.execute(select(UserRow.name, UserRow.version)):
                self._versions[row.name] = row.version
            return tree

    @staticmethod
    def _cluster(row: Any) -> Cluster:
        return Cluster(
            id=row.tree_id,
            conditions=_decode_conditions(row.conditions),
            count=row.count,
            position_sum=row.position_sum,
            user=row.user,
            polarity=row.polarity,
            seed=None if row.seed is None else tuple(json.loads(row.seed)),
            seq=row.seq,
        )

    def refresh_user(self, tree: IHDRTree, user: str) -> None:
        """Reload a user's layer when another process has corrected since it was read."""
        with self._tx() as conn:
            self._reload_user_if_stale(conn, tree, user, lock=False)

    def _reload_user_if_stale(self, conn: Connection, tree: IHDRTree, user: str, *, lock: bool) -> int:
        query = select(UserRow.version).where(UserRow.name == user)
        if lock and conn.dialect.name != "sqlite":
            query = query.with_for_update()
        version = conn.execute(query).scalar_one_or_none() or 0
        if version != self._versions.get(user, 0):
            layer: dict[int, list[Cluster]] = {}
            rows = conn.execute(
                select(ClusterRow)
                .where(ClusterRow.user == user)
                .order_by(ClusterRow.node_id, ClusterRow.seq, ClusterRow.id)
            )
            service_of = {n.id: n.service for n in tree.root.iter_dfs()}
            for row in rows:
                layer.setdefault(service_of[row.node_id], []).append(self._cluster(row))
            tree.set_user_layer(user, layer)
            self._versions[user] = version
        return version

    # -- writing --------------------------------------------------------------------------------
    def save_build(
        self, tree: IHDRTree, samples: SampleSet | SampleLog, *, seconds: float | None = None
    ) -> None:
        """Store a freshly built tree and its samples, in one transaction.

        ``samples`` is a build's :class:`~homecog.knowledge.sample_log.SampleLog` (compact), or
        one sample set stored with its codes and readings. Users' corrections already in the
        log are replayed on the new tree, so a rebuild (another mode, a retrained Q table)
        loses none of them.
        """
        corrections = self._corrections()
        for kind, user, payload in corrections:
            tree.replay(kind, user, payload)
        with self._tx() as conn:
            now = datetime.now(UTC).replace(tzinfo=None)
            build_id = (conn.execute(select(func.max(ExperienceRow.id))).scalar_one() or 0) + 1
            conn.execute(delete(ClusterRow))
            conn.execute(update(NodeRow).values(parent_id=None))
            conn.execute(delete(NodeRow))
            conn.execute(delete(HomeRow))
            conn.execute(
                insert(HomeRow),
                [
                    {
                        "id": 1,
                        "name": self.home.name,
                        "content_hash": self.home.content_hash,
                        "mode": tree.mode,
                        "built_at": now,
                        "state": json.dumps(tree.to_state().counters()),
                    }
                ],
            )
            self._write_nodes(conn, tree)
            self._write_clusters(conn, tree, None)
            for user in tree.users:
                self._write_clusters(conn, tree, user)
            if isinstance(samples, SampleLog):
                rows = self._log_rows(samples, build_id, tree.mode, seconds, now)
            else:
                rows = self._sample_rows(samples, build_id, tree.mode, seconds, now)
            conn.execute(insert(ExperienceRow), rows)
            for user in tree.users:
                self._ensure_user(conn, user)
                conn.execute(update(UserRow).where(UserRow.name == user).values(version=UserRow.version + 1))
        self._versions = {}

    @staticmethod
    def _log_rows(
        log: SampleLog, build_id: int, mode: str, seconds: float | None, now: datetime
    ) -> list[dict[str, Any]]:
        return [
            {
                "kind": "samples",
                "user": None,
                "created_at": now,
                "payload": json.dumps(
                    {
                        **payload,
                        "build": build_id,
                        "part": i,
                        "parts": len(log.parts),
                        "mode": mode,
                        "seconds": seconds,
                    }
                ),
                "data": blob,
            }
            for i, (payload, blob) in enumerate(log.parts)
        ]

    @staticmethod
    def _sample_rows(
        samples: SampleSet, build_id: int, mode: str, seconds: float | None, now: datetime
    ) -> list[dict[str, Any]]:
        parts = max(1, -(-len(samples) // SAMPLES_PER_ROW))
        numeric = [j for j, d in enumerate(samples.space.dims) if d.numeric]
        rows = []
        for part in range(parts):
            chunk = slice(part * SAMPLES_PER_ROW, (part + 1) * SAMPLES_PER_ROW)
            rows.append(
                {
                    "kind": "samples",
                    "user": None,
                    "created_at": now,
                    "payload": json.dumps(
                        {
                            "build": build_id,
                            "part": part,
                            "parts": parts,
                            "mode": mode,
                            "seconds": seconds,
                            "count": len(samples.codes[chunk]),
                        }
                    ),
                    "data": sample_log.pack(
                        {
                            "codes": samples.codes[chunk],
                            "readings": samples.readings[chunk][:, numeric],
                            "numeric": np.array(numeric, dtype=np.int64),
                            "positions": samples.positions[chunk],
                            "masks": samples.masks[chunk],
                        }
                    ),
                }
            )
        return rows

    def _write_nodes(self, conn: Connection, tree: IHDRTree) -> None:
        conn.execute(
            insert(NodeRow),
            [
                {
                    "id": n.id,
                    "parent_id": n.parent.id if n.parent else None,
                    "name": n.name,
                    "kind": n.kind,
                    "service": n.service,
                    "count": n.count,
                    "position_sum": n.position_sum,
                }
                for n in tree.root.iter_dfs()
            ],
        )

    def _write_clusters(
        self, conn: Connection, tree: IHDRTree, user: str | None, services: set[int] | None = None
    ) -> None:
        if user is None:
            pairs = list(tree.shared_clusters())
        else:
            nodes = {n.service: n for n in tree.root.iter_dfs() if n.kind == "service"}
            pairs = [
                (nodes[a], c)
                for a, cs in sorted(tree.user_clusters(user).items())
                if services is None or a in services
                for c in cs
            ]
        if pairs:
            conn.execute(
                insert(ClusterRow),
                [
                    {
                        "node_id": node.id,
                        "user": user,
                        "tree_id": c.id,
                        "polarity": c.polarity,
                        "conditions": _encode_conditions(c.conditions),
                        "count": c.count,
                        "position_sum": c.position_sum,
                        "seq": c.seq,
                        "seed": None if c.seed is None else json.dumps(list(c.seed)),
                    }
                    for node, c in pairs
                ],
            )

    def _ensure_user(self, conn: Connection, user: str) -> None:
        dialect = conn.dialect.name
        values = {"name": user, "version": 0, "corrections": 0}
        if dialect == "postgresql":
            from sqlalchemy.dialects.postgresql import insert as pg_insert

            conn.execute(pg_insert(UserRow).values(values).on_conflict_do_nothing())
        elif dialect in ("mysql", "mariadb"):
            conn.execute(insert(UserRow).values(values).prefix_with("IGNORE"))
        else:
            from sqlalchemy.dialects.sqlite import insert as sqlite_insert

            conn.execute(sqlite_insert(UserRow).values(values).on_conflict_do_nothing())

    def correct(
        self, tree: IHDRTree, point: Point, want: list[str], user: str
    ) -> tuple[list[str], list[str]]:
        """Apply and store a correction in one transaction; returns (added, rejected).

        A transaction the server aborts for a deadlock between concurrent corrections
        (MariaDB's locks on the users and clusters indexes) is run again.
        """
        for attempt in range(CONFLICT_RETRIES):
            try:
                return self._correct_once(tree, point, want, user)
            except _ConflictError:
                if attempt == CONFLICT_RETRIES - 1:
                    raise
                time.sleep(random.uniform(0, 0.01 * (attempt + 1)))
        raise AssertionError("unreachable")

    def _correct_once(
        self, tree: IHDRTree, point: Point, want: list[str], user: str
    ) -> tuple[list[str], list[str]]:
        if not user or len(user) > 200:
            raise StoreError("--user must be 1 to 200 characters")
        try:
            with self._tx() as conn:
                if user not in self._known_users:  # a row, once: the lock the correction takes
                    self._ensure_user(conn, user)
                version = self._reload_user_if_stale(conn, tree, user, lock=True)
                added, rejected = tree.correct_one(point, want, user)
                touched = {tree.home.service_index(s) for s in added + rejected}
                if touched:
                    node_ids = [
                        n.id for n in tree.root.iter_dfs() if n.kind == "service" and n.service in touched
                    ]
                    conn.execute(
                        delete(ClusterRow).where(ClusterRow.user == user, ClusterRow.node_id.in_(node_ids))
                    )
                    self._write_clusters(conn, tree, user, touched)
                payload = {
                    "context": tree.space.context(point),
                    "codes": list(point.codes),
                    "readings": list(point.readings),
                    "want": want,
                    "added": added,
                    "rejected": rejected,
                }
                conn.execute(
                    insert(ExperienceRow),
                    [
                        {
                            "kind": "correction",
                            "user": user,
                            "created_at": datetime.now(UTC).replace(tzinfo=None),
                            "payload": json.dumps(payload),
                            "data": None,
                        }
                    ],
                )
                conn.execute(
                    update(UserRow)
                    .where(UserRow.name == user)
                    .values(version=UserRow.version + 1, corrections=UserRow.corrections + 1)
                )
        except BaseException:
            self._versions.pop(user, None)  # the tree may hold what did not commit: reload next time
            tree.set_user_layer(user, {})
            raise
        self._versions[user] = version + 1
        self._known_users.add(user)
        return added, rejected

    # -- the log ----------------------------------------------------------------------------------
    def _corrections(self) -> list[tuple[str, str | None, dict[str, Any]]]:
        with self._tx() as conn:
            rows = conn.execute(
                select(ExperienceRow.kind, ExperienceRow.user, ExperienceRow.payload)
                .where(ExperienceRow.kind.in_(["correction", "sample"]))
                .order_by(ExperienceRow.id)
            )
            return [(r.kind, r.user, json.loads(r.payload)) for r in rows]

    def rebuild(self) -> IHDRTree:
        """The tree rebuilt from the experience log alone: the last build's samples, then every
        single sample and correction in the order they were committed."""
        with self._tx() as conn:
            rows = conn.execute(
                select(
                    ExperienceRow.id,
                    ExperienceRow.kind,
                    ExperienceRow.user,
                    ExperienceRow.payload,
                    ExperienceRow.data,
                ).order_by(ExperienceRow.id)
            ).all()
        builds = [json.loads(r.payload)["build"] for r in rows if r.kind == "samples"]
        if not builds:
            raise StoreError(f"--db {redact(self.url)}: the log holds no samples; run homecog build")
        last = max(builds)
        parts = [r for r in rows if r.kind == "samples" and json.loads(r.payload)["build"] == last]
        parts.sort(key=lambda r: json.loads(r.payload)["part"])
        meta = json.loads(parts[0].payload)
        tree = IHDRTree(self.home, mode=meta["mode"])
        if meta.get("format") == sample_log.FORMAT:
            logged = [(json.loads(r.payload), r.data) for r in parts]
            try:
                for samples in sample_log.regenerate(self.home, logged):
                    tree.learn_many(samples)
            except ValueError as e:
                raise StoreError(f"--db {redact(self.url)}: {e}") from None
        else:
            tree.learn_many(self._samples_from([sample_log.unpack(r.data) for r in parts]))
        for r in rows:
            if r.kind in ("correction", "sample"):
                tree.replay(r.kind, r.user, json.loads(r.payload))
        return tree

    def _samples_from(self, arrays: list[dict[str, np.ndarray]]) -> SampleSet:
        from homecog.knowledge.space import Space

        space = Space(self.home)
        codes = np.concatenate([a["codes"] for a in arrays])
        readings = np.full((len(codes), len(space.dims)), np.nan)
        numeric = arrays[0]["numeric"]
        readings[:, numeric] = np.concatenate([a["readings"] for a in arrays])
        return SampleSet(
            space=space,
            codes=codes,
            readings=readings,
            positions=np.concatenate([a["positions"] for a in arrays]),
            masks=np.concatenate([a["masks"] for a in arrays]),
        )

    def drop_all(self) -> None:
        """Remove every table (tests use it to leave a server database clean)."""
        with self.engine.begin() as conn:
            Base.metadata.drop_all(conn)
            conn.execute(text("DROP TABLE IF EXISTS alembic_version"))
