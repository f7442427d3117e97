"""Where a correction came from, as the experience log keeps it.

A correction is *explicit* (a user said what they want: the HMI, the API, ``homecog correct``),
*observed* (the running robot saw a person switch a device by hand: the service that makes the
switch was wanted just before it) or an *undo* (a person switched back what the robot had just
switched: the robot's service was not wanted where it acted). An explicit correction by a
service list speaks of every service; the others speak of one service, and every other service
keeps what it had. Each counts ``weight`` corrections' worth.

>>> Kind.observed("TurnOnLamp", weight=1).payload()
{'kind': 'observed', 'weight': 1, 'concerns': ['TurnOnLamp']}
>>> EXPLICIT.payload()
{}
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

Source = Literal["explicit", "observed", "undo"]
KINDS: tuple[Source, ...] = ("explicit", "observed", "undo")


@dataclass(frozen=True)
class Kind:
    """A correction's kind, the services it concerns (``None``: all) and its weight; ``note``
    says more for the history (the device switched, the robot's action undone)."""

    kind: Source = "explicit"
    concerns: list[str] | None = None
    weight: int = 1
    note: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind: {self.kind!r}; expected one of {', '.join(KINDS)}")
        if not 1 <= self.weight <= 100:
            raise ValueError(f"weight: {self.weight}; expected a whole number from 1 to 100")

    @classmethod
    def observed(cls, service: str, *, weight: int = 1, **note: Any) -> Kind:
        """A person's switch: ``service`` (the one that makes it) was wanted."""
        return cls("observed", [service], weight, note)

    @classmethod
    def undo(cls, service: str, *, weight: int = 1, **note: Any) -> Kind:
        """A person undid the robot's ``service``: it was not wanted where the robot did it."""
        return cls("undo", [service], weight, note)

    def payload(self) -> dict[str, Any]:
        """What the log adds to the correction's row (nothing for a plain explicit one, so
        older rows and new ones read alike)."""
        if self.kind == "explicit" and self.concerns is None and self.weight == 1 and not self.note:
            return {}
        out: dict[str, Any] = {"kind": self.kind, "weight": self.weight, "concerns": self.concerns}
        if self.note:
            out["note"] = self.note
        return out


EXPLICIT = Kind()
