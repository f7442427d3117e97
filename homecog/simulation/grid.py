"""Collision-free paths on a floor plan: an occupancy grid rasterized from the
layout's walls, A* over it, and line-of-sight shortcutting of the cell path.

A cell is occupied when its centre is closer to a solid wall piece (doors cut out, the border
included) than the robot's radius plus half the wall's thickness: the grid is the set of
positions the robot's *centre* may take, so the robot itself can be planned as a point.
A* only finds the way (which doors, which side of a wall); the shortcutting then replaces
runs of cells by straight segments that keep the same clearance from every wall, measured
on the exact wall geometry rather than on the cells.

>>> from homecog.home import load_home
>>> layout = load_home("paper").layout
>>> path = plan_path(layout, "sofa", "table")       # one room, nothing in between
>>> path
[(1.6, 1.4), (4.4, 3.2)]
>>> len(plan_path(layout, "sofa", "bed")) > 2         # through the door to the bedroom
True
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, field

import numpy as np

from homecog.errors import PlanningError
from homecog.home.floor import RESOLUTION, ROBOT_RADIUS, free_floor
from homecog.home.layout import WALL_THICKNESS, Layout, Point2, Segment, point_segment_distance

_SQRT2 = math.sqrt(2.0)
# 8-connected moves (row step, column step, cost in cells)
_MOVES = [(-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0)] + [
    (di, dj, _SQRT2) for di in (-1, 1) for dj in (-1, 1)
]
_CACHE_SIZE = 16


@dataclass(eq=False)
class OccupancyGrid:
    """Where the robot's centre may be on a layout, cell ``[row, col]`` covering
    ``[col·res, (col+1)·res) × [row·res, (row+1)·res)`` (rows go up with y).

    Build it with :func:`occupancy_grid`, which caches one per layout.

    >>> from homecog.home import load_home
    >>> grid = occupancy_grid(load_home("paper").layout)
    >>> grid.occupied.shape                          # 8 m by 10 m at 5 cm
    (160, 200)
    >>> grid.is_free((1.6, 1.4)), grid.is_free((6.0, 1.0))   # the sofa; the bedroom wall
    (True, False)
    """

    layout: Layout
    resolution: float
    radius: float
    walls: list[Segment]
    occupied: np.ndarray  # bool, shape (rows, cols)
    _paths: dict[tuple[Point2, Point2], list[Point2] | None] = field(default_factory=dict, repr=False)

    @property
    def clearance(self) -> float:
        """The least distance from the robot's centre to a wall's centre line."""
        return self.radius + WALL_THICKNESS / 2

    def cell(self, p: Point2) -> tuple[int, int]:
        """The (row, column) of the cell holding point ``p``, clipped to the grid."""
        rows, cols = self.occupied.shape
        col = min(max(int(p[0] // self.resolution), 0), cols - 1)
        row = min(max(int(p[1] // self.resolution), 0), rows - 1)
        return row, col

    def centre(self, cell: tuple[int, int]) -> Point2:
        """The point at the centre of a cell, in metres."""
        return ((cell[1] + 0.5) * self.resolution, (cell[0] + 0.5) * self.resolution)

    def wall_distance(self, p: Point2) -> float:
        """The distance from ``p`` to the nearest solid wall's centre line."""
        return min(point_segment_distance(p, s) for s in self.walls)

    def is_free(self, p: Point2) -> bool:
        """Whether the robot's centre may stand at ``p`` (exact geometry, not the cells)."""
        w, h = self.layout.size
        return 0 <= p[0] <= w and 0 <= p[1] <= h and self.wall_distance(p) >= self.clearance

    def line_of_sight(self, a: Point2, b: Point2) -> bool:
        """Whether the robot can drive straight from ``a`` to ``b`` keeping its clearance."""
        return all(_segment_distance(a, b, s) >= self.clearance for s in self.walls)

    def find_path(self, start: Point2, goal: Point2) -> list[Point2] | None:
        """Waypoints from ``start`` to ``goal`` (both free), or ``None`` when the goal cannot be
        reached. The first and last waypoints are ``start`` and ``goal`` themselves."""
        key = (start, goal)
        if key not in self._paths:
            cells = self._astar(self.cell(start), self.cell(goal))
            if cells is None:
                self._paths[key] = None
            else:
                raw = [start, *(self.centre(c) for c in cells[1:-1]), goal]
                self._paths[key] = self._shortcut(raw)
        path = self._paths[key]
        return None if path is None else list(path)

    def _astar(self, start: tuple[int, int], goal: tuple[int, int]) -> list[tuple[int, int]] | None:
        """A* over free cells, 8-connected without cutting corners, octile heuristic. The start
        and goal cells are allowed even where occupied: their points are checked as exact
        geometry, and a point clear of the walls can lie in a cell whose centre is not."""
        rows, cols = self.occupied.shape
        blocked = self.occupied.copy()
        blocked[start] = blocked[goal] = False
        cost = np.full((rows, cols), np.inf)
        came = np.full((rows, cols, 2), -1, dtype=np.int64)
        done = np.zeros((rows, cols), dtype=bool)
        gr, gc = goal

        def heuristic(r: int, c: int) -> float:
            dr, dc = abs(r - gr), abs(c - gc)
            return dr + dc + (_SQRT2 - 2) * min(dr, dc)

        cost[start] = 0.0
        heap = [(heuristic(*start), 0.0, start)]
        while heap:
            _, g, (r, c) = heapq.heappop(heap)
            if done[r, c]:
                continue
            done[r, c] = True
            if (r, c) == goal:
                path = [goal]
                while path[-1] != start:
                    pr, pc = came[path[-1]]
                    path.append((int(pr), int(pc)))
                return path[::-1]
            for dr, dc, step in _MOVES:
                nr, nc = r + dr, c + dc
                if not (0 <= nr < rows and 0 <= nc < cols) or blocked[nr, nc] or done[nr, nc]:
                    continue
                if dr and dc and (blocked[r + dr, c] or blocked[r, c + dc]):
                    continue  # a diagonal step may not cut the corner of an occupied cell
                ng = g + step
                if ng < cost[nr, nc]:
                    cost[nr, nc] = ng
                    came[nr, nc] = (r, c)
                    heapq.heappush(heap, (ng + heuristic(nr, nc), ng, (nr, nc)))
        return None

    def _shortcut(self, raw: list[Point2]) -> list[Point2]:
        """Drop the waypoints the robot can drive past in a straight line: from each kept
        waypoint, jump to the farthest later one in sight. The next cell is always in reach,
        so the result is never worse than the cell path."""
        path = [raw[0]]
        i = 0
        while i < len(raw) - 1:
            j = len(raw) - 1
            while j > i + 1 and not self.line_of_sight(raw[i], raw[j]):
                j -= 1
            path.append(raw[j])
            i = j
        return path


