"""The knowledge store's tables (SPEC §6), as SQLAlchemy 2 models; Alembic migrations in
``migrations/`` make and change them.

- ``homes``: the home a database is made for, its hash, the mode, the tree's counters;
- ``nodes``: rows with a parent (root, categories, services);
- ``clusters``: conditions as JSON, ``user`` NULL for the shared tree, else the user's layer;
- ``users``: a row per household member, the lock their corrections take, a version;
- ``experiences``: the append-only log of sample batches, single samples and corrections,
  indexed by (kind, user, id) for counts and the history of corrections.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import BigInteger, DateTime, Double, ForeignKey, Index, Integer, LargeBinary, String, Text
from sqlalchemy.dialects import mysql
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

SCHEMA_VERSION = "0002"
_LongBlob = LargeBinary().with_variant(mysql.LONGBLOB(), "mysql", "mariadb")
_LongText = Text().with_variant(mysql.LONGTEXT(), "mysql", "mariadb")


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
    __table_args__ = (Index("ix_experiences_kind_user_id", "kind", "user", "id"),)  # migration 0002
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    kind: Mapped[str] = mapped_column(String(16))
    user: Mapped[str | None] = mapped_column(String(200), nullable=True)
    created_at: Mapped[datetime] = mapped_column(DateTime)
    payload: Mapped[str | None] = mapped_column(_LongText, nullable=True)
    data: Mapped[bytes | None] = mapped_column(_LongBlob, nullable=True)


# -- urls and engines ---------------------------------------------------------------------------
