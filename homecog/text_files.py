"""Reading the text files people give homecog, bounded: home files, event and scenario files,
logs and the real data sets' files.

Whatever the path names, the answer is the text or one line saying what is wrong, fast and in
bounded memory: only a regular file is read (a folder, a named pipe, a device such as
``/dev/zero`` or a socket is refused before a byte is read, and opening never waits on a pipe),
up to a size limit per kind of file, each line up to :data:`LINE_LIMIT`; text is UTF-8, and a
NUL byte says the file is not text. Limits (docs/design.md, "Hostile input"):

==================  ==========  ===========================================================
kind                limit       why
==================  ==========  ===========================================================
a home file         1 MiB       the largest home we learn (1,002 devices) is 385 kB
a file of rows      256 MiB     an event, scenario or log file; a year of a busy home's log
==================  ==========  ===========================================================

>>> import tempfile
>>> from pathlib import Path
>>> with tempfile.TemporaryDirectory() as folder:
...     path = Path(folder) / "home.yaml"
...     _ = path.write_text("name: den\\n")
...     read_text(path, limit=HOME_FILE_LIMIT, what="a home file", error=ValueError)
...     try:
...         read_text(Path(folder), limit=HOME_FILE_LIMIT, what="a home file", error=ValueError)
...     except ValueError as e:
...         print(str(e).replace(folder, "FOLDER"))
'name: den\\n'
FOLDER: is a directory, not a home file
"""

from __future__ import annotations

import codecs
import itertools
import os
import stat
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path

KIB = 1024
MIB = 1024 * KIB
HOME_FILE_LIMIT = 1 * MIB
ROWS_FILE_LIMIT = 256 * MIB
LINE_LIMIT = 64 * KIB
_CHUNK = 64 * KIB


def size_text(n: int) -> str:
    """A size in bytes as people read it.

    >>> size_text(512), size_text(1536), size_text(3 * MIB)
    ('512 bytes', '1.5 KiB', '3 MiB')
    """
    for unit, size in (("GiB", 1024 * MIB), ("MiB", MIB), ("KiB", KIB)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n} bytes"


def _kind(mode: int) -> str | None:
    """What a file that is not a regular one is, in a user's words."""
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return None if stat.S_ISREG(mode) else "not a regular file"


def not_regular(path: Path) -> str | None:
    """What an existing ``path`` is when it is no regular file, in a user's words (``None`` for a
    regular file or nothing there): a file to write is never a device or a pipe.

    >>> not_regular(Path("/dev/null")), not_regular(Path("/no/such/file"))
    ('a device', None)
    """
    try:
        return _kind(os.stat(path).st_mode)
    except OSError:
        return None


def not_to_write(path: Path) -> str | None:
    """Why ``path`` is no file to write (a folder, a device, a named pipe: a file is written
    beside it and renamed over it, and a pipe without a reader would hang the writer), or None.

    >>> not_to_write(Path("/dev/null")), not_to_write(Path("/")), not_to_write(Path("/no/such"))
    ('is a device, not a file to write', 'is a directory', None)
    """
    kind = not_regular(path)
    if kind is None:
        return None
    return f"is {kind}" if path.is_dir() else f"is {kind}, not a file to write"


