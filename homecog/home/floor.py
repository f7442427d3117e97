"""A floor plan the robot can live in, checked when the home is loaded.

A home with a ``layout`` is refused, with one line naming the file, the key path and what to
change, when

- a value of ``location`` (where the user is) is neither a place nor a room of the layout;
- a device's ``room`` is not a room of the layout;
- a place lies inside a wall, or closer to one than the robot's centre can come
  (:data:`ROBOT_RADIUS` plus half the wall's thickness);
- somewhere the user or an errand can be — a ``location`` value, the place of an object to
  bring, a place to dock at, a device switched by hand — cannot be reached from the robot's
  start: a room with no door, or a place walled off.

Where the robot's centre may be is the floor less a band of that clearance along every wall
piece (the doors cut out); what it can reach from its start is that free floor's connected
part (:func:`connected_parts`), on a grid of :data:`RESOLUTION`, 4-connected as the planner's
8-connected moves that never cut a corner are. The simulator plans its paths on the same free floor
(:func:`free_floor`).

>>> from homecog.home import load_home
>>> layout = load_home("paper").layout
>>> free = free_floor(layout)
>>> free.shape, bool(free[28, 32])          # 8 m by 10 m at 5 cm; the sofa at (1.6, 1.4)
((160, 200), True)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from homecog.errors import HomeFileError
from homecog.home.layout import WALL_THICKNESS, Layout, Point2, point_segment_distance

RESOLUTION = 0.05  # metres per cell
ROBOT_RADIUS = 0.2  # metres


def clearance(radius: float = ROBOT_RADIUS) -> float:
    """How far the robot's centre keeps from a wall's centre line."""
    return radius + WALL_THICKNESS / 2


def free_floor(layout: Layout, *, resolution: float = RESOLUTION, radius: float = ROBOT_RADIUS) -> np.ndarray:
    """Cells ``[row, col]`` (rows go up with y) whose centre keeps :func:`clearance` from every
    solid wall piece: each piece marks only the cells near it, so a large floor costs little."""
    w, h = layout.size
    cols, rows = math.ceil(w / resolution), math.ceil(h / resolution)
    free = np.ones((rows, cols), dtype=bool)
    reach = clearance(radius)
    for x0, y0, x1, y1 in layout.solid_walls():
        c0 = max(int((min(x0, x1) - reach) / resolution) - 1, 0)
        c1 = min(int((max(x0, x1) + reach) / resolution) + 2, cols)
        r0 = max(int((min(y0, y1) - reach) / resolution) - 1, 0)
        r1 = min(int((max(y0, y1) + reach) / resolution) + 2, rows)
        if c0 >= c1 or r0 >= r1:
            continue
        px, py = np.meshgrid((np.arange(c0, c1) + 0.5) * resolution, (np.arange(r0, r1) + 0.5) * resolution)
        dx, dy = x1 - x0, y1 - y0
        t = np.clip(((px - x0) * dx + (py - y0) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
        free[r0:r1, c0:c1] &= np.hypot(px - (x0 + t * dx), py - (y0 + t * dy)) >= reach
    return free


def connected_parts(free: np.ndarray) -> np.ndarray:
    """A label per free cell, the same for cells joined by a 4-connected way (0: not free).

    Runs of free cells along each row are joined where they touch a run of the next row, by
    union-find over the runs (a floor has a few per row), so it costs a pass over the cells.

    >>> connected_parts(np.array([[1, 0, 1], [1, 0, 1], [1, 1, 0]], dtype=bool)).tolist()
    [[1, 0, 2], [1, 0, 2], [1, 1, 0]]
    """
    rows, cols = free.shape
    padded = np.zeros((rows, cols + 1), dtype=bool)
    padded[:, 1:] = free
    starts = free & ~padded[:, :-1]  # a run begins where a free cell follows a wall or the edge
    run = np.cumsum(starts.reshape(-1)).reshape(rows, cols) * free
    parent = list(range(int(run.max()) + 1))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    both = free[:-1] & free[1:]
    for a, b in set(zip(run[:-1][both].tolist(), run[1:][both].tolist(), strict=True)):
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(x) for x in range(len(parent))], dtype=np.int64)
    _, dense = np.unique(roots, return_inverse=True)  # 0 stays 0: the root of "no run" is itself
    return dense.reshape(-1)[run]


def _cell(p: Point2, shape: tuple[int, int], resolution: float = RESOLUTION) -> tuple[int, int]:
    rows, cols = shape
    return min(max(int(p[1] // resolution), 0), rows - 1), min(max(int(p[0] // resolution), 0), cols - 1)


def _labels_near(labels: np.ndarray, p: Point2) -> set[int]:
    """The free parts touching a point's cell (its own, or a neighbour's where the point is
    clear of the walls but its cell's centre is not)."""
    r, c = _cell(p, labels.shape)
    near = labels[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2]
    return {int(x) for x in near.reshape(-1) if x}


