"""A home's floor plan as a pyrobosim world: what ``homecog export pyrobosim`` writes
and what the pyrobosim body loads. Written as plain YAML; pyrobosim itself is needed only to
open it.

==================  ===================================================================
homecog             pyrobosim
==================  ===================================================================
room                a room: its rectangle as a polygon, inset by half a wall (the robot
                    keeps as far off a wall as in homecog's own simulator), walls a
                    quarter of a wall thick (the middle of a wall between two rooms is
                    the door's hallway, so that pyrobosim can close a door)
door                a hallway between the rooms on either side, as wide as the door,
                    straight through it
place               a location of its own category: a square of :data:`PLACE_SIZE`
                    metres at the place, one object spawn on it, and navigation poses
                    on its clear sides, facing it (the robot stands beside the sofa,
                    not on it); a docking place is a charger
object              an object of its own category (a small disc) on its place's spawn
the robot           a robot at its start place, as fast as homecog's own, with a path
                    planner (:data:`PLANNERS`: A* on a 5 cm grid by default)
==================  ===================================================================

pyrobosim reads location and object categories from metadata files, so a world is three
files: ``world.yaml`` and, beside it, ``world_locations.yaml`` and ``world_objects.yaml``
(named after the world's file; the world refers to them by ``$PWD``, its own folder).

>>> from homecog.home import load_home
>>> world = pyrobosim_world(load_home("paper"))
>>> [room["name"] for room in world.world["rooms"]]
['living_room', 'bedroom', 'dining_area', 'kitchen']
>>> [(h["room_start"], h["room_end"]) for h in world.world["hallways"]]
[('living_room', 'bedroom'), ('living_room', 'dining_area'), ('dining_area', 'kitchen')]
>>> world.world["locations"][0]
{'name': 'sofa', 'category': 'sofa', 'parent': 'living_room', 'pose': {'position': {'x': 1.6, 'y': 1.4}}, \
'is_charger': False}
>>> world.world["objects"]
[{'name': 'cup', 'category': 'cup', 'parent': 'dispenser'}]
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from homecog.errors import PlanningError
from homecog.home.layout import WALL_THICKNESS, Layout, Point2, Rect
from homecog.home.model import Home
from homecog.simulation.robot import DiffDrive

PLACE_SIZE = 0.3
"""The side of the square a place is in pyrobosim, metres."""
CLEARANCE = 0.1
"""Room left between the robot and a place's square, or a wall, where it stands, metres."""
OBJECT_RADIUS = 0.04
"""The radius of an object's disc, metres."""
PLANNERS: dict[str, dict[str, Any]] = {
    "astar": {"grid_resolution": 0.05, "compress_path": True},
    "rrt": {"bidirectional": True, "rrt_star": True, "max_connection_dist": 0.5, "compress_path": True},
    "prm": {"max_nodes": 200, "max_connection_dist": 1.5, "compress_path": True},
    "world_graph": {"compress_path": True},
}
"""pyrobosim's path planners by name, with the settings the world gives each."""
_HALF = WALL_THICKNESS / 2
# pyrobosim draws a room's walls outside its polygon; a quarter of a wall on each side leaves
# the middle of a wall between two rooms to the door's hallway, so that a door can be closed
_WALL = WALL_THICKNESS / 4
_SIDES = 4  # navigation poses tried around a place: its square's sides (its inflated corners are square)


@dataclass(frozen=True)
class PyRoboSimWorld:
    """A world and its location and object metadata, as pyrobosim's YAML has them."""

    world: dict[str, Any]
    locations: dict[str, Any]
    objects: dict[str, Any]

    def names(self) -> dict[str, list[str]]:
        """The names of its rooms, hallways (``room_start-room_end``), locations and objects."""
        w = self.world
        return {
            "rooms": [r["name"] for r in w["rooms"]],
            "hallways": [f"{h['room_start']}-{h['room_end']}" for h in w["hallways"]],
            "locations": [loc["name"] for loc in w["locations"]],
            "objects": [o["name"] for o in w["objects"]],
        }

    def write(self, path: str | Path) -> list[Path]:
        """Write the world to ``path`` and its metadata beside it; the files written."""
        path = Path(path)
        stem = path.stem
        files = {
            path.with_name(f"{stem}_locations.yaml"): self.locations,
            path.with_name(f"{stem}_objects.yaml"): self.objects,
        }
        world = dict(self.world)
        world["metadata"] = {
            "locations": f"$PWD/{stem}_locations.yaml",
            "objects": f"$PWD/{stem}_objects.yaml",
        }
        path.parent.mkdir(parents=True, exist_ok=True)
        for target, data in files.items():
            target.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
        head = f"# pyrobosim world of the home {self.world['params']['name']!r}, written by homecog\n"
        path.write_text(head + yaml.safe_dump(world, sort_keys=False), encoding="utf-8")
        return [path, *files]


