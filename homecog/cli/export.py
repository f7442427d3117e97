"""``homecog export pyrobosim``: a home's floor plan as a world for another simulator."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from homecog.cli.options import HomeOption, JsonOption, check_writable
from homecog.cli.output import emit_json, stdout
from homecog.home import load_home

export_app = typer.Typer(help="Write a home's floor plan for another simulator.", no_args_is_help=True)


@export_app.command("pyrobosim")
def export_pyrobosim(
    out: Annotated[
        Path, typer.Option("--out", help="The world's YAML file; its metadata files go beside it.")
    ],
    home: HomeOption = "paper",
    planner: Annotated[
        str, typer.Option("--planner", help="The robot's path planner there: astar, rrt, prm or world_graph.")
    ] = "astar",
    json: JsonOption = False,
) -> None:
    """Write the home's floor plan as a pyrobosim world: rooms as polygons, doors as hallways,
    places as locations, the objects on them, and the robot at its start."""
    from homecog.errors import UsageProblemError
    from homecog.simulation.pyrobosim_world import PLANNERS, pyrobosim_world

    if planner not in PLANNERS:
        raise UsageProblemError(
            f"--planner: unknown path planner {planner!r}; expected one of {', '.join(PLANNERS)}"
        )
    h = load_home(home)
    check_writable(out, inputs={"--home": home})
    world = pyrobosim_world(h, planner=planner)
    files = world.write(out)
    names = world.names()
    if json:
        emit_json({**names, "world": str(files[0]), "files": [str(f) for f in files]})
        return
    for key, items in names.items():
        stdout.print(f"{len(items)} {key}: {', '.join(items) or '-'}", highlight=False, markup=False)
    stdout.print(f"pyrobosim world: {files[0]} (with {', '.join(f.name for f in files[1:])})")
