"""The knowledge store's tables, as SQLAlchemy 2 models; Alembic migrations in
``migrations/`` make and change them.

- ``homes``: one row per home, under its name: its hash, home file, Q tables, mode, the tree's
  counters and a version that moves on every write;
- ``nodes``: rows with a parent (root, categories, services);
- ``clusters``: conditions as JSON, ``user`` NULL for the shared tree, else the user's layer;
- ``users``: a row per household member, the lock their corrections take, a version;
- ``experiences``: the log: the last build's sample batches, single samples and corrections,
  indexed by (home, kind, user, id) for counts and the history of corrections.

Every table but ``homes`` has a ``home`` column, the home's name, first in its keys: one
database holds many homes.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import (
    BigInteger,
    DateTime,
    Double,
    ForeignKeyConstraint,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
)
from sqlalchemy.dialects import mysql
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

SCHEMA_VERSION = "0004"
_LongBlob = LargeBinary().with_variant(mysql.LONGBLOB(), "mysql", "mariadb")
_LongText = Text().with_variant(mysql.LONGTEXT(), "mysql", "mariadb")
# a home's or a user's name: compared exactly everywhere, on MariaDB too (migration 0004)
_Name = String(200).with_variant(
    mysql.VARCHAR(200, charset="utf8mb4", collation="utf8mb4_bin"), "mysql", "mariadb"
)


class Base(DeclarativeBase):
    pass


class HomeRow(Base):
    """A home of the database (many since migration 0003), under its name: its content hash,
    the home file and the Q tables it was built from, the mode, the tree's counters, and a
    version that moves on every write (build, correction) so servers see staleness cheaply."""

    __tablename__ = "homes"
    name: Mapped[str] = mapped_column(_Name, primary_key=True)
    content_hash: Mapped[str] = mapped_column(String(64))
    mode: Mapped[str] = mapped_column(String(16))
    built_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)
    state: Mapped[str | None] = mapped_column(_LongText, nullable=True)  # JSON: precedence, counters
    version: Mapped[int] = mapped_column(BigInteger, default=0)
    build: Mapped[int] = mapped_column(BigInteger, default=0)  # moves on every build only
    source: Mapped[str | None] = mapped_column(_LongText, nullable=True)  # the home file (YAML)
    policy: Mapped[bytes | None] = mapped_column(_LongBlob, nullable=True)  # the Q tables (.npz)


class NodeRow(Base):
    """A node of a home's tree: root, category or service, with its parent."""

    __tablename__ = "nodes"
    __table_args__ = (
        ForeignKeyConstraint(["home", "parent_id"], ["nodes.home", "nodes.id"], name="fk_nodes_parent"),
    )
    home: Mapped[str] = mapped_column(_Name, primary_key=True)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=False)
    parent_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    name: Mapped[str] = mapped_column(String(200))
    kind: Mapped[str] = mapped_column(String(16))
    service: Mapped[int] = mapped_column(Integer)
    count: Mapped[int] = mapped_column(BigInteger)
    position_sum: Mapped[float] = mapped_column(Double)


class ClusterRow(Base):
    """A cluster of a node; ``user`` is NULL for the shared tree, else the user's layer."""

    __tablename__ = "clusters"
    __table_args__ = (
        ForeignKeyConstraint(["home", "node_id"], ["nodes.home", "nodes.id"], name="fk_clusters_node"),
        Index("ix_clusters_home_node", "home", "node_id"),
        Index("ix_clusters_home_user", "home", "user"),
    )
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    home: Mapped[str] = mapped_column(_Name)
    node_id: Mapped[int] = mapped_column(Integer)
    user: Mapped[str | None] = mapped_column(_Name, nullable=True)
    tree_id: Mapped[int] = mapped_column(BigInteger)
    polarity: Mapped[int] = mapped_column(Integer)
    conditions: Mapped[str] = mapped_column(_LongText)
    count: Mapped[int] = mapped_column(BigInteger)
    position_sum: Mapped[float] = mapped_column(Double)
    seq: Mapped[int] = mapped_column(BigInteger)
    seed: Mapped[str | None] = mapped_column(Text, nullable=True)


class UserRow(Base):
    """A household member of a home: the lock their corrections take, and a version for caches."""

    __tablename__ = "users"
    home: Mapped[str] = mapped_column(_Name, primary_key=True)
    name: Mapped[str] = mapped_column(_Name, primary_key=True)
    version: Mapped[int] = mapped_column(BigInteger, default=0)
    corrections: Mapped[int] = mapped_column(BigInteger, default=0)


class ExperienceRow(Base):
    """The experience log: the last build's sample batches, single samples and corrections."""

    __tablename__ = "experiences"
    __table_args__ = (Index("ix_experiences_home_kind_user_id", "home", "kind", "user", "id"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    home: Mapped[str] = mapped_column(_Name)
    kind: Mapped[str] = mapped_column(String(16))
    user: Mapped[str | None] = mapped_column(_Name, nullable=True)
    created_at: Mapped[datetime] = mapped_column(DateTime)
    payload: Mapped[str | None] = mapped_column(_LongText, nullable=True)
    data: Mapped[bytes | None] = mapped_column(_LongBlob, nullable=True)


# -- urls and engines ---------------------------------------------------------------------------
