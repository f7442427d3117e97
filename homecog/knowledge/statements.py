"""The statements of a correction's transaction, built once.

SQLAlchemy caches a statement's compiled form, but building the expression (``select(...)
.where(...)``) costs on every call about what the database's work does; a correction is on the
path of every ``POST /api/corrections``, so its statements are made here once, with bound
parameters: ``h`` the home, ``u`` the user.
"""

from __future__ import annotations

from sqlalchemy import bindparam, insert, select, update

from homecog.knowledge.schema import ExperienceRow, HomeRow, UserRow

#: the user's version (the lock a correction takes, with FOR UPDATE where the server has it)
USER_VERSION = select(UserRow.version).where(UserRow.home == bindparam("h"), UserRow.name == bindparam("u"))
USER_VERSION_LOCKED = USER_VERSION.with_for_update()
#: one correction in the experience log (``t`` its time, ``p`` its payload as JSON)
LOG_CORRECTION = insert(ExperienceRow).values(
    home=bindparam("h"),
    kind="correction",
    user=bindparam("u"),
    created_at=bindparam("t"),
    payload=bindparam("p"),
)
#: the user's version and count of corrections moved on
BUMP_USER = (
    update(UserRow)
    .where(UserRow.home == bindparam("h"), UserRow.name == bindparam("u"))
    .values(version=UserRow.version + 1, corrections=UserRow.corrections + 1)
)
#: the home's version moved on: servers holding its tree see it
BUMP_HOME = update(HomeRow).where(HomeRow.name == bindparam("h")).values(version=HomeRow.version + 1)
