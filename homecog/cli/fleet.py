"""``homecog fleet train`` and ``homecog serve``: a fleet of homes in one database."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from homecog.cli.options import HostOption, JsonOption, PortOption, TokenOption, server_settings, url_host
from homecog.cli.output import emit_json, stdout
from homecog.cli.progress import CommandProgress
from homecog.errors import UsageProblemError
from homecog.progress import Counted

FleetDb = Annotated[
    str | None,
    typer.Option("--db", help="Database URL of the fleet (default: $HOMECOG_DB); PostgreSQL in production."),
]


def _db(db: str | None) -> str:
    url = db or os.environ.get("HOMECOG_DB")
    if not url:
        raise UsageProblemError("--db URL (or $HOMECOG_DB) is needed: the database of the fleet")
    return url


def fleet_train(
    folder: Annotated[Path, typer.Argument(help="A folder of home files (*.yaml).")],
    db: FleetDb = None,
    ray: Annotated[
        str | None, typer.Option("--ray", help="Address of a Ray cluster (default: a local Ray here).")
    ] = None,
    workers: Annotated[int, typer.Option(min=1, max=1024, help="CPUs of the local Ray.")] = 2,
    serial: Annotated[
        bool, typer.Option("--serial", help="One home after another here, without Ray.")
    ] = False,
    seed: Annotated[int, typer.Option(min=0, help="Seed of training and samples.")] = 0,
    json_out: JsonOption = False,
) -> int:
    """Learn every home file of FOLDER into one database: training, samples and tree, as tasks
    on Ray; a home already learned for the same content is skipped, one that fails is reported."""
    from homecog.fleet.train import HomeResult, fleet_train, home_files
    from homecog.knowledge.database import redact

    url = _db(db)
    if ray is not None and serial:
        raise UsageProblemError("--serial runs without Ray; it goes without --ray")
    total = len(home_files(folder))
    how = (
        "serially"
        if serial or (workers == 1 and ray is None)
        else f"on Ray ({ray or f'local, {workers} CPUs'})"
    )
    serial = serial or (workers == 1 and ray is None)
    with CommandProgress(f"fleet train, {how}") as progress:
        done = 0
        progress(Counted.of("homes learned", done, total))

        def report(r: HomeResult) -> None:
            nonlocal done
            done += 1
            progress(Counted.of("homes learned", done, total))
            if json_out:
                return
            name = r.home or r.file
            if r.status == "learned":
                rate = r.greedy_optimal_rate or 0.0
                line = f"  {name}: learned, {r.samples:,} samples, rate {rate:.4f}, {r.seconds:.1f} s"
            elif r.status == "skipped":
                line = f"  {name}: skipped (learned already for this content)"
            else:
                line = f"  {name}: failed: {r.error}"
            progress.say(line, style="red" if r.status == "failed" else None)

        results, seconds = fleet_train(
            folder, url, address=ray, workers=workers, serial=serial, seed=seed, on_result=report
        )
    failed = [r for r in results if r.status == "failed"]
    learned = [r for r in results if r.status == "learned"]
    if json_out:
        emit_json(
            {
                "homes": [r.as_dict() for r in results],
                "seconds": seconds,
                "workers": 1 if serial else workers,
                "ray": None if serial else (ray or "local"),
                "db": redact(url),
            }
        )
    else:
        per_minute = 60 * len(learned) / seconds if seconds > 0 else 0.0
        stdout.print(
            f"{len(learned)} learned, {len(results) - len(learned) - len(failed)} skipped, "
            f"{len(failed)} failed in {seconds:.1f} s ({per_minute:.1f} homes/min) into {redact(url)}"
        )
    return 1 if failed else 0


def serve(
    db: FleetDb = None,
    host: HostOption = "127.0.0.1",
    port: PortOption = 8000,
    token: TokenOption = None,
    cache: Annotated[
        int, typer.Option(min=1, max=1_000_000, help="Homes' trees kept in memory at most.")
    ] = 128,
) -> None:
    """Serve the HTTP API of every home of the database (/api/homes/{home}/...), stateless."""
    import gc

    from homecog.fleet.serve import Fleet, FleetApp
    from homecog.knowledge.database import redact
    from homecog.web.serving import run

    url = _db(db)
    settings = server_settings(token, host)
    fleet = Fleet(url, settings, cache=cache)
    try:
        names = fleet.names()
        stdout.print(f"knowledge: {redact(url)} ({len(names)} homes)", style="dim")
        stdout.print(f"homecog serves {len(names)} homes: http://{url_host(host)}:{port}/api/homes")
        gc.freeze()
        run(FleetApp(fleet), settings, host=host, port=port)
    finally:
        fleet.close()
