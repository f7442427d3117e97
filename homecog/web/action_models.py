"""The HTTP contract of what the robot did and its undo, and of what the household did by hand:
``GET /api/actions``, ``POST /api/actions/{id}/undo`` and ``GET /api/switches``."""

from __future__ import annotations

from datetime import date
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from homecog.web.models import STRICT, State, User


class SwitchOut(BaseModel):
    device: str
    state: State = Field(description="The state the robot switched it to.")


class UndoneOut(BaseModel):
    device: str
    by: Literal["person", "hmi"] = Field(description="Switched back by hand, or undone here.")


class ActionOut(BaseModel):
    id: int = Field(description="The action's number, for its undo.")
    at: float = Field(description="When: seconds since 1970 (UTC).")
    home_time: str | None = Field(description="The home's clock then (HH:MM).")
    services: list[str] = Field(description="The services it carried out, in order.")
    switches: list[SwitchOut] = Field(description="The devices it switched.")
    user: str = Field(description="Whose services they were.")
    why: list[dict[str, Any]] = Field(
        description="Why: each service's explanation, as POST /api/cognize gives it."
    )
    actions: list[str] = Field(description="The plan's actions carried out.")
    undone: list[UndoneOut] = Field(description="Its switches that were undone, and how.")
    undone_here: bool = Field(description="Whether it was undone from the HMI (its services rejected).")


class HouseholdOut(BaseModel):
    household_switches: int = Field(description="Device changes by people (and automations) seen.")
    learned: dict[str, int] = Field(
        description="What they taught: observed (a switch), undo (of the robot's), quiet (a situation "
        "lived through with the devices as they were)."
    )
    ignored: dict[str, int] = Field(description="Changes not learned from, by reason.")
    fights: int = Field(
        description="Switches of the robot's of a device a person had switched in the same situation."
    )
    left_alone: int = Field(description="Services the robot left out because a person holds a device.")
    undo_window_minutes: float
    hold_minutes: float


class ActionsOut(BaseModel):
    actions: list[ActionOut] = Field(description="The robot's latest actions, newest first.")
    household: HouseholdOut


class UndoIn(BaseModel):
    model_config = STRICT
    user: User | None = Field(None, description="Who undoes it (default: whose services they were).")


class UndoOut(BaseModel):
    model_config = ConfigDict(extra="forbid")
    action: int
    switched: list[SwitchOut] = Field(description="The devices switched back.")
    rejected: list[str] = Field(description="The services learned as not wanted where the robot acted.")
    user: str


class SwitchDayOut(BaseModel):
    day: date = Field(description="The day, in the server's local time.")
    switches: int = Field(description="Devices people switched by hand that day (undos by hand too).")
    undos: int = Field(description="The robot's actions undone that day, by hand or from the page.")


class SwitchesOut(BaseModel):
    days: list[SwitchDayOut] = Field(description="Oldest first; every day of the range, none left out.")
