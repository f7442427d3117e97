"""Many homes in one database: every per-home table keyed by the home's name.

A database of schema 0002 holds one home (``homes.id = 1``); its rows move to the keyed form
under that home's name, taken from the ``homes`` row. ``homes`` gains a version that moves on
every write, a build counter, the home file and the Q tables. The tables are made anew under
temporary names, filled from the old ones, and renamed, which every database (SQLite,
PostgreSQL, MariaDB) does the same way; the constraints and indexes carry names of their own.

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op
from sqlalchemy.dialects import mysql

revision = "0003"
down_revision = "0002"

LONGTEXT = sa.Text().with_variant(mysql.LONGTEXT(), "mysql", "mariadb")
LONGBLOB = sa.LargeBinary().with_variant(mysql.LONGBLOB(), "mysql", "mariadb")
NEW = "_v3"


def _home() -> sa.Column:
    return sa.Column("home", sa.String(200), nullable=False)


def _create() -> dict[str, sa.Table]:
    homes = op.create_table(
        "homes" + NEW,
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("content_hash", sa.String(64), nullable=False),
        sa.Column("mode", sa.String(16), nullable=False),
        sa.Column("built_at", sa.DateTime, nullable=True),
        sa.Column("state", LONGTEXT, nullable=True),
        sa.Column("version", sa.BigInteger, nullable=False),
        sa.Column("build", sa.BigInteger, nullable=False),
        sa.Column("source", LONGTEXT, nullable=True),
        sa.Column("policy", LONGBLOB, nullable=True),
        sa.PrimaryKeyConstraint("name", name="pk_homes"),
    )
    nodes = op.create_table(
        "nodes" + NEW,
        _home(),
        sa.Column("id", sa.Integer, nullable=False, autoincrement=False),
        sa.Column("parent_id", sa.Integer, nullable=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("service", sa.Integer, nullable=False),
        sa.Column("count", sa.BigInteger, nullable=False),
        sa.Column("position_sum", sa.Double, nullable=False),
        sa.PrimaryKeyConstraint("home", "id", name="pk_nodes"),
        sa.ForeignKeyConstraint(
            ["home", "parent_id"], ["nodes" + NEW + ".home", "nodes" + NEW + ".id"], name="fk_nodes_parent"
        ),
    )
    clusters = op.create_table(
        "clusters" + NEW,
        sa.Column("id", sa.Integer, nullable=False, autoincrement=True),
        _home(),
        sa.Column("node_id", sa.Integer, nullable=False),
        sa.Column("user", sa.String(200), nullable=True),
        sa.Column("tree_id", sa.BigInteger, nullable=False),
        sa.Column("polarity", sa.Integer, nullable=False),
        sa.Column("conditions", LONGTEXT, nullable=False),
        sa.Column("count", sa.BigInteger, nullable=False),
        sa.Column("position_sum", sa.Double, nullable=False),
        sa.Column("seq", sa.BigInteger, nullable=False),
        sa.Column("seed", sa.Text, nullable=True),
        sa.PrimaryKeyConstraint("id", name="pk_clusters"),
        sa.ForeignKeyConstraint(
            ["home", "node_id"], ["nodes" + NEW + ".home", "nodes" + NEW + ".id"], name="fk_clusters_node"
        ),
    )
    users = op.create_table(
        "users" + NEW,
        _home(),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("version", sa.BigInteger, nullable=False),
        sa.Column("corrections", sa.BigInteger, nullable=False),
        sa.PrimaryKeyConstraint("home", "name", name="pk_users"),
    )
    experiences = op.create_table(
        "experiences" + NEW,
        sa.Column("id", sa.Integer, nullable=False, autoincrement=True),
        _home(),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("user", sa.String(200), nullable=True),
        sa.Column("created_at", sa.DateTime, nullable=False),
        sa.Column("payload", LONGTEXT, nullable=True),
        sa.Column("data", LONGBLOB, nullable=True),
        sa.PrimaryKeyConstraint("id", name="pk_experiences"),
    )
    return {"homes": homes, "nodes": nodes, "clusters": clusters, "users": users, "experiences": experiences}


def _copy(new: dict[str, sa.Table], home: str) -> None:
    """Fill the new tables from the old ones, the rows under ``home``."""
    meta = sa.MetaData()
    bind = op.get_bind()
    for table, order in (("nodes", "id"), ("clusters", "id"), ("users", "name"), ("experiences", "id")):
        old = sa.Table(table, meta, autoload_with=bind)
        names = [c.name for c in old.columns]
        select = sa.select(sa.literal(home, sa.String(200)), *[old.c[n] for n in names]).order_by(
            old.c[order]
        )
        bind.execute(sa.insert(new[table]).from_select(["home", *names], select))


def upgrade() -> None:
    bind = op.get_bind()
    row = bind.execute(sa.text("SELECT name FROM homes ORDER BY id")).first()
    new = _create()
    if row is not None:  # a database without a home row has no rows of a home either
        homes = sa.Table("homes", sa.MetaData(), autoload_with=bind)
        kept = ["name", "content_hash", "mode", "built_at", "state"]
        one = sa.literal(1, sa.BigInteger)
        rows = sa.select(*[homes.c[k] for k in kept], one, one).where(homes.c.name == row.name)
        bind.execute(sa.insert(new["homes"]).from_select([*kept, "version", "build"], rows))
        unbuilt = new["homes"].c.built_at.is_(None)
        bind.execute(sa.update(new["homes"]).where(unbuilt).values(build=0))
        _copy(new, row.name)
    for table in ("clusters", "nodes", "users", "experiences", "homes"):
        op.drop_table(table)
    for table in ("homes", "nodes", "clusters", "users", "experiences"):
        op.rename_table(table + NEW, table)
    op.create_index("ix_clusters_home_node", "clusters", ["home", "node_id"])
    op.create_index("ix_clusters_home_user", "clusters", ["home", "user"])
    op.create_index("ix_experiences_home_kind_user_id", "experiences", ["home", "kind", "user", "id"])


def downgrade() -> None:
    raise NotImplementedError("a database of many homes cannot go back to one home per database")
