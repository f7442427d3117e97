"""Shared output of the commands: a readable summary, or one JSON object with ``--json``."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    TextColumn,
    TimeRemainingColumn,
)

stdout = Console(highlight=False, soft_wrap=True)
stderr = Console(stderr=True, highlight=False)


def emit_json(data: dict[str, Any]) -> None:
    """Print one JSON object on stdout and nothing else. Counts are exact however long (the
    start states of a home of 50,000 devices have 15,052 digits, past Python's default limit
    on turning an int into text; these are ours, not a stranger's, and take microseconds)."""
    limit = sys.get_int_max_str_digits()
    sys.set_int_max_str_digits(0)
    try:
        text = json.dumps(data, ensure_ascii=False)
    finally:
        sys.set_int_max_str_digits(limit)
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def emit(data: dict[str, Any], json: bool, *lines: str) -> None:
    """``data`` as one JSON object (with ``json``), else ``lines`` for a person."""
    if json:
        emit_json(data)
        return
    for line in lines:
        stdout.print(line)


def stderr_progress(time_column: ProgressColumn, *, transient: bool = False, quiet: bool = False) -> Progress:
    """Progress on stderr: what is done, a bar, how many of how many, then ``time_column``
    (the time elapsed or the time remaining). Silent with ``quiet`` or when stderr is no terminal."""
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        time_column,
        console=stderr,
        transient=transient,
        disable=quiet or not stderr.is_terminal,
    )


@contextmanager
def progress_bar(description: str, total: int) -> Iterator[Any]:
    """A progress bar on stderr; yields ``update(done, total)``. Silent when stderr is no terminal."""
    with stderr_progress(TimeRemainingColumn(), transient=True) as progress:
        task = progress.add_task(description, total=total)

        def update(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        yield update
