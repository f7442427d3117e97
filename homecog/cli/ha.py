"""``homecog ha``: a Home Assistant instance's history and entities.

``homecog ha history`` turns the household's own switches in the recorder into an event file;
``homecog ha scaffold`` writes a first home file from the instance's entities. The token of the
instance comes from ``$HOMECOG_HA_TOKEN`` or ``--ha-token``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from homecog.cli.output import emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.errors import HomeAssistantError
from homecog.home import load_home

ha_app = typer.Typer(
    help="Learn from a Home Assistant instance: its history and its entities.", no_args_is_help=True
)

HomeOption = Annotated[str, typer.Option("--home", help="A built-in home name or the path of a YAML file.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
TokenOption = Annotated[
    str | None,
    typer.Option("--ha-token", help="An access token of the instance (default: $HOMECOG_HA_TOKEN)."),
]


def _token(given: str | None) -> str:
    return given or os.environ.get("HOMECOG_HA_TOKEN", "")


def _writable(path: Path, option: str = "--out", inputs: dict[str, object] | None = None) -> None:
    from homecog.cli.options import check_not_input
    from homecog.text_files import not_to_write

    problem = not_to_write(path)
    if problem is not None:
        raise HomeAssistantError(f"{option} {path}: {problem}")
    check_not_input(path, option, inputs or {})
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise HomeAssistantError(f"{option} {path}: cannot write there: {e.strerror}") from None


@ha_app.command("history")
def history(
    recorder: Annotated[
        str,
        typer.Option(
            "--recorder",
            help="The recorder database: a SQLite file, or a SQLAlchemy URL of MariaDB/PostgreSQL.",
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="The event file (CSV) to write.")],
    home: HomeOption = "paper",
    home_assistant: Annotated[
        str | None,
        typer.Option(
            "--home-assistant", help="The instance's URL: its answer says which user is homecog's, left out."
        ),
    ] = None,
    ha_token: TokenOption = None,
    since: Annotated[str | None, typer.Option(help="From this ISO 8601 time (local unless it says).")] = None,
    until: Annotated[str | None, typer.Option(help="Until this ISO 8601 time (excluded).")] = None,
    quiet: Annotated[
        float | None,
        typer.Option(
            min=0, help="Also write quiet rows: a feature change with no switch this many minutes around it."
        ),
    ] = None,
    json: JsonOption = False,
) -> None:
    """Write an event file of the household's own switches from the recorder.

    One row per switch of a mapped device by a person (not an automation, not homecog), with the
    context at that moment and, as its services, the service that makes the switch."""
    from homecog.evaluation.ha_history import read_history

    h = load_home(home)
    _writable(out, inputs={"--recorder": recorder, "--home": home})
    robots: tuple[str, ...] = ()
    if home_assistant is not None:
        from homecog.context.ha_client import query

        (user,) = query(home_assistant, _token(ha_token), ["auth/current_user"])
        robots = (user["id"],)
    with CommandProgress("ha history") as progress:
        progress("reading the recorder")
        result = read_history(h, recorder, out, exclude_users=robots, since=since, until=until, quiet=quiet)
    data = result.as_dict()
    data["homecog_user"] = robots[0] if robots else None
    if json:
        emit_json(data)
        return
    for line in result.unrecorded:
        stdout.print(f"warning: {line}", highlight=False)
    per_device = ", ".join(f"{d} {n}" for d, n in result.devices.items()) or "none"
    left_out = ", ".join(f"{k.replace('_', ' ')} {n}" for k, n in result.skipped.items() if n) or "nothing"
    quiet_rows = "" if result.quiet is None else f" and {result.quiet} quiet rows"
    stdout.print(
        f"wrote {out}: {result.events} switches by people ({per_device}){quiet_rows}", highlight=False
    )
    stdout.print(f"left out: {left_out}", highlight=False)
    if not robots:
        stdout.print(
            "note: without --home-assistant, homecog's own switches count as a person's", style="dim"
        )
    stdout.print(f"next: homecog replay --home {home} --events {out}", highlight=False)


@ha_app.command("scaffold")
def scaffold(
    home_assistant: Annotated[str, typer.Option("--home-assistant", help="The instance's URL.")],
    out: Annotated[Path, typer.Option("--out", help="The home file (YAML) to write.")],
    ha_token: TokenOption = None,
    name: Annotated[str | None, typer.Option(help="The home's name (default: the instance's).")] = None,
    json: JsonOption = False,
) -> None:
    """Write a first home file from the instance's entities, for you to edit.

    Numeric sensors by device class, helpers, people; switchable entities as devices with a
    service each way; default bins and rules."""
    from homecog.context.ha_client import query
    from homecog.home.ha_scaffold import scaffold as write

    _writable(out)
    states, config = query(home_assistant, _token(ha_token), ["get_states", "get_config"])
    place = config.get("location_name") if isinstance(config, dict) else None
    text, summary = write(states, name=name or (place if isinstance(place, str) else None) or out.stem)
    out.write_text(text, encoding="utf-8")
    if json:
        emit_json({**summary, "out": str(out)})
        return
    stdout.print(
        f"wrote {out}: {len(summary['features'])} features, {len(summary['devices'])} devices, "
        f"{len(summary['services'])} services",
        highlight=False,
    )
    if summary["odd"]:
        stdout.print(f"left out {summary['odd']:,} entities the instance described oddly", highlight=False)
    stdout.print(f"next: edit it, then homecog home check {out}", highlight=False)
