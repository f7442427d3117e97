"""Where homecog keeps what it makes: Q tables and the knowledge databases.

Under the user's data directory (``~/.local/share/homecog`` on Linux), or
``$HOMECOG_DATA`` when set. Files are named by the home's name and content hash, so a home that
changes gets new ones and a Q table is never used for another home. A home's name is an
identifier (:mod:`homecog.names`), and :func:`data_file` checks it again: nothing homecog names
after a home is ever outside the data directory.

What homecog keeps is private to its user: the folders it makes are ``0700`` and its Q tables and
SQLite databases ``0600`` (a database's ``-wal`` and ``-shm`` files take its mode), whatever the
umask; folders that were there before are left as they are.
"""

from __future__ import annotations

import json
import os
import tempfile
import zipfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from platformdirs import user_data_path

from homecog.errors import HomeFileError
from homecog.home.model import Home
from homecog.names import home_name_problem


def data_dir() -> Path:
    """The data directory (not created here)."""
    env = os.environ.get("HOMECOG_DATA")
    return Path(env).expanduser() if env else user_data_path("homecog", appauthor=False)


def data_file(folder: str, home: Home, suffix: str) -> Path:
    """The file of ``home`` in a folder of the data directory, named by its name and hash.

    >>> from homecog.home import load_home
    >>> data_file("qtables", load_home("paper"), ".npz").relative_to(data_dir()).parent
    PosixPath('qtables')
    """
    problem = home_name_problem(home.name)
    if problem is not None:  # a Home made in code, not read from a file: never a path
        raise HomeFileError(problem)
    return data_dir() / folder / f"{home.name}-{home.content_hash[:16]}{suffix}"


#: the modes of what homecog keeps: its folders and its files
PRIVATE_DIR, PRIVATE_FILE = 0o700, 0o600


def make_private_dirs(folder: Path) -> None:
    """Make ``folder`` and the folders above it that are missing, each ``0700`` (``mkdir -p``
    makes intermediate ones by the umask); OSError where one cannot be made."""
    missing = [p for p in (folder, *folder.parents) if not p.exists()]
    for path in reversed(missing):
        try:
            path.mkdir(mode=PRIVATE_DIR)
        except FileExistsError:  # made meanwhile by another process
            continue
        os.chmod(path, PRIVATE_DIR)  # mkdir's mode passes through the umask
    if not folder.is_dir():
        raise NotADirectoryError(20, "Not a directory", str(folder))


def create_private_file(path: Path) -> None:
    """Create ``path`` empty with mode ``0600`` unless it exists (a SQLite database about to be
    made: SQLite would make it by the umask, readable by everyone)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), PRIVATE_FILE)
    except FileExistsError:
        return
    os.close(fd)


def q_table_path(home: Home, *, joint: bool = False) -> Path:
    """The cached Q tables of a home: learned group by group, or (``joint``) as one table."""
    return data_file("qtables", home, "-joint.npz" if joint else ".npz")


@contextmanager
def atomic_write(path: Path, error: type[Exception]) -> Iterator[BinaryIO]:
    """A file to write ``path`` through: a temporary file beside it, renamed into place when the
    block ends without an error, so a failed or interrupted write leaves the old file as it was.
    An OS error becomes ``error`` naming the path; a device or a named pipe is never renamed
    over."""
    from homecog.text_files import not_to_write

    problem = not_to_write(path)
    if problem is not None:
        raise error(f"{path}: {problem}")
    try:
        make_private_dirs(path.parent)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as e:
        raise error(f"{path}: cannot write: {e.strerror}") from None
    try:
        with os.fdopen(fd, "wb") as f:  # mkstemp's file is 0600: it stays private
            yield f
        os.replace(tmp, path)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        raise error(f"{path}: cannot write: {e.strerror}") from None
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextmanager
def reading(path: Path, error: type[Exception], what: str) -> Iterator[None]:
    """Errors of reading ``path`` as ``error`` naming it: missing, a folder, not allowed, or not
    ``what`` (a file of another kind or a damaged one)."""
    try:
        yield
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{path}: is a directory, not {what}") from None
    except PermissionError:
        raise error(f"{path}: cannot read: permission denied") from None
    except (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError):
        raise error(f"{path}: not {what}") from None
