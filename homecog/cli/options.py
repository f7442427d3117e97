"""What the commands share: the options every command takes, and checks made before any work."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Annotated

import typer

from homecog.errors import UsageProblemError

__all__ = [
    "ContextOption",
    "DbOption",
    "HomeOption",
    "JsonOption",
    "UsageProblemError",
    "UserOption",
    "check_writable",
    "method_names",
    "status",
]

HomeOption = Annotated[str, typer.Option("--home", help="A built-in home name or the path of a YAML file.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
DbOption = Annotated[
    str | None,
    typer.Option(
        "--db", help="Database URL (default: $HOMECOG_DB or a SQLite file under the data directory)."
    ),
]
ContextOption = Annotated[
    str, typer.Option("--context", help="name=value for every feature and device, comma-separated.")
]
UserOption = Annotated[str, typer.Option("--user", help="The household member.")]
HostOption = Annotated[str, typer.Option(help="Address to serve on; any but 127.0.0.1 needs a token.")]
PortOption = Annotated[int, typer.Option(min=1, max=65535, help="Port to serve on.")]


def check_writable(path: Path) -> None:
    """Fail before the work, not after it, when ``path`` cannot be written."""
    if path.is_dir():
        raise UsageProblemError(f"--out {path}: is a directory")
    blocker = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        raise UsageProblemError(f"--out {path}: cannot write there: {blocker} is not a directory")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=".homecog-check-"):
            pass
    except OSError as e:
        raise UsageProblemError(f"--out {path}: cannot write there: {e.strerror}") from None


def status(message: str) -> None:
    from homecog.cli.output import stderr

    if stderr.is_terminal:
        stderr.print(message, style="dim")


#: Every method of ``eval`` and ``replay`` (homecog.evaluation.methods.METHODS), the default.
ALL_METHODS = "multi,paper,kmeans,hoeffding,frequency,naive_bayes,ha_usage,markov"


def method_names(text: str) -> list[str]:
    """The --methods list, validated."""
    from homecog.evaluation.methods import METHODS

    names = [m.strip() for m in text.split(",") if m.strip()]
    bad = [m for m in names if m not in METHODS]
    if bad or not names:
        raise UsageProblemError(
            f"--methods: unknown method {bad[0] if bad else '(none)'!r}; "
            f"expected some of {', '.join(METHODS)}"
        )
    return names
