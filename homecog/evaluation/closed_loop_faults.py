"""What went wrong in a closed loop, per device and per service.

The simulated household (:mod:`homecog.evaluation.closed_loop`) counts every switch by what it
was: the robot's, one of the robot's switches it switched back within the undo window (the
robot was wrong), one of its own that undid nothing (the robot should have made it: it missed
it), and the robot switching again a device the household switched in the same situation (a
fight). Per device these are its counts; per service, each switch counts for the service that
sets just that device to that state (``TurnOnLamp`` for the lamp switched on), so a service the
robot proposed where it was not wanted shows as ``wrong`` and one the household had to do by
hand as ``missed``. A switch that no service of its own makes (only a scene sets that device)
counts for its device alone.

>>> from homecog.home import load_home
>>> home = load_home("paper")
>>> faults = Faults()
>>> faults.robot[("lamp", True)] += 2; faults.undone[("lamp", True)] += 1
>>> faults.missed[("curtain", False)] += 3
>>> per_device(home, faults)["lamp"]
{'robot_switches': 2, 'undone': 1, 'missed': 0, 'fights': 0}
>>> services = per_service(home, faults)
>>> services["TurnOnLamp"], services["CloseCurtain"]
({'done': 2, 'wrong': 1, 'missed': 0, 'fights': 0}, {'done': 0, 'wrong': 0, 'missed': 3, 'fights': 0})
>>> [row[0] for row in worst(per_device(home, faults), ("undone", "missed"))]
['curtain', 'lamp']
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from homecog.home.model import Home
from homecog.robot.guidance import switch_services

Switch = tuple[str, bool]  # (device, the state it was switched to)


@dataclass
class Faults:
    """Per switch (device, state): the robot's switches, those the household undid (counted
    under the robot's switch), the household's own switches that undid nothing (under the
    household's switch) and fights (under the robot's switch)."""

    robot: Counter[Switch] = field(default_factory=Counter)
    undone: Counter[Switch] = field(default_factory=Counter)
    missed: Counter[Switch] = field(default_factory=Counter)
    fights: Counter[Switch] = field(default_factory=Counter)


def per_device(home: Home, faults: Faults) -> dict[str, dict[str, int]]:
    """Every device of ``home``, in its order: the robot's switches of it, those undone, the
    household's switches of it the robot missed, and fights."""
    out = {}
    for device in home.device_names:
        switches = [(device, False), (device, True)]
        out[device] = {
            "robot_switches": sum(faults.robot[s] for s in switches),
            "undone": sum(faults.undone[s] for s in switches),
            "missed": sum(faults.missed[s] for s in switches),
            "fights": sum(faults.fights[s] for s in switches),
        }
    return out


def per_service(home: Home, faults: Faults) -> dict[str, dict[str, int]]:
    """Every service that switches one device, in the home's order: how often the robot did it,
    how often that was wrong (undone), how often the household did it by hand (missed), and
    fights."""
    by_switch = switch_services(home)
    out = {name: {"done": 0, "wrong": 0, "missed": 0, "fights": 0} for name in home.service_names}
    kinds = {"done": faults.robot, "wrong": faults.undone, "missed": faults.missed, "fights": faults.fights}
    for key, counts in kinds.items():
        for switch, n in counts.items():
            if switch in by_switch:
                out[by_switch[switch]][key] += n
    named = set(by_switch.values())
    return {name: counts for name, counts in out.items() if name in named}


def worst(rows: Mapping[str, Mapping[str, int]], keys: Sequence[str]) -> list[tuple[str, Mapping[str, int]]]:
    """The rows where any of ``keys`` is above 0, the most of them first (ties in their order)."""
    wrong = [(name, row) for name, row in rows.items() if any(row[k] for k in keys)]
    return sorted(wrong, key=lambda item: -sum(item[1][k] for k in keys))