def occupancy_grid(
    layout: Layout, *, resolution: float = RESOLUTION, radius: float = ROBOT_RADIUS
) -> OccupancyGrid:
    """The occupancy grid of a layout for a robot of ``radius`` metres, built once per layout.

    >>> from homecog.home import load_home
    >>> layout = load_home("paper").layout
    >>> occupancy_grid(layout) is occupancy_grid(layout)
    True
    """
    if resolution <= 0 or radius < 0:
        raise ValueError(
            f"expected a positive resolution and a non-negative radius, got {resolution}, {radius}"
        )
    key = (id(layout), resolution, radius)
    grid = _GRIDS.get(key)
    if grid is not None and grid.layout is layout:  # the grid keeps its layout alive, so ids stay unique
        return grid
    grid = OccupancyGrid(
        layout=layout,
        resolution=resolution,
        radius=radius,
        walls=layout.solid_walls(),
        occupied=~free_floor(layout, resolution=resolution, radius=radius),
    )
    if len(_GRIDS) >= _CACHE_SIZE:
        del _GRIDS[next(iter(_GRIDS))]
    _GRIDS[key] = grid
    return grid


_GRIDS: dict[tuple[int, float, float], OccupancyGrid] = {}


def plan_path(
    layout: Layout,
    origin: str,
    target: str,
    *,
    resolution: float = RESOLUTION,
    radius: float = ROBOT_RADIUS,
) -> list[Point2]:
    """Waypoints in metres for the robot to go from place (or room) ``origin`` to ``target``.

    Raises :class:`PlanningError` for an unknown place, a place inside a wall or too close to
    one for the robot, and a place that cannot be reached.

    >>> from homecog.home import load_home
    >>> plan_path(load_home("paper").layout, "sofa", "sofa")
    [(1.6, 1.4)]
    """
    grid = occupancy_grid(layout, resolution=resolution, radius=radius)
    points = {}
    for name in (origin, target):
        if not layout.has_place(name):
            known = ", ".join([*layout.places, *layout.rooms])
            raise PlanningError(f"unknown place {name!r}; the layout has {known}")
        p = layout.place(name)
        if not grid.is_free(p):
            raise PlanningError(
                f"place {name!r} at ({p[0]:g}, {p[1]:g}) is inside a wall or too close to one "
                f"for the robot (radius {radius:g} m)"
            )
        points[name] = p
    start, goal = points[origin], points[target]
    if start == goal:
        return [start]
    path = grid.find_path(start, goal)
    if path is None:
        raise PlanningError(f"place {target!r} cannot be reached from {origin!r}")
    return path


def _cross(o: Point2, a: Point2, b: Point2) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _segment_distance(a: Point2, b: Point2, s: Segment) -> float:
    """The least distance between segment ``a``–``b`` and wall segment ``s``."""
    c, d = (s[0], s[1]), (s[2], s[3])
    d1, d2, d3, d4 = _cross(c, d, a), _cross(c, d, b), _cross(a, b, c), _cross(a, b, d)
    if d1 * d2 < 0 and d3 * d4 < 0:
        return 0.0  # they cross; touching and overlapping give 0 below
    return min(
        point_segment_distance(a, s),
        point_segment_distance(b, s),
        point_segment_distance(c, (*a, *b)),
        point_segment_distance(d, (*a, *b)),
    )
