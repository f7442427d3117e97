"""The floor plan of a home (the ``layout`` section): rooms, walls, doors,
places and objects in metres, and what the robot does for an interaction service.

::

    layout:
      size: [12, 8]                    # x by y in metres; its border is the outer wall
      rooms: {living_room: [0, 0, 7, 5], bedroom: [7, 0, 12, 5]}   # [x0, y0, x1, y1]
      walls: [[7, 0, 7, 5]]            # interior walls, horizontal or vertical segments
      doors: [[7, 2, 7, 3]]            # openings, each lying on a wall
      places: {sofa: [2, 2], bed: [10, 1], charger: [0.5, 4.5], dispenser: [1, 7]}
      objects: {cup: dispenser}        # movable objects and the place each starts at
      robot: charger                   # where the robot starts (default: the first place)
      errands:                         # optional, per interaction service
        SendDrinks: {bring: cup, pour: true}  # fetch it (pour at its place), hand it over
        ChargeItSelf: {dock: charger}         # go there and dock
        CallToWakeup: {say: Good morning}     # go to the user and speak

An interaction service without an errand is "go to the user and speak its name". A device
is at the place of its own name if there is one, else at the centre of its room; the user is
at the place named by the context's ``location`` value (or the centre of a room of that name).

>>> from homecog.home import load_home
>>> layout = load_home("paper").layout
>>> layout.place("charger") == layout.places["charger"]
True
>>> layout.errand("SendDrinks")
Errand(bring='cup', pour=True, dock=None, say=None)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from homecog.home.shapes import Fail, check_keys, mapping_of, numbers

Point2 = tuple[float, float]
Segment = tuple[float, float, float, float]
Rect = tuple[float, float, float, float]

WALL_THICKNESS = 0.1  # metres; walls are drawn and rasterized this thick
_ERRAND_KEYS = ("bring", "pour", "dock", "say")
_LAYOUT_KEYS = ("size", "rooms", "walls", "doors", "places", "objects", "robot", "errands")


@dataclass(frozen=True)
class Errand:
    """What the robot does for an interaction service (one of bring, dock or say)."""

    bring: str | None = None
    pour: bool = False
    dock: str | None = None
    say: str | None = None


@dataclass(frozen=True)
class Layout:
    """A validated floor plan. Coordinates in metres, x to the right and y up."""

    size: Point2
    rooms: Mapping[str, Rect]
    walls: tuple[Segment, ...]
    doors: tuple[Segment, ...]
    places: Mapping[str, Point2]
    objects: Mapping[str, str]
    robot: str
    errands: Mapping[str, Errand] = field(default_factory=dict)
    device_rooms: Mapping[str, str] = field(default_factory=dict)

    def place(self, name: str) -> Point2:
        """The point of a place, or the centre of a room of that name."""
        if name in self.places:
            return self.places[name]
        if name in self.rooms:
            x0, y0, x1, y1 = self.rooms[name]
            return ((x0 + x1) / 2, (y0 + y1) / 2)
        raise KeyError(name)

    def has_place(self, name: str) -> bool:
        return name in self.places or name in self.rooms

    def device_place(self, device: str) -> str:
        """Where the robot goes to switch a device by hand: its place, or its room."""
        if device in self.places:
            return device
        room = self.device_rooms.get(device)
        if room is not None and room in self.rooms:
            return room
        raise KeyError(device)

    def errand(self, service: str) -> Errand | None:
        return self.errands.get(service)

    def room_at(self, p: Point2) -> str | None:
        for name, (x0, y0, x1, y1) in self.rooms.items():
            if x0 <= p[0] <= x1 and y0 <= p[1] <= y1:
                return name
        return None

    def solid_walls(self) -> list[Segment]:
        """Every wall piece, the border included, with the doors cut out."""
        w, h = self.size
        pieces = [(0.0, 0.0, w, 0.0), (w, 0.0, w, h), (0.0, h, w, h), (0.0, 0.0, 0.0, h)]
        out: list[Segment] = []
        for wall in [*pieces, *self.walls]:
            out.extend(_cut(wall, [d for d in self.doors if _on_segment(d, wall)]))
        return out

    def wall_near(self, p: Point2, clearance: float = WALL_THICKNESS / 2) -> Segment | None:
        """A solid wall piece within ``clearance`` of ``p``, if any."""
        for s in self.solid_walls():
            if point_segment_distance(p, s) < clearance:
                return s
        return None


def _horizontal(s: Segment) -> bool:
    return s[1] == s[3]


def _on_segment(door: Segment, wall: Segment) -> bool:
    """Whether ``door`` lies along ``wall`` (collinear and within it)."""
    if _horizontal(wall) != _horizontal(door) or (wall[0] == wall[2] and wall[1] == wall[3]):
        return False
    if _horizontal(wall):
        lo, hi = sorted((wall[0], wall[2]))
        return door[1] == wall[1] and all(lo <= x <= hi for x in (door[0], door[2]))
    lo, hi = sorted((wall[1], wall[3]))
    return door[0] == wall[0] and all(lo <= y <= hi for y in (door[1], door[3]))


def _cut(wall: Segment, doors: list[Segment]) -> list[Segment]:
    """The pieces of a wall left after cutting the doors out of it."""
    axis = 0 if _horizontal(wall) else 1
    lo, hi = sorted((wall[axis], wall[axis + 2]))
    gaps = sorted(tuple(sorted((d[axis], d[axis + 2]))) for d in doors)
    pieces, start = [], lo
    for g0, g1 in gaps:
        if g0 > start:
            pieces.append((start, g0))
        start = max(start, g1)
    if start < hi:
        pieces.append((start, hi))
    if axis == 0:
        return [(a, wall[1], b, wall[1]) for a, b in pieces]
    return [(wall[0], a, wall[0], b) for a, b in pieces]


def point_segment_distance(p: Point2, s: Segment) -> float:
    """The distance from a point to a segment (x0, y0, x1, y1), in metres.

    >>> point_segment_distance((1, 1), (0, 0, 2, 0)), point_segment_distance((3, 0), (0, 0, 2, 0))
    (1.0, 1.0)
    """
    (x, y), (x0, y0, x1, y1) = p, s
    dx, dy = x1 - x0, y1 - y0
    t = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((x - x0) * dx + (y - y0) * dy) / (dx * dx + dy * dy)))
    return math.hypot(x - (x0 + t * dx), y - (y0 + t * dy))


def parse_layout(
    data: object,
    fail: Fail,
    *,
    devices: Mapping[str, tuple[str | None, bool]],
    interaction: set[str],
    services: set[str],
) -> Layout:
    """Validate the ``layout`` section; ``devices`` maps each device to (room, iot).

    ``fail(path, message)`` makes the error that names the file and key path.
    """
    data = _mapping(data, "layout", fail)
    check_keys(data, "layout", _LAYOUT_KEYS, fail, ("size", "places"))
    size = _size(data["size"], fail)
    rooms = _rooms(data.get("rooms", {}) or {}, size, fail)
    walls = _segments(data, "walls", size, fail)
    doors = _segments(data, "doors", size, fail)
    _check_doors(doors, walls, size, fail)
    places = _places(data["places"], size, fail)
    objects = _objects(data.get("objects", {}) or {}, places, fail)
    robot = data.get("robot", next(iter(places)))
    if robot not in places:
        raise fail("layout.robot", f"unknown place {robot!r}; expected one of {', '.join(places)}")
    errands = {
        name: _errand(name, value, fail, interaction=interaction, services=services, layout=(places, objects))
        for name, value in _mapping(data.get("errands", {}) or {}, "layout.errands", fail).items()
    }
    layout = Layout(
        size=size,
        rooms=rooms,
        walls=walls,
        doors=doors,
        places=places,
        objects=objects,
        robot=robot,
        errands=errands,
        device_rooms={d: room for d, (room, _) in devices.items() if room},
    )
    _check_places_off_walls(layout, fail)
    _check_hand_devices(layout, devices, fail)
    return layout


def _mapping(value: object, path: str, fail: Fail) -> dict[str, Any]:
    return mapping_of(value, path, fail, kind=lambda v: type(v).__name__)


def _size(value: object, fail: Fail) -> Point2:
    w, h = numbers(value, "layout.size", fail, 2)
    if w <= 0 or h <= 0:
        raise fail("layout.size", f"expected positive width and height, got {w:g} by {h:g}")
    return w, h


def _inside(p: tuple[float, ...], size: Point2, path: str, fail: Fail) -> None:
    """Every point of ``p`` (x, y, x, y, ...) on the floor."""
    w, h = size
    for x, y in zip(p[::2], p[1::2], strict=True):
        if not (0 <= x <= w and 0 <= y <= h):
            raise fail(path, f"point ({x:g}, {y:g}) lies outside the floor of {w:g} by {h:g} m")


def _rooms(value: object, size: Point2, fail: Fail) -> dict[str, Rect]:
    rooms: dict[str, Rect] = {}
    for name, item in _mapping(value, "layout.rooms", fail).items():
        path = f"layout.rooms.{name}"
        r = numbers(item, path, fail, 4)
        if not (r[0] < r[2] and r[1] < r[3]):
            raise fail(path, "expected [x0, y0, x1, y1] with x0 < x1 and y0 < y1")
        _inside(r, size, path, fail)
        rooms[name] = r  # type: ignore[assignment]
    return rooms


def _segments(data: dict[str, Any], key: str, size: Point2, fail: Fail) -> tuple[Segment, ...]:
    """The ``walls`` or ``doors``: horizontal or vertical segments on the floor."""
    value = data.get(key, []) or []
    if not isinstance(value, list):
        raise fail(f"layout.{key}", f"expected a list of [x0, y0, x1, y1], got {value!r}")
    out = []
    for i, item in enumerate(value):
        path = f"layout.{key}[{i}]"
        s = numbers(item, path, fail, 4)
        if s[0] != s[2] and s[1] != s[3]:
            raise fail(path, "expected a horizontal or vertical segment")
        if s[0] == s[2] and s[1] == s[3]:
            raise fail(path, "is a point; expected a segment")
        _inside(s, size, path, fail)
        out.append(s)
    return tuple(out)  # type: ignore[arg-type]


def _check_doors(doors: tuple[Segment, ...], walls: tuple[Segment, ...], size: Point2, fail: Fail) -> None:
    w, h = size
    border = [(0.0, 0.0, w, 0.0), (w, 0.0, w, h), (0.0, h, w, h), (0.0, 0.0, 0.0, h)]
    for i, d in enumerate(doors):
        if not any(_on_segment(d, wall) for wall in [*border, *walls]):
            raise fail(f"layout.doors[{i}]", "does not lie on a wall")


def _places(value: object, size: Point2, fail: Fail) -> dict[str, Point2]:
    places: dict[str, Point2] = {}
    for name, item in _mapping(value, "layout.places", fail).items():
        p = numbers(item, f"layout.places.{name}", fail, 2)
        _inside(p, size, f"layout.places.{name}", fail)
        places[name] = p  # type: ignore[assignment]
    if not places:
        raise fail("layout.places", "is empty; expected at least one place")
    return places


def _objects(value: object, places: Mapping[str, Point2], fail: Fail) -> dict[str, str]:
    objects: dict[str, str] = {}
    for name, place in _mapping(value, "layout.objects", fail).items():
        if place not in places:
            raise fail(
                f"layout.objects.{name}", f"unknown place {place!r}; expected one of {', '.join(places)}"
            )
        objects[name] = place
    return objects


def _errand(
    name: str,
    value: object,
    fail: Fail,
    *,
    interaction: set[str],
    services: set[str],
    layout: tuple[Mapping[str, Point2], Mapping[str, str]],
) -> Errand:
    """The errand of an interaction service; ``layout`` is the (places, objects) read so far."""
    path = f"layout.errands.{name}"
    if name not in services:
        raise fail(path, f"unknown service {name!r}")
    if name not in interaction:
        raise fail(path, f"{name} switches devices; only a service without `set` has an errand")
    spec = _mapping(value, path, fail)
    check_keys(spec, path, _ERRAND_KEYS, fail)
    if len([k for k in ("bring", "dock", "say") if k in spec]) != 1:
        raise fail(path, "expected exactly one of bring, dock or say")
    _check_errand(spec, path, fail, *layout)
    return Errand(
        bring=spec.get("bring"),
        pour=bool(spec.get("pour", False)),
        dock=spec.get("dock"),
        say=spec.get("say"),
    )


def _check_errand(
    spec: dict[str, Any], path: str, fail: Fail, places: Mapping[str, Point2], objects: Mapping[str, str]
) -> None:
    if "bring" in spec and spec["bring"] not in objects:
        raise fail(f"{path}.bring", f"unknown object {spec['bring']!r}; expected one of layout.objects")
    if "dock" in spec and spec["dock"] not in places:
        raise fail(f"{path}.dock", f"unknown place {spec['dock']!r}")
    if "pour" in spec and (not isinstance(spec["pour"], bool) or "bring" not in spec):
        raise fail(f"{path}.pour", "expected true or false, with bring")
    if "say" in spec and not isinstance(spec["say"], str):
        raise fail(f"{path}.say", "expected a string")


def _check_places_off_walls(layout: Layout, fail: Fail) -> None:
    for name, p in layout.places.items():
        wall = layout.wall_near(p)
        if wall is not None:
            raise fail(f"layout.places.{name}", f"({p[0]:g}, {p[1]:g}) lies inside the wall {list(wall)}")


def _check_hand_devices(layout: Layout, devices: Mapping[str, tuple[str | None, bool]], fail: Fail) -> None:
    """Every device switched by hand has a place of its name or a room of the layout."""
    for device, (room, iot) in devices.items():
        if not iot and device not in layout.places and (room is None or room not in layout.rooms):
            raise fail(
                "layout.places",
                f"device {device!r} is switched by hand but has no place of its name"
                + (f" and its room {room!r} is not in layout.rooms" if room else " and no room"),
            )
