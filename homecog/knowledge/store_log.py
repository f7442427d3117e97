"""Reading a home's experience log: the counts of its rows, the single samples and corrections
in commit order and the last build's samples (what a tree rebuilt from the log alone learns,
:func:`homecog.knowledge.core.rebuild`);
and whether a tree in memory is stale (the home's version, the users corrected since).

A part of :class:`~homecog.knowledge.store.Store`; every query is under the store's home.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Any

from sqlalchemy import func, select, text
from sqlalchemy.engine import Connection, Engine

from homecog.errors import StoreError
from homecog.knowledge import sample_log
from homecog.knowledge.corrections import Example
from homecog.knowledge.database import redact
from homecog.knowledge.rows import samples_from
from homecog.knowledge.samples import SampleSet
from homecog.knowledge.schema import Base, ClusterRow, ExperienceRow, HomeRow, NodeRow, UserRow

if TYPE_CHECKING:
    from homecog.home.model import Home

# the key of the homes row's counters that holds how many samples the tree was built from
# (``samples_logged``, of older databases, summed every build's and is no longer read)
BUILD_SAMPLES = "build_samples"


class StoreLog:
    """The log's side of a store (mixed into :class:`~homecog.knowledge.store.Store`)."""

    home: Home
    url: str
    engine: Engine
    _build: int
    _versions: dict[str, int]

    def _tx(self, *, read: bool = False) -> AbstractContextManager[Connection]:  # the store's
        raise NotImplementedError

    def home_version(self) -> tuple[int, int] | None:
        """``(version, build)`` of the home: the version moves on every write, the build on every
        build; ``None`` when the database has no such home. One primary-key lookup."""
        with self._tx(read=True) as conn:
            row = conn.execute(
                select(HomeRow.version, HomeRow.build).where(HomeRow.name == self.home.name)
            ).first()
            return None if row is None else (row.version, row.build)

    def stale_users(self) -> list[str] | None:
        """The users whose corrections other processes changed since this store's tree read
        them; ``None`` after another build (the whole tree is then to be loaded again)."""
        with self._tx(read=True) as conn:
            build = conn.execute(select(HomeRow.build).where(HomeRow.name == self.home.name)).scalar()
            if build != self._build:
                return None
            rows = conn.execute(
                select(UserRow.name, UserRow.version).where(UserRow.home == self.home.name)
            ).all()
            return [name for name, version in rows if version != self._versions.get(name, 0)]

    def user_after(self, user: str, have: int) -> tuple[int, list[Example]]:
        """A user's version and their corrections committed after the first ``have``."""
        with self._tx(read=True) as conn:
            version = conn.execute(
                select(UserRow.version).where(UserRow.home == self.home.name, UserRow.name == user)
            ).scalar_one_or_none()
            return version or 0, self._examples(conn, user, have)  # type: ignore[attr-defined]

    def counts(self) -> dict[str, int]:
        """Rows of the home per table: nodes, clusters (shared and per user), experiences, users."""
        h = self.home.name

        def count(table: Any, *where: Any) -> int:
            query = select(func.count()).select_from(table).where(table.home == h, *where)
            return conn.execute(query).scalar_one()

        with self._tx(read=True) as conn:
            return {
                "nodes": count(NodeRow),
                "clusters": count(ClusterRow, ClusterRow.user.is_(None)),
                "user_clusters": count(ClusterRow, ClusterRow.user.is_not(None)),
                "experiences": count(ExperienceRow),
                "corrections": count(ExperienceRow, ExperienceRow.kind == "correction"),
                "users": count(UserRow),
            }

    def experience_count(self) -> int:
        """Experiences in the log: the samples of the build the tree is built from, and every
        single sample and correction (what :meth:`rebuild` learns; an earlier build's samples
        are not counted, nor kept)."""
        with self._tx(read=True) as conn:
            # single samples and corrections: one indexed count; the build's samples: the
            # count the build wrote beside the tree
            others = conn.execute(
                select(func.count())
                .select_from(ExperienceRow)
                .where(ExperienceRow.home == self.home.name, ExperienceRow.kind != "samples")
            ).scalar_one()
            return others + self._samples_logged(conn)

    def _samples_logged(self, conn: Connection) -> int:
        """Samples of the last build (read from its sample batches in databases older than that
        count, whose log may still hold earlier builds' batches)."""
        state = conn.execute(select(HomeRow.state).where(HomeRow.name == self.home.name)).scalar_one_or_none()
        counters = json.loads(state or "{}")
        if BUILD_SAMPLES in counters:
            return int(counters[BUILD_SAMPLES])
        batches = conn.execute(
            select(ExperienceRow.payload).where(
                ExperienceRow.home == self.home.name, ExperienceRow.kind == "samples"
            )
        )
        parts = [json.loads(p) for (p,) in batches]
        last = max((p["build"] for p in parts), default=None)
        return sum(p.get("count", 0) for p in parts if p["build"] == last)

    def holds_other_home(self) -> bool:
        """Whether the database holds this home's name for other content (another home file): a
        store opened to replace it, whose next build replaces it whole."""
        with self._tx(read=True) as conn:
            stored = conn.execute(select(HomeRow.content_hash).where(HomeRow.name == self.home.name)).scalar()
        return stored is not None and stored != self.home.content_hash

    def singles(self) -> list[tuple[str, str | None, dict[str, Any]]]:
        """Every single sample and correction of the log, ``(kind, user, payload)``, in the order
        they were committed."""
        with self._tx(read=True) as conn:
            rows = conn.execute(
                select(ExperienceRow.kind, ExperienceRow.user, ExperienceRow.payload)
                .where(ExperienceRow.home == self.home.name, ExperienceRow.kind.in_(["correction", "sample"]))
                .order_by(ExperienceRow.id)
            )
            return [(r.kind, r.user, json.loads(r.payload)) for r in rows]

    def last_build(self) -> tuple[str, Iterator[SampleSet]]:
        """The mode of the last build and its samples as the log keeps them (made again from
        the compact log part by part); :class:`StoreError` when the log holds none."""
        with self._tx(read=True) as conn:
            rows = conn.execute(
                select(ExperienceRow.payload, ExperienceRow.data)
                .where(ExperienceRow.home == self.home.name, ExperienceRow.kind == "samples")
                .order_by(ExperienceRow.id)
            ).all()
        parts = [(json.loads(r.payload), r.data) for r in rows]
        if not parts:
            raise StoreError(f"database {redact(self.url)}: the log holds no samples; run homecog build")
        last = max(meta["build"] for meta, _ in parts)
        parts = sorted((p for p in parts if p[0]["build"] == last), key=lambda p: p[0]["part"])
        return parts[0][0]["mode"], self._sample_sets(parts)

    def _sample_sets(self, parts: list[tuple[dict[str, Any], bytes]]) -> Iterator[SampleSet]:
        if parts[0][0].get("format") != sample_log.FORMAT:
            yield samples_from(self.home, [sample_log.unpack(data) for _, data in parts])
            return
        try:
            yield from sample_log.regenerate(self.home, parts)
        except ValueError as e:
            raise StoreError(f"database {redact(self.url)}: {e}") from None

    def drop_all(self) -> None:
        """Remove every table (tests use it to leave a server database clean)."""
        with self.engine.begin() as conn:
            Base.metadata.drop_all(conn)
            conn.execute(text("DROP TABLE IF EXISTS alembic_version"))


def stored_homes(conn: Connection) -> Iterator[tuple[str, str, bool]]:
    """``(name, content hash, built)`` of every home of a database, by name."""
    rows = conn.execute(select(HomeRow.name, HomeRow.content_hash, HomeRow.built_at).order_by(HomeRow.name))
    for name, content_hash, built_at in rows:
        yield name, content_hash, built_at is not None