def pyrobosim_world(home: Home, *, robot: DiffDrive | None = None, planner: str = "astar") -> PyRoboSimWorld:
    """The pyrobosim world of ``home``'s floor plan, its robot with ``planner``. Raises
    :class:`PlanningError` for a home without a layout, an unknown planner, a place in no room
    or one with no side the robot can stand at."""
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; a pyrobosim world needs the floor plan")
    if planner not in PLANNERS:
        raise PlanningError(f"unknown path planner {planner!r}; pyrobosim has {', '.join(PLANNERS)}")
    robot = robot or DiffDrive()
    rooms = _rooms(layout)
    docks = {e.dock for e in layout.errands.values() if e.dock is not None}
    locations, location_data = [], {}
    for name, (x, y) in layout.places.items():
        room = _room_of(rooms, (x, y))
        if room is None:
            raise PlanningError(f"place {name!r} ({x:g}, {y:g}) lies in no room; pyrobosim needs a room")
        sides = nav_poses(layout, rooms, name, robot.radius)
        if not sides:
            raise PlanningError(
                f"place {name!r}: no side of it is clear for the robot to stand at in pyrobosim"
            )
        locations.append(
            {
                "name": name,
                "category": name,
                "parent": room,
                "pose": {"position": {"x": x, "y": y}},
                "is_charger": name in docks,
            }
        )
        location_data[name] = {
            "footprint": {"type": "box", "dims": [PLACE_SIZE, PLACE_SIZE], "height": 0.5},
            "nav_poses": [_pose(dx, dy, yaw) for dx, dy, yaw in sides],
            "locations": [{"name": "spot", "footprint": {"type": "parent"}}],
        }
    objects = [{"name": o, "category": o, "parent": place} for o, place in layout.objects.items()]
    object_data = {
        o: {"footprint": {"type": "circle", "radius": OBJECT_RADIUS}, "height": 0.1} for o in layout.objects
    }
    world = {
        "params": {"name": home.name, "inflation_radius": robot.radius},
        "robots": [_robot(layout, rooms, robot, planner)],
        "rooms": [
            {
                "name": name,
                "footprint": {"type": "polygon", "coords": _corners(rect)},
                "wall_width": _WALL,
                "nav_poses": [{"position": {"x": round((x0 + x1) / 2, 6), "y": round((y0 + y1) / 2, 6)}}],
            }
            for name, rect in rooms.items()
            for x0, y0, x1, y1 in [rect]
        ],
        "hallways": _hallways(layout, rooms, robot.radius),
        "locations": locations,
        "objects": objects,
    }
    return PyRoboSimWorld(world, location_data, object_data)


def nav_poses(
    layout: Layout, rooms: dict[str, Rect], place: str, radius: float
) -> list[tuple[float, float, float]]:
    """Where the robot stands at ``place`` in pyrobosim: ``(dx, dy, yaw)`` from the place, on
    the sides of its square that are clear of walls and of the other places' squares, facing it.

    >>> from homecog.home import load_home
    >>> layout = load_home("paper").layout
    >>> [(dx, dy) for dx, dy, _ in nav_poses(layout, _rooms(layout), "charger", 0.2)]  # by two walls
    [(0.45, 0.0), (0.0, -0.45)]
    """
    x, y = layout.places[place]
    room = _room_of(rooms, (x, y))
    reach = PLACE_SIZE / 2 + radius + CLEARANCE
    out = []
    for k in range(_SIDES):
        angle = k * math.tau / _SIDES
        dx, dy = round(reach * math.cos(angle), 4) + 0.0, round(reach * math.sin(angle), 4) + 0.0  # no -0.0
        p = (x + dx, y + dy)
        if _room_of(rooms, p) != room or layout.wall_near(p, _HALF + radius + CLEARANCE) is not None:
            continue
        if any(_box_distance(p, q) < radius + CLEARANCE for n, q in layout.places.items() if n != place):
            continue
        out.append((dx, dy, round(math.remainder(angle + math.pi, math.tau), 4)))
    return out


