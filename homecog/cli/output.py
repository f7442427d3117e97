"""Shared output of the commands: a readable summary, or one JSON object with ``--json``."""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

stdout = Console(highlight=False, soft_wrap=True)
stderr = Console(stderr=True, highlight=False)


def emit_json(data: dict[str, Any]) -> None:
    """Print one JSON object on stdout and nothing else."""
    sys.stdout.write(json.dumps(data, ensure_ascii=False) + "\n")
    sys.stdout.flush()


@contextmanager
def progress_bar(description: str, total: int) -> Iterator[Any]:
    """A progress bar on stderr; yields ``update(done, total)``. Silent when stderr is no terminal."""
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=stderr,
        transient=True,
        disable=not stderr.is_terminal,
    ) as progress:
        task = progress.add_task(description, total=total)

        def update(done: int, total: int) -> None:
            progress.update(task, completed=done, total=total)

        yield update


def big_number(n: int) -> str:
    """A count as people read it: ``663,552``, or ``1.3e+62`` past a trillion.

    >>> big_number(663552), big_number(2**200)
    ('663,552', '1.6e+60')
    """
    return f"{n:,}" if n < 10**12 else f"{n:.2g}"
