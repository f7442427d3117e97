"""``homecog plan`` and ``homecog simulate``: services decomposed into robot actions and carried
out on the floor plan by a body, homecog's own or pyrobosim."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from homecog.cli.context_args import (
    AtOption,
    DoingOption,
    GivenContext,
    PairsArgument,
    WhereOption,
    optional_context,
)
from homecog.cli.options import (
    HomeOption,
    JsonOption,
    check_writable,
)
from homecog.cli.output import emit_json, stdout
from homecog.errors import UsageProblemError
from homecog.home import Home, load_home

ServicesOption = Annotated[
    str, typer.Option("--services", help="Services in priority order, comma-separated.")
]
RobotOption = Annotated[
    str,
    typer.Option(
        "--robot", help="The body that carries the plan out: builtin (homecog's own simulator) or pyrobosim."
    ),
]
PlannerOption = Annotated[
    str | None,
    typer.Option(
        "--planner",
        help="pyrobosim's path planner: astar (default), rrt, prm or world_graph (with --robot pyrobosim).",
    ),
]
PlanContextOption = Annotated[
    str | None,
    typer.Option(
        "--context", help="The context (as for cognize): the user's location and the device states."
    ),
]


def _plan(h: Home, services: str, given: GivenContext | None) -> Any:
    """The plan of ``services`` in the context ``given`` (None: the layout's defaults)."""
    from homecog.home.codec import Space
    from homecog.planning import plan_services

    names = [s.strip() for s in services.split(",") if s.strip()]
    if not names:
        raise UsageProblemError("--services: expected at least one service")
    values = None
    if given is not None:  # what a short context left out is left to the plan's defaults
        values = {k: v for k, v in Space(h).context(given.point).items() if k not in given.assumed}
    return plan_services(h, names, context=values)


def plan(
    services: ServicesOption,
    home: HomeOption = "paper",
    context: PlanContextOption = None,
    pairs: PairsArgument = None,
    at: AtOption = None,
    where: WhereOption = None,
    doing: DoingOption = None,
    json: JsonOption = False,
) -> None:
    """Decompose services into robot actions (HTN), in the given order, with the task tree."""
    h = load_home(home)
    given = optional_context(h, context, at, where, doing, pairs)
    result = _plan(h, services, given)
    if json:
        emit_json({"actions": [list(a) for a in result.actions], "tree": [n.as_dict() for n in result.tree]})
        return
    stdout.print(result.outline(), highlight=False, markup=False)
    stdout.print(f"{len(result.actions)} actions", style="dim")


def simulate(
    services: ServicesOption,
    home: HomeOption = "paper",
    context: PlanContextOption = None,
    pairs: PairsArgument = None,
    at: AtOption = None,
    where: WhereOption = None,
    doing: DoingOption = None,
    robot: RobotOption = "builtin",
    planner: PlannerOption = None,
    png: Annotated[Path | None, typer.Option("--png", help="Draw the trajectory into this PNG file.")] = None,
    bag: Annotated[
        Path | None,
        typer.Option("--bag", help="Also write the run as a ROS 2 bag (MCAP) into this new folder."),
    ] = None,
    json: JsonOption = False,
) -> None:
    """Plan the services and carry the plan out with a robot on the floor plan (a failed action
    is planned again from where it failed)."""
    from homecog.errors import PlanningError
    from homecog.simulation import draw_trajectory
    from homecog.simulation.bag import check_bag_folder, write_bag
    from homecog.simulation.bodies import carry_out, make_body

    h = load_home(home)
    given = optional_context(h, context, at, where, doing, pairs)
    if png is not None:
        check_writable(png, "--png", inputs={"--home": home})
    if bag is not None:
        check_bag_folder(bag)
    result = _plan(h, services, given)
    body = make_body(robot, h, result.start, planner=planner)
    acting, sim = carry_out(body, result)
    if not acting.achieved:
        raise PlanningError(f"the {body.name} robot could not carry the plan out: {acting.reason}")
    data = sim.as_dict()
    data["robot"] = {
        "body": body.name,
        "planner": body.planner,
        "achieved": acting.achieved,
        "replans": acting.replans,
        "failures": [str(f) for f in acting.failures],
    }
    data["png"] = None
    if png is not None:
        draw_trajectory(h.layout, sim, png)
        data["png"] = str(png)
    data["bag"] = str(write_bag(h, sim, bag)) if bag is not None else None
    if json:
        emit_json(data)
        return
    for step in sim.timeline:
        stdout.print(
            f"{step['start']:7.1f} s  {' '.join(step['action'])}"
            + (f"  ({step['distance_m']:.2f} m)" if step["distance_m"] else ""),
            highlight=False,
            markup=False,
        )
    for failure in acting.failures:
        stdout.print(f"replanned: {failure}", style="dim", highlight=False, markup=False)
    total = f"{len(sim.timeline)} actions in {sim.seconds:.1f} s, {sim.distance_m:.2f} m driven"
    stdout.print(f"{total} by the {body.name} robot")
    if png is not None:
        stdout.print(f"trajectory: {png}")
    if bag is not None:
        stdout.print(f"ROS 2 bag: {bag}")
