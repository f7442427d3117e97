"""A correction: one value from the edge where it arrives to the knowledge core.

The HTTP API, ``homecog correct``, an event file and the running robot (a person's switch, an
undo) each build a :class:`Correction`; the core (:mod:`homecog.knowledge.core`) commits it to the
experience log and then applies it to the tree, unchanged. The log's row is the correction's
:meth:`Correction.row` and reads back as the same value (:meth:`Correction.from_row`).

A correction is *explicit* (a user said what they want), *observed* (the running robot saw a
person switch a device by hand: the service that makes the switch was wanted just before it) or
an *undo* (a person switched back what the robot had just switched). It names the services
wanted (``want``) and the services it speaks of (``concerns``; ``None``: every service — the whole
set wanted there); every other service keeps what it had. It counts ``weight`` corrections' worth.

>>> from homecog.home.codec import Point
>>> at = Point(codes=(0, 1), readings=(None, None))
>>> Correction.change("ann", at, add=["TurnOnLamp"], reject=["SendDrinks"]).says()
'wants TurnOnLamp; does not want SendDrinks'
>>> Correction.whole("ann", at, []).says()
'wants no service there'
>>> c = Correction.observed("ann", at, "TurnOnLamp", device="lamp", state="on")
>>> Correction.from_row("ann", c.row({"lamp": "on"}, [], [])) == c
True
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from homecog.errors import ContextError, NameProblemError
from homecog.home.codec import Point
from homecog.home.recent import Recent
from homecog.names import user_name_problem

Source = Literal["explicit", "observed", "undo"]
KINDS: tuple[Source, ...] = ("explicit", "observed", "undo")
MAX_WEIGHT = 100


@dataclass(frozen=True)
class Correction:
    """What a user wants at a point: ``want`` among ``concerns`` (``None``: among every service),
    from ``kind``, counted ``weight`` times; ``note`` says more for the history (the device
    switched, the robot's action undone)."""

    user: str
    point: Point
    want: tuple[str, ...]
    concerns: tuple[str, ...] | None = None
    kind: Source = "explicit"
    weight: int = 1
    note: Mapping[str, Any] = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        problem = user_name_problem(self.user)
        if problem is not None:
            raise NameProblemError(problem)
        if self.kind not in KINDS:
            raise ContextError(f"kind: {self.kind!r}; expected one of {', '.join(KINDS)}")
        if (
            isinstance(self.weight, bool)
            or not isinstance(self.weight, int)
            or not 1 <= self.weight <= MAX_WEIGHT
        ):
            raise ContextError(f"weight: {self.weight!r}; expected a whole number from 1 to {MAX_WEIGHT}")
        for names, what in ((self.want, "wants"), (self.concerns or (), "concerns")):
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise ContextError(f"a correction {what} {twice[0]} twice")
        if self.concerns is not None:
            if not self.concerns:
                raise ContextError("a correction of some services names no service")
            outside = [n for n in self.want if n not in self.concerns]
            if outside:
                raise ContextError(
                    f"a correction of some services wants {outside[0]}, which it does not concern"
                )

    # -- the edges' ways to make one -------------------------------------------------------------
    @classmethod
    def whole(cls, user: str, point: Point, want: Sequence[str]) -> Correction:
        """The whole set ``want`` is wanted at ``point``: every other service is not."""
        return cls(user, point, tuple(dict.fromkeys(want)))

    @classmethod
    def change(
        cls, user: str, point: Point, *, add: Sequence[str] = (), reject: Sequence[str] = ()
    ) -> Correction:
        """Some services added, some rejected; every other service keeps what it had."""
        both = sorted(set(add) & set(reject))
        if both:
            raise ContextError(f"a correction both adds and rejects {both[0]}")
        add, reject = tuple(dict.fromkeys(add)), tuple(dict.fromkeys(reject))
        return cls(user, point, add, (*add, *reject))

    @classmethod
    def observed(cls, user: str, point: Point, service: str, *, weight: int = 1, **note: Any) -> Correction:
        """A person's switch: ``service`` (the one that makes it) was wanted."""
        return cls(user, point, (service,), (service,), "observed", weight, note)

    @classmethod
    def lived(cls, user: str, point: Point, services: Sequence[str]) -> Correction:
        """A situation lived with the devices as they are: ``services`` (each would switch one)
        were not wanted there; one correction's worth."""
        return cls(user, point, (), tuple(services), "observed", 1, {"quiet": True})

    @classmethod
    def undo(cls, user: str, point: Point, service: str, *, weight: int = 1, **note: Any) -> Correction:
        """A person undid the robot's ``service``: it was not wanted where the robot did it."""
        return cls(user, point, (), (service,), "undo", weight, note)

    # -- in words and in the log ---------------------------------------------------------------
    def says(self) -> str:
        """What the correction says, in words (what is stored, whatever the robot answered)."""
        if self.concerns is None:
            return f"wants exactly {', '.join(self.want)}" if self.want else "wants no service there"
        parts = []
        if self.want:
            parts.append(f"wants {', '.join(self.want)}")
        rejected = [n for n in self.concerns if n not in self.want]
        if rejected:
            parts.append(f"does not want {', '.join(rejected)}")
        return "; ".join(parts)

    def row(
        self, context: Mapping[str, str], added: Sequence[str], rejected: Sequence[str]
    ) -> dict[str, Any]:
        """The log's payload: the context (as text, for people), the point, the correction, and
        what it changed in the answer (``added``, ``rejected``)."""
        p = self.point
        out: dict[str, Any] = {
            "context": dict(context),
            "codes": list(p.codes),
            "readings": list(p.readings),
            **({"recent": p.recent.as_dict()} if p.recent is not None else {}),
            **({"missing": sorted(p.missing)} if p.missing else {}),
            "want": list(self.want),
            "added": list(added),
            "rejected": list(rejected),
        }
        plain = self.kind == "explicit" and self.concerns is None and self.weight == 1 and not self.note
        if not plain:  # a plain explicit one adds nothing, so older rows and new ones read alike
            out.update(kind=self.kind, weight=self.weight, concerns=_list(self.concerns))
            if self.note:
                out["note"] = dict(self.note)
        return out

    @classmethod
    def from_row(cls, user: str | None, payload: Mapping[str, Any]) -> Correction:
        """The correction a log row holds (rows without a user are the default user's)."""
        concerns = payload.get("concerns")
        return cls(
            user or "default",
            point_of_row(payload),
            tuple(payload["want"]),
            None if concerns is None else tuple(concerns),
            payload.get("kind", "explicit"),
            payload.get("weight", 1),
            payload.get("note", {}),
        )


def point_of_row(payload: Mapping[str, Any]) -> Point:
    """The point a log row (a correction's or a single sample's) was made at."""
    recent = payload.get("recent")
    return Point(
        codes=tuple(payload["codes"]),
        readings=tuple(payload["readings"]),
        recent=None if recent is None else Recent.from_dict(recent),
        missing=frozenset(payload.get("missing", ())),
    )


def _list(names: tuple[str, ...] | None) -> list[str] | None:
    return None if names is None else list(names)


@dataclass(frozen=True)
class Outcome:
    """What a stored correction did: the user's correction ``number`` (their first is 1), the
    services the robot now proposes there that it did not (``added``) and those it no longer
    proposes (``rejected``), and what the correction says (:meth:`Correction.says`)."""

    correction: Correction
    number: int
    added: tuple[str, ...]
    rejected: tuple[str, ...]

    def as_dict(self) -> dict[str, Any]:
        c = self.correction
        return {
            "user": c.user,
            "number": self.number,
            "stored": {"kind": c.kind, "want": list(c.want), "concerns": _list(c.concerns)},
            "says": c.says(),
            "added": list(self.added),
            "rejected": list(self.rejected),
        }
