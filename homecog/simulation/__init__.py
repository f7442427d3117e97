"""Simulation: a differential-drive robot carries out a plan on the home's floor plan
along collision-free A* paths, taking time for every action and switching devices; the
trajectory is drawn like the paper's Fig. 15.

>>> from homecog.home import load_home
>>> from homecog.planning import plan_services
>>> home = load_home("paper")
>>> plan = plan_services(home, ["SendDrinks"], user="sofa")
>>> result = simulate(home, plan.actions, state=plan.start)   # the state the plan was made from
>>> [row["action"][0] for row in result.timeline]
['move', 'pick', 'pour', 'move', 'hand_over']
>>> result.held is None and result.seconds > 13       # 13 s of work plus the driving
True
"""

from __future__ import annotations

from typing import Any

from homecog.simulation.grid import OccupancyGrid, occupancy_grid, plan_path
from homecog.simulation.robot import DiffDrive
from homecog.simulation.simulate import Simulation, SimulationResult, action_seconds, simulate

__all__ = [
    "DiffDrive",
    "OccupancyGrid",
    "Simulation",
    "SimulationResult",
    "action_seconds",
    "draw_trajectory",
    "occupancy_grid",
    "plan_path",
    "simulate",
]


def __getattr__(name: str) -> Any:
    # the drawing imports matplotlib (half a second): only for those who draw, not for the
    # running robot that acts through the simulator
    if name == "draw_trajectory":
        from homecog.simulation.draw import draw_trajectory

        return draw_trajectory
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
