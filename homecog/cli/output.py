"""Shared output of the commands: a readable summary, or one JSON object with ``--json``."""

from __future__ import annotations

import json
import sys
from typing import Any

from rich.console import Console

stdout = Console(highlight=False, soft_wrap=True)


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