def place_pose(
    layout: Layout, rooms: dict[str, Rect], place: str, radius: float
) -> tuple[float, float, float]:
    """Where the robot stands at ``place`` in pyrobosim (its first clear side): ``x, y, yaw``."""
    x, y = layout.place(place)
    if place not in layout.places:  # a room: its centre
        return x, y, 0.0
    dx, dy, yaw = nav_poses(layout, rooms, place, radius)[0]
    return x + dx, y + dy, yaw


def _rooms(layout: Layout) -> dict[str, Rect]:
    """The rooms, inset by half a wall; the whole floor is one room where the layout has none."""
    rects = dict(layout.rooms) or {"floor": (0.0, 0.0, *layout.size)}
    return {n: (x0 + _HALF, y0 + _HALF, x1 - _HALF, y1 - _HALF) for n, (x0, y0, x1, y1) in rects.items()}


def _room_of(rooms: dict[str, Rect], p: Point2) -> str | None:
    return next((n for n, (x0, y0, x1, y1) in rooms.items() if x0 <= p[0] <= x1 and y0 <= p[1] <= y1), None)


def _corners(rect: Rect) -> list[list[float]]:
    x0, y0, x1, y1 = (round(v, 6) for v in rect)
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def _box_distance(p: Point2, centre: Point2) -> float:
    """The distance from ``p`` to a place's square at ``centre``."""
    dx = max(abs(p[0] - centre[0]) - PLACE_SIZE / 2, 0.0)
    dy = max(abs(p[1] - centre[1]) - PLACE_SIZE / 2, 0.0)
    return math.hypot(dx, dy)


def _pose(dx: float, dy: float, yaw: float) -> dict[str, Any]:
    return {"position": {"x": dx, "y": dy}, "rotation_eul": {"yaw": yaw}}


def _hallways(layout: Layout, rooms: dict[str, Rect], radius: float) -> list[dict[str, Any]]:
    """A hallway through each door between two rooms: a straight one across the wall, long
    enough that the robot's free space in it meets the rooms' on both sides."""
    out = []
    reach = _HALF + 2 * radius + CLEARANCE
    for x0, y0, x1, y1 in layout.doors:
        mx, my = (x0 + x1) / 2, (y0 + y1) / 2
        nx, ny = (0.0, 1.0) if y0 == y1 else (1.0, 0.0)
        before = _room_of(rooms, (mx - nx * 2 * _HALF, my - ny * 2 * _HALF))
        after = _room_of(rooms, (mx + nx * 2 * _HALF, my + ny * 2 * _HALF))
        if before is None or after is None or before == after:
            continue  # a door to the outside, or within one room: nothing to join
        points = [
            [round(mx - nx * reach, 6), round(my - ny * reach, 6)],
            [round(mx + nx * reach, 6), round(my + ny * reach, 6)],
        ]
        out.append(
            {
                "room_start": before,
                "room_end": after,
                "width": round(abs(x1 - x0) + abs(y1 - y0), 6),
                "wall_width": _WALL,
                "conn_method": "points",
                "conn_points": points,
            }
        )
    return out


def _robot(layout: Layout, rooms: dict[str, Rect], robot: DiffDrive, planner: str) -> dict[str, Any]:
    x, y, yaw = place_pose(layout, rooms, layout.robot, robot.radius)
    return {
        "name": "robot",
        "radius": robot.radius,
        "pose": {"position": {"x": round(x, 6), "y": round(y, 6)}, "rotation_eul": {"yaw": yaw}},
        "max_linear_velocity": robot.max_linear,
        "max_angular_velocity": robot.max_angular,
        "path_planner": {
            "type": planner,
            **PLANNERS[planner],
            **({"grid_inflation_radius": robot.radius} if planner == "astar" else {}),
        },
        "path_executor": {
            "type": "constant_velocity",
            "linear_velocity": robot.max_linear,
            "max_angular_velocity": robot.max_angular,
            "dt": robot.dt,
        },
    }
