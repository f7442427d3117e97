"""``homecog log events`` and ``homecog adapt-kasteren``: a home's log of state changes as an
event file, and van Kasteren's houses as a home, a log and events.

The home's ``log:`` section says which entities of the log are its features and devices; what
the log holds that does not fit is counted by reason and skipped, and the summary says so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from homecog.cli.options import HomeOption, JsonOption, check_conversion, check_readable, check_writable
from homecog.cli.output import emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.evaluation.log_events import LogEvents
from homecog.home import load_home

log_app = typer.Typer(help="Turn a home's logs of state changes into event files.", no_args_is_help=True)


@log_app.command("events")
def events(
    log: Annotated[Path, typer.Option("--log", help="The log: a CSV of timestamp,entity,state[,user].")],
    out: Annotated[Path, typer.Option("--out", help="The event file (CSV) to write.")],
    home: HomeOption = "paper",
    quiet: Annotated[
        float | None,
        typer.Option(
            min=0,
            help="Minutes: a feature change this far from every switch is a quiet row "
            "(default: the home's log section, else 10).",
        ),
    ] = None,
    exclude_user: Annotated[
        list[str] | None,
        typer.Option("--exclude-user", help="Leave out the switches of this user (the log's user column)."),
    ] = None,
    json: JsonOption = False,
) -> None:
    """Write an event file from a log: a row per switch of a device, with the context just
    before it and the service that makes it, and quiet rows where the context changed with no
    switch near."""
    from homecog.evaluation.log_events import convert_log

    h = load_home(home)
    check_readable(log, "--log", "a log file")
    check_writable(out, inputs={"--log": log, "--home": home})
    with CommandProgress("log events") as progress:
        progress(f"reading {log.name}")
        result = convert_log(h, log, out, quiet=quiet, exclude_users=exclude_user or ())
    if json:
        emit_json(result.as_dict())
        return
    summary(result)
    stdout.print(f"next: homecog replay --home {home} --events {out}")


def summary(result: LogEvents) -> None:
    """The readable summary of a conversion."""
    per_device = ", ".join(f"{d} {n}" for d, n in result.devices.items()) or "none"
    stdout.print(
        f"wrote {result.path}: {result.rows} rows, {result.switches} switches ({per_device}) and "
        f"{result.quiet} quiet rows, from {result.log_rows} log rows"
    )
    left_out = ", ".join(f"{k.replace('_', ' ')} {n}" for k, n in result.skipped.items() if n) or "nothing"
    stdout.print(f"left out: {left_out}")
    if result.unknown_entities:
        names = list(result.unknown_entities)
        more = f" and {len(names) - 10} more" if len(names) > 10 else ""
        stdout.print(f"unknown entities: {', '.join(names[:10])}{more}")
    if result.reordered:
        stdout.print(f"sorted: {result.reordered} rows came after a later one")
    stdout.print(f"no quiet row: {result.near_switch} changes within the quiet minutes of a switch")


def adapt_kasteren(
    folder: Annotated[Path, typer.Argument(help="The folder of van Kasteren's house files.")],
    house: Annotated[str, typer.Option(help="The house: A, B or C.")] = "A",
    out: Annotated[Path, typer.Option(help="Where to write the home file, the log and the events.")] = Path(
        "."
    ),
    name: Annotated[str | None, typer.Option(help="The home's name (default kasteren_<house>).")] = None,
    json: JsonOption = False,
) -> None:
    """Turn one of van Kasteren's houses into a home file, a log and an event file."""
    from homecog.evaluation.kasteren import convert

    check_conversion(folder, out)
    with CommandProgress("adapt-kasteren") as progress:
        progress(f"converting house {house}")
        done = convert(folder, house, out, name)
    h = load_home(done.home)
    if json:
        emit_json(
            {
                "home": str(done.home),
                "log": str(done.log),
                "events": str(done.events),
                "name": h.name,
                "devices": len(h.devices),
                "contexts": h.context_count,
                "log_rows": done.log_rows,
                "outside_labelled_days": done.left_out,
                "conversion": done.result.as_dict(),
            }
        )
        return
    stdout.print(
        f"wrote {done.home} ({len(h.devices)} devices, {h.context_count} contexts) and {done.log} "
        f"({done.log_rows} rows; {done.left_out} firings' starts and ends outside the labelled days left out)"
    )
    summary(done.result)
    stdout.print(f"next: homecog replay --home {done.home} --events {done.events}")