def open_regular(path: Path, *, limit: int, what: str, error: type[Exception]) -> int:
    """A file descriptor of ``path`` for reading, checked to be a regular file of at most
    ``limit`` bytes; ``error`` naming the path and what is wrong. Opening never blocks (a named
    pipe without a writer would wait for one)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | getattr(os, "O_CLOEXEC", 0))
    except FileNotFoundError:
        raise error(f"{path}: no such file") from None
    except PermissionError:
        raise error(f"{path}: cannot read: permission denied") from None
    except OSError as e:
        raise error(f"{path}: cannot read: {e.strerror}") from None
    try:
        info = os.fstat(fd)
        kind = _kind(info.st_mode)
        if kind is not None:
            raise error(f"{path}: is {kind}, not {what}")
        if info.st_size > limit:
            raise error(f"{path}: {size_text(info.st_size)}, over the {size_text(limit)} {what} may have")
        os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return fd


def check_file(path: Path, *, what: str, error: type[Exception], limit: int = ROWS_FILE_LIMIT) -> None:
    """Refuse, before any work, a path that :func:`read_text` or :func:`text_lines` would."""
    os.close(open_regular(path, limit=limit, what=what, error=error))


def read_text(path: Path, *, limit: int, what: str, error: type[Exception]) -> str:
    """The whole UTF-8 text of a regular file of at most ``limit`` bytes (a leading byte order
    mark dropped); ``error`` naming the path, and the line where the text is not UTF-8 or holds
    a NUL byte."""
    fd = open_regular(path, limit=limit, what=what, error=error)
    with os.fdopen(fd, "rb") as f:
        try:
            data = f.read(limit + 1)  # a file that grew since: never more than the limit
        except OSError as e:
            raise error(f"{path}: cannot read: {e.strerror}") from None
    if len(data) > limit:
        raise error(f"{path}: over the {size_text(limit)} {what} may have")
    nul = data.find(b"\0")
    if nul >= 0:
        raise error(f"{path}: line {_line_of(data, nul)}: a NUL byte; {what} is text")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise error(f"{path}: line {_line_of(data, e.start)}: not UTF-8 text") from None


def _line_of(data: bytes, at: int) -> int:
    return data.count(b"\n", 0, at) + 1


@contextmanager
def text_lines(
    path: Path, *, what: str, error: type[Exception], limit: int = ROWS_FILE_LIMIT
) -> Iterator[Iterator[str]]:
    """The lines of a regular UTF-8 file of at most ``limit`` bytes, read as they are used
    (each with its line ending, as :mod:`csv` wants them), each at most :data:`LINE_LIMIT`
    characters; ``error`` naming the path and the line of what is wrong."""
    fd = open_regular(path, limit=limit, what=what, error=error)
    with os.fdopen(fd, "rb") as f:
        yield _lines(f, path, limit=limit, what=what, error=error)


def _lines(f: object, path: Path, *, limit: int, what: str, error: type[Exception]) -> Iterator[str]:
    decoder = codecs.getincrementaldecoder("utf-8-sig")()
    line, pending, total = 1, "", 0
    while True:
        try:
            chunk = f.read(_CHUNK)  # type: ignore[attr-defined]
        except OSError as e:
            raise error(f"{path}: cannot read: {e.strerror}") from None
        total += len(chunk)
        if total > limit:
            raise error(f"{path}: over the {size_text(limit)} {what} may have")
        try:
            pending += decoder.decode(chunk, final=not chunk)
        except UnicodeDecodeError as e:  # pending holds no line ending: they are in the chunk
            at = line + _line_of(chunk, max(e.start, 0)) - 1
            raise error(f"{path}: line {at}: not UTF-8 text") from None
        cut = pending.rfind("\n") + 1
        block, pending = pending[:cut], pending[cut:]
        complete = block.split("\n")[:-1]
        if "\0" in block or (complete and max(map(len, complete)) > LINE_LIMIT):
            for text in complete:  # a line at a time, so that the lines before it are read first
                yield _line(text + "\n", path, line, what, error)
                line += 1
        else:  # the common case, a chunk of good lines, without a call for each
            yield from map(str.__add__, complete, itertools.repeat("\n"))
            line += len(complete)
        if len(pending) > LINE_LIMIT:
            raise error(f"{path}: line {line}: longer than {size_text(LINE_LIMIT)}")
        if not chunk:
            if pending:
                yield _line(pending, path, line, what, error)
            return


def _line(text: str, path: Path, line: int, what: str, error: type[Exception]) -> str:
    if len(text) > LINE_LIMIT + 1:
        raise error(f"{path}: line {line}: longer than {size_text(LINE_LIMIT)}")
    if "\0" in text:
        raise error(f"{path}: line {line}: a NUL byte; {what} is text")
    return text


def timestamp_cell(text: str, path: Path, line: int, error: type[Exception]) -> datetime:
    """The timestamp column of a line of a file of rows, an ISO 8601 time; ``error`` naming the
    path, the line and the text as given otherwise."""
    try:
        return datetime.fromisoformat(text.strip())
    except ValueError:
        raise error(f"{path}: line {line}, column timestamp: {text!r} is not an ISO 8601 time") from None


def check_zone(path: Path, line: int, at: datetime, zoned: tuple[bool, int], error: type[Exception]) -> None:
    """Refuse a timestamp with a time zone in a file whose first had none, or the other way
    (``zoned``: whether the first had one, and its line): such times cannot be compared.

    >>> check_zone(Path("e.csv"), 3, datetime.fromisoformat("2024-03-01T07:00+01:00"), (False, 2), ValueError)
    Traceback (most recent call last):
    ...
    ValueError: e.csv: line 3, column timestamp: has a time zone, unlike line 2's
    """
    if (at.tzinfo is not None) != zoned[0]:
        with_zone = "has a time zone" if at.tzinfo else "has no time zone"
        raise error(f"{path}: line {line}, column timestamp: {with_zone}, unlike line {zoned[1]}'s")


def check_header_unique(header: Sequence[str], path: Path, error: type[Exception]) -> None:
    """A header whose columns each have their own name; ``error`` naming the path and those named
    twice otherwise (which of two cells of one name would be read is nobody's guess).

    >>> check_header_unique(["timestamp", "lamp", "lamp"], Path("e.csv"), ValueError)
    Traceback (most recent call last):
    ...
    ValueError: e.csv: line 1: column(s) named twice: lamp
    """
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise error(f"{path}: line 1: column(s) named twice: {', '.join(twice)}")
