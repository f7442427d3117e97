"""What the commands share: the options every command takes, and checks made before any work."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from homecog.errors import UsageProblemError
from homecog.evaluation.registry import METHOD_NAMES, REGISTRY
from homecog.names import user_name_problem

if TYPE_CHECKING:
    from homecog.web.settings import Settings

__all__ = [
    "ContextOption",
    "DbOption",
    "HomeOption",
    "JsonOption",
    "MethodsOption",
    "TokenOption",
    "UserOption",
    "check_conversion",
    "check_not_input",
    "check_readable",
    "check_writable",
    "method_names",
]

HomeOption = Annotated[str, typer.Option("--home", help="A built-in home name or the path of a YAML file.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
DbOption = Annotated[
    str | None,
    typer.Option(
        "--db", help="Database URL (default: $HOMECOG_DB or a SQLite file under the data directory)."
    ),
]
_CONTEXT_HELP = "name=value for every feature and device, comma-separated."
#: ``--context``, optional: the short way (:mod:`homecog.cli.context_args`) may give it instead
ContextOption = Annotated[str | None, typer.Option("--context", help=_CONTEXT_HELP)]


def _user(value: str | None) -> str | None:
    """``--user`` checked as every edge checks a user name (:mod:`homecog.names`)."""
    if value is None:
        return None
    problem = user_name_problem(value)
    if problem is not None:
        raise UsageProblemError(f"--user: {problem}")
    return value


UserOption = Annotated[
    str | None,
    typer.Option(
        "--user",
        help="The household member (1 to 64 printable characters; default: the home's "
        "household.default_user).",
        callback=_user,
    ),
]
HostOption = Annotated[str, typer.Option(help="Address to serve on; any but 127.0.0.1 needs a token.")]
PortOption = Annotated[int, typer.Option(min=1, max=65535, help="Port to serve on.")]
TokenOption = Annotated[
    str | None,
    typer.Option(
        help="Token every /api request needs (default: $HOMECOG_TOKEN; none on 127.0.0.1, "
        "else generated and printed once)."
    ),
]
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def server_settings(token: str | None, host: str) -> Settings:
    """The settings of a server on ``host``: ``token`` (or $HOMECOG_TOKEN; refused unless 8 or
    more ASCII characters), one generated and printed once when there is none off loopback."""
    import secrets

    from homecog.cli.output import stdout
    from homecog.web.settings import Settings

    settings = Settings.of(token=token)
    if host not in LOCAL_HOSTS and settings.token is None:
        settings = settings.model_copy(update={"token": secrets.token_urlsafe(24)})
        stdout.print(f"token for every /api request (shown once): {settings.token}")
    return settings


def url_host(host: str) -> str:
    """``host`` as a URL writes it (an IPv6 address in brackets).

    >>> url_host("127.0.0.1"), url_host("::1")
    ('127.0.0.1', '[::1]')
    """
    return host if ":" not in host else f"[{host}]"


def check_readable(path: Path, option: str, what: str, limit: int | None = None) -> None:
    """Fail before the work, with one line naming the option, when ``path`` is no file to read:
    missing, a folder, a named pipe, a device (``/dev/zero``), or over ``limit`` bytes (by
    default a file of rows' limit, 256 MiB)."""
    from homecog.text_files import ROWS_FILE_LIMIT, check_file

    try:
        check_file(path, what=what, error=UsageProblemError, limit=limit or ROWS_FILE_LIMIT)
    except UsageProblemError as e:
        raise UsageProblemError(f"{option} {e}") from None


def check_not_input(path: Path, option: str, inputs: Mapping[str, object]) -> None:
    """Refuse to write ``path`` when it is one of the command's input files, ``inputs`` (option
    → path, or a home's name or a URL, which are no file): the same file whether named alike,
    through a link or by another hard link, so its output never overwrites what it reads."""
    try:
        out = os.stat(path)
    except (OSError, ValueError):
        return  # a file not there yet is no input
    for given_as, given in inputs.items():
        if given is None:
            continue
        text = str(given).removeprefix("sqlite:///") if str(given).startswith("sqlite:///") else str(given)
        try:
            same = os.path.samestat(out, os.stat(text))
        except (OSError, ValueError):
            continue
        if same:
            raise UsageProblemError(f"{option} {path}: is the file of {given_as}, an input; write elsewhere")


def check_writable(
    path: Path, option: str = "--out", inputs: Mapping[str, object] | None = None, *, private: bool = False
) -> None:
    """Fail before the work, not after it, when ``path`` cannot be written: a folder, a device
    or a named pipe (a file is written beside and renamed over it: never over ``/dev/null``),
    or one of the command's ``inputs`` (:func:`check_not_input`). ``private``: the folders it
    makes for ``path`` are ``0700`` (a Q table's, as the data directory's)."""
    from homecog.paths import make_private_dirs
    from homecog.text_files import not_to_write

    problem = not_to_write(path)
    if problem is not None:
        raise UsageProblemError(f"{option} {path}: {problem}")
    check_not_input(path, option, inputs or {})
    blocker = next((p for p in path.parents if p.exists() and not p.is_dir()), None)
    if blocker is not None:
        raise UsageProblemError(f"{option} {path}: cannot write there: {blocker} is not a directory")
    try:
        if private:
            make_private_dirs(path.parent)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix=".homecog-check-"):
            pass
    except OSError as e:
        raise UsageProblemError(f"{option} {path}: cannot write there: {e.strerror}") from None


#: Every method of ``eval`` and ``replay``, the default.
ALL_METHODS = ",".join(METHOD_NAMES)
MethodsOption = Annotated[str, typer.Option(help="Methods, comma-separated.")]


def check_conversion(folder: Path, out: Path) -> None:
    """Before a data set is converted: its folder is one, and the output folder can be written."""
    if not folder.is_dir():
        raise UsageProblemError(f"{folder}: not a folder")
    check_writable(out / ".probe")


def method_names(text: str) -> list[str]:
    """The --methods list, validated."""
    names = [m.strip() for m in text.split(",") if m.strip()]
    bad = [m for m in names if m not in REGISTRY]
    if bad or not names:
        raise UsageProblemError(
            f"--methods: unknown method {bad[0] if bad else '(none)'!r}; "
            f"expected some of {', '.join(METHOD_NAMES)}"
        )
    return names
