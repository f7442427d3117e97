"""A plan request: services decomposed into robot actions, carried out by the simulated robot.

A pure function of the home, so that a server can run it in a process of its own
(:mod:`homecog.web.planner`): planning costs a tenth of a second to a second, and under the
same interpreter lock as cognition it would slow every answer.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from homecog.home.codec import Space
from homecog.home.model import Home

#: Services one plan request may ask for (docs/design.md, "Hostile input").
MAX_PLAN_SERVICES = 32


def plan_request(
    home: Home, services: list[str], context: Mapping[str, object] | None, robot: str = "builtin"
) -> dict[str, Any]:
    """The services decomposed into robot actions, in the given order, and the plan carried
    out by a robot of the body ``robot`` (homecog's own simulator, or pyrobosim) on the floor
    plan: its timeline, time, distance and trajectory (``[t, x, y]`` rows, at most 400).
    :class:`PlanningError` when it cannot be."""
    from homecog.planning import plan_services
    from homecog.simulation.bodies import Preview

    space = Space(home)
    where = dict(space.context(space.point(context))) if context else None
    result = plan_services(home, services, context=where)
    sim = Preview(home, robot).run(result)
    simulation = sim.as_dict()
    del simulation["actions"]  # the same as the plan's
    simulation["trajectory"] = _thin(sim.trajectory, 400)
    return {
        "actions": [list(a) for a in result.actions],
        "tree": [n.as_dict() for n in result.tree],
        "simulation": simulation,
    }


def _thin(trajectory: np.ndarray, most: int) -> list[list[float]]:
    """At most ``most`` rows ``[t, x, y]`` of a trajectory, evenly spaced, first and last kept.

    >>> _thin(np.array([[t, t, 0, 0] for t in range(10)], dtype=float), 4)
    [[0.0, 0.0, 0.0], [3.0, 3.0, 0.0], [6.0, 6.0, 0.0], [9.0, 9.0, 0.0]]
    """
    n = len(trajectory)
    keep = np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int)) if n else []
    return [[round(float(t), 2), round(float(x), 3), round(float(y), 3)] for t, x, y, *_ in trajectory[keep]]
