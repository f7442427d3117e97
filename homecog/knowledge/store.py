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
import random
import time
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy import delete, func, insert, select, text, update
from sqlalchemy.engine import Connection
from sqlalchemy.exc import DBAPIError, OperationalError, SQLAlchemyError

from homecog.errors import ConflictError, StoreError
from homecog.home.codec import Point
from homecog.home.model import Home
from homecog.knowledge import sample_log
from homecog.knowledge.database import (
    db_message,
    default_url,
    is_conflict,
    make_engine,
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
    samples_from,
)
from homecog.knowledge.sample_log import SampleLog
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.schema import Base, ClusterRow, ExperienceRow, HomeRow, NodeRow, UserRow
from homecog.knowledge.state import NodeState, TreeState

__all__ = ["Store", "StoreError", "default_url", "redact"]
SAMPLES_PER_ROW = 32768
CONFLICT_RETRIES = 50  # attempts of a correction that the server aborts for a deadlock


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
        self._batch: Connection | None = None  # the transaction corrections share (see batch)
        try:
            self._migrate()
            self._check_home()
        except StoreError:
            self.engine.dispose()
            raise
        except (SQLAlchemyError, DBAPIError, OSError) as e:
            self.engine.dispose()
            raise StoreError(db_message(self.url, e)) from None

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
        if self._batch is not None:  # inside batch(): its transaction
            yield self._batch
            return
        try:
            with self.engine.begin() as conn:
                yield conn
        except StoreError:
            raise
        except (OperationalError, DBAPIError) as e:
            if is_conflict(e):
                raise ConflictError(db_message(self.url, e)) from None
            raise StoreError(db_message(self.url, e)) from None

    def close(self) -> None:
        self.engine.dispose()

    @contextmanager
    def batch(self) -> Iterator[None]:
        """Corrections made inside share one transaction: all of them are stored, or none.

        On an error the tree may hold corrections that were not stored: load it again.
        """
        if self._batch is not None:
            raise StoreError("a batch of corrections is already open")
        try:
            with self._tx() as conn:
                self._batch = conn
                try:
                    yield
                finally:
                    self._batch = None
        except BaseException:
            self._versions.clear()  # what this process believes of every user may not be stored
            raise

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
            # single samples and corrections: one indexed count; every build's samples: the
            # total the last build wrote beside the tree
            others = conn.execute(
                select(func.count()).select_from(ExperienceRow).where(ExperienceRow.kind != "samples")
            ).scalar_one()
            return others + self._samples_logged(conn)

    @staticmethod
    def _samples_logged(conn: Connection) -> int:
        """Samples in the log, of every build (read from the sample batches in databases older
        than that count)."""
        state = conn.execute(select(HomeRow.state).where(HomeRow.id == 1)).scalar_one_or_none()
        counters = json.loads(state or "{}")
        if "samples_logged" in counters:
            return int(counters["samples_logged"])
        batches = conn.execute(select(ExperienceRow.payload).where(ExperienceRow.kind == "samples"))
        return sum(json.loads(p).get("count", 0) for (p,) in batches)

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
            for row in conn.execute(
                select(ClusterRow)
                .where(ClusterRow.user.is_(None))
                .order_by(ClusterRow.node_id, ClusterRow.seq, ClusterRow.id)
            ):
                state.shared.append((row.node_id, cluster_from_row(row)))
            # a user's layer is made from their corrections (user clusters of older databases
            # are left unread)
            for row in conn.execute(
                select(ExperienceRow.user, ExperienceRow.payload)
                .where(ExperienceRow.kind == "correction")
                .order_by(ExperienceRow.id)
            ):
                state.users.setdefault(row.user or "default", []).append(
                    example_from_payload(self.home, json.loads(row.payload))
                )
            try:
                tree = IHDRTree.from_state(self.home, state)
            except (ValueError, KeyError):
                raise StoreError(f"--db {redact(self.url)}: the stored tree does not fit the home") from None
            for row in conn.execute(select(UserRow.name, UserRow.version)):
                self._versions[row.name] = row.version
            return tree

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
            rows = conn.execute(
                select(ExperienceRow.payload)
                .where(ExperienceRow.kind == "correction", ExperienceRow.user == user)
                .order_by(ExperienceRow.id)
            )
            tree.set_user_examples(user, [example_from_payload(self.home, json.loads(p)) for (p,) in rows])
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
            logged = self._samples_logged(conn) + len(samples)
            conn.execute(delete(ClusterRow))
            conn.execute(update(NodeRow).values(parent_id=None))
            conn.execute(delete(NodeRow))
            conn.execute(delete(HomeRow))
            state = tree.to_state()
            counters = {**state.counters(), "samples_logged": logged}
            home_row = {
                "id": 1,
                "name": self.home.name,
                "content_hash": self.home.content_hash,
                "mode": tree.mode,
                "built_at": now,
                "state": json.dumps(counters),
            }
            conn.execute(insert(HomeRow), [home_row])
            conn.execute(insert(NodeRow), node_rows(state))
            self._write_clusters(conn, tree)
            if isinstance(samples, SampleLog):
                rows = log_rows(samples, build_id, tree.mode, seconds, now)
            else:
                rows = sample_rows(samples, build_id, tree.mode, seconds, now)
            conn.execute(insert(ExperienceRow), rows)
            for user in tree.users:
                self._ensure_user(conn, user)
                conn.execute(update(UserRow).where(UserRow.name == user).values(version=UserRow.version + 1))
        self._versions = {}

    def _write_clusters(self, conn: Connection, tree: IHDRTree) -> None:
        """Insert the shared clusters (a user's layer is their corrections in the log)."""
        pairs = [(node.id, c) for node, c in tree.shared_clusters()]
        if pairs:
            conn.execute(insert(ClusterRow), cluster_rows(pairs, None))

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
        if self._batch is not None:  # a conflict aborts the whole batch: nothing to retry here
            return self._correct_once(tree, point, want, user)
        for attempt in range(CONFLICT_RETRIES):
            try:
                return self._correct_once(tree, point, want, user)
            except ConflictError:
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
            tree.set_user_examples(user, [])
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
            tree.learn_many(samples_from(self.home, [sample_log.unpack(r.data) for r in parts]))
        for r in rows:
            if r.kind in ("correction", "sample"):
                tree.replay(r.kind, r.user, json.loads(r.payload))
        return tree

    def drop_all(self) -> None:
        """Remove every table (tests use it to leave a server database clean)."""
        with self.engine.begin() as conn:
            Base.metadata.drop_all(conn)
            conn.execute(text("DROP TABLE IF EXISTS alembic_version"))
