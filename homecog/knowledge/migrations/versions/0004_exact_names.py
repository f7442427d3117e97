"""Names compared exactly on MariaDB and MySQL, as SQLite and PostgreSQL compare them.

A home's and a user's name are keys (``homes.name``, ``users.name``, the ``home`` and ``user``
columns of every table). MariaDB's default collation compares text without case (``Kim`` is
``kim``), so one server held two users as one row where the others keep two: their versions,
locks and layers mixed. The name columns take the binary collation ``utf8mb4_bin``; its pad
space (``'kim '`` equal to ``'kim'``) does not matter, since no name ends with a space
(:mod:`homecog.names`). The foreign keys on ``home`` are dropped around the change (MariaDB
refuses to change a column one uses) and made again. Nothing to do on the other databases.

Revision ID: 0004
Revises: 0003
"""

from __future__ import annotations

from alembic import op

revision = "0004"
down_revision = "0003"

#: (table, column, NOT NULL) of every name column.
NAME_COLUMNS = (
    ("homes", "name", True),
    ("nodes", "home", True),
    ("clusters", "home", True),
    ("clusters", "user", False),
    ("users", "home", True),
    ("users", "name", True),
    ("experiences", "home", True),
    ("experiences", "user", False),
)
EXACT = "CHARACTER SET utf8mb4 COLLATE utf8mb4_bin"
FOREIGN_KEYS = (
    ("clusters", "fk_clusters_node", "home, node_id"),
    ("nodes", "fk_nodes_parent", "home, parent_id"),
)


def upgrade() -> None:
    if op.get_bind().dialect.name not in ("mysql", "mariadb"):
        return
    for table, name, _ in FOREIGN_KEYS:
        op.execute(f"ALTER TABLE {table} DROP FOREIGN KEY {name}")
    for table, column, required in NAME_COLUMNS:
        null = "NOT NULL" if required else "NULL"
        op.execute(f"ALTER TABLE {table} MODIFY `{column}` VARCHAR(200) {EXACT} {null}")
    for table, name, columns in reversed(FOREIGN_KEYS):
        op.execute(
            f"ALTER TABLE {table} ADD CONSTRAINT {name} FOREIGN KEY ({columns}) REFERENCES nodes (home, id)"
        )


def downgrade() -> None:
    raise NotImplementedError("names compared without case would mix users again")