def _doorless(layout: Layout, room: str) -> bool:
    """Whether no door lies on the boundary of a room."""
    x0, y0, x1, y1 = layout.rooms[room]
    for d in layout.doors:
        on_x = d[0] == d[2] and d[0] in (x0, x1) and min(d[1], d[3]) < y1 and max(d[1], d[3]) > y0
        on_y = d[1] == d[3] and d[1] in (y0, y1) and min(d[0], d[2]) < x1 and max(d[0], d[2]) > x0
        if on_x or on_y:
            return False
    return True


def _targets(
    layout: Layout, locations: Sequence[str], devices: Mapping[str, tuple[str | None, bool]]
) -> list[tuple[str, str, str]]:
    """(name, key path, why) of everywhere the user or an errand can be."""
    out = [(v, f"context.location.values[{i}]", "the user can be there") for i, v in enumerate(locations)]
    out += [(p, f"layout.objects.{o}", f"the {o} is fetched from there") for o, p in layout.objects.items()]
    out += [
        (e.dock, f"layout.errands.{s}.dock", f"{s} docks there") for s, e in layout.errands.items() if e.dock
    ]
    for d, (room, iot) in devices.items():
        if not iot:
            where = d if d in layout.places else room
            if where is not None:
                out.append((where, f"devices.{d}", f"{d} is switched by hand there"))
    return out


def check_floor(
    layout: Layout,
    *,
    locations: Sequence[str],
    devices: Mapping[str, tuple[str | None, bool]],
    fail: Callable[[str, str], HomeFileError],
) -> None:
    """Refuse a floor plan the robot cannot live in (see the module); ``locations`` are the
    values of the context's ``location`` (none where it has no such feature), ``devices`` maps
    each device to (room, iot)."""
    for i, value in enumerate(locations):
        if not layout.has_place(value):
            raise fail(
                f"context.location.values[{i}]",
                f"{value!r} is neither a place nor a room of the layout; add it to layout.places or "
                "layout.rooms, or rename the value",
            )
    for device, (room, _) in devices.items():
        if room is not None and room not in layout.rooms:
            known = ", ".join(layout.rooms) or "none"
            raise fail(
                f"devices.{device}.room",
                f"room {room!r} is not a room of the layout (layout.rooms: {known}); add it there or "
                "change the device's room",
            )
    reach = clearance()
    for name, p in layout.places.items():
        near = min((point_segment_distance(p, s) for s in layout.solid_walls()), default=math.inf)
        if near < reach:
            raise fail(
                f"layout.places.{name}",
                f"({p[0]:g}, {p[1]:g}) is {near:.2f} m from a wall; the robot (radius {ROBOT_RADIUS:g} m) "
                f"needs {reach:.2f} m: move the place away from the wall",
            )
    labels = connected_parts(free_floor(layout))
    start = _labels_near(labels, layout.places[layout.robot])
    for name, path, why in _targets(layout, locations, devices):
        if _labels_near(labels, layout.place(name)) & start:
            continue
        room = name if name in layout.rooms else layout.room_at(layout.place(name))
        if room is not None and _doorless(layout, room):
            change = f"room {room!r} has no door: add one to layout.doors on a wall of it"
        else:
            change = "walls close it off: add a door to layout.doors on the way there"
        raise fail(
            path, f"{name!r} ({why}) cannot be reached from the robot's start {layout.robot!r}; {change}"
        )
