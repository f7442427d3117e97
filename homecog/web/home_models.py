"""The HTTP contract of the home itself (``GET /api/home``) and of where its context comes from
(``GET /api/source``): what a page needs to show the home in its own words — each feature's
unit, each device's room, the household's default user.

>>> from homecog.home import load_home
>>> out = home_out(load_home("paper"))
>>> out.household.default_user, [(d.name, d.room) for d in out.devices][:2]
('default', [('window', 'living_room'), ('curtain', 'living_room')])
>>> [(f.name, f.unit) for f in out.features][1:3], out.features[1].bins
([('temperature', '°C'), ('illumination', 'lx')], [[None, 25.0], [25.0, 30.0], [30.0, None]])
"""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, Field

from homecog.home.model import Device, Feature, Home


class FeatureOut(BaseModel):
    name: str
    kind: Literal["clock", "numeric", "categorical"]
    values: list[str] = Field(description="The bins (clock, numeric) or the values, in code order.")
    unit: str | None
    bins: list[list[float | None]] | None = Field(
        description="Per value of a clock or numeric feature, its half-open interval [low, high) "
        "(hours for a clock, where low > high wraps midnight; null: no end); null for a categorical one."
    )


class DeviceOut(BaseModel):
    name: str
    room: str | None = Field(
        description="The room it is in: the home file's, else the floor plan's room that holds the "
        "place of the device's name; null: neither says."
    )
    iot: bool = Field(description="Switched by an IoT command; otherwise the robot goes and does it.")


class ServiceOut(BaseModel):
    name: str
    category: str


class LayoutOut(BaseModel):
    """The floor plan in metres, y up."""

    size: list[float] = Field(description="[width, height]")
    rooms: dict[str, list[float]] = Field(description="Rectangles [x0, y0, x1, y1].")
    walls: list[list[float]] = Field(description="Segments [x0, y0, x1, y1].")
    doors: list[list[float]] = Field(description="Segments [x0, y0, x1, y1].")
    places: dict[str, list[float]] = Field(description="Points [x, y].")
    robot: str = Field(description="The place the robot starts at.")


class HouseholdOut(BaseModel):
    """Who lives there, as the home file's ``household`` section says."""

    default_user: str = Field(
        description="The user the robot acts for, and whom a request that names no user speaks for."
    )
    users: list[str] | None = Field(
        description="The homecog users of the household, the default user among them; null: any user."
    )


class HomeOut(BaseModel):
    name: str
    features: list[FeatureOut]
    devices: list[DeviceOut]
    services: list[ServiceOut]
    household: HouseholdOut
    layout: LayoutOut | None = Field(description="null for a home without a floor plan.")


def device_room(home: Home, device: Device) -> str | None:
    """The room a device is in: the home file's ``room``, else the floor plan's room holding a
    place of the device's own name (where the robot switches it by hand), else ``None``."""
    if device.room is not None:
        return device.room
    layout = home.layout
    if layout is None or device.name not in layout.places:
        return None
    return layout.room_at(layout.places[device.name])


def _bins(f: Feature) -> list[list[float | None]] | None:
    """A feature's bins as JSON takes them: an infinite end as null."""
    if f.bins is None:
        return None
    return [[None if math.isinf(x) else x for x in b] for b in f.bins]


def household_out(home: Home) -> HouseholdOut:
    """The household's default user and, where the home names them, its users."""
    h = home.household
    users = None if h.users is None else sorted({*h.users.values(), h.default_user})
    return HouseholdOut(default_user=h.default_user, users=users)


def home_out(home: Home) -> HomeOut:
    """The home as ``GET /api/home`` gives it."""
    layout = home.layout
    return HomeOut(
        name=home.name,
        features=[
            FeatureOut(name=f.name, kind=f.kind, values=list(f.values), unit=f.unit, bins=_bins(f))
            for f in home.features
        ],
        devices=[DeviceOut(name=d.name, room=device_room(home, d), iot=d.iot) for d in home.devices],
        services=[ServiceOut(name=s.name, category=s.category) for s in home.services],
        household=household_out(home),
        layout=None
        if layout is None
        else LayoutOut(
            size=list(layout.size),
            rooms={name: list(r) for name, r in layout.rooms.items()},
            walls=[list(w) for w in layout.walls],
            doors=[list(d) for d in layout.doors],
            places={name: list(p) for name, p in layout.places.items()},
            robot=layout.robot,
        ),
    )


class SourceOut(BaseModel):
    """Where the context comes from and whether it is connected; a real home's source says more
    (absent fields: the source does not report them)."""

    kind: str = Field(description="simulated, manual, mqtt or home_assistant")
    connected: bool
    url: str | None = None
    since: float | None = Field(None, description="Connected since: seconds since 1970 (UTC).")
    version: str | None = Field(None, description="Home Assistant's version.")
    reconnects: int | None = None
    missing: list[str] | None = Field(None, description="Features and devices without a value yet.")
    skipped: int | None = Field(None, description="States that could not be read, skipped.")
    skipped_switches: int | None = None
    last_error: str | None = None
