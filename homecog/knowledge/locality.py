"""How far a correction reaches: the hull of the examples that say the same.

A user's correction that departs from the shared knowledge — a service added where the robot
would not propose it, or rejected where it would — holds near the contexts it was made in, and
widens only as more corrections agree. Its learner's key says which features tell the cell
apart; the features outside the key are held to what the agreeing examples of the cell have
shown, their *hull*:

- a categorical feature, to the values seen (the sofa and the armchair, not the bed);
- a numeric feature, to the span of the intervals seen (its bins and the user's own cuts, from
  the lowest seen to the highest);
- the clock, to the shortest arc of the day that holds the times seen, :data:`CLOCK_MARGIN`
  hours wider on either side (a wish at 20:30 holds from 19:30 to 21:30; six between 19:00
  and 21:30 hold from 18:00 to 22:30, not at 03:00).

A reading that is missing is held to the atoms seen (``unknown`` among them or not).

>>> hull = Hull.of([((20.5,), (18.0,)), ((21.5,), (21.0,))], clock=frozenset({0}), numeric=frozenset())
>>> hull.holds((21.0,), (21.0,)), hull.holds((22.25,), (21.0,)), hull.holds((3.0,), (21.0,))
(True, True, False)
>>> Hull.of([((None,), ("sofa",))], clock=frozenset(), numeric=frozenset()).holds((None,), ("bed",))
False
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

#: hours a correction's time reaches beyond the times it was made at, either side
CLOCK_MARGIN = 1.0
#: distinct values of a feature the agreeing examples must show before it holds for every value
FREE = 2
_DAY = 24.0


def clock_arc(hours: Sequence[float]) -> tuple[float, float]:
    """The shortest arc of the day that holds ``hours``: its start and its length.

    >>> clock_arc([23.0, 1.0, 0.5]), clock_arc([9.0])
    ((23.0, 2.0), (9.0, 0.0))
    """
    ordered = sorted(h % _DAY for h in hours)
    gaps = [(ordered[(i + 1) % len(ordered)] - h) % _DAY for i, h in enumerate(ordered)]
    if len(ordered) == 1:
        return ordered[0], 0.0
    widest = max(range(len(gaps)), key=gaps.__getitem__)
    start = ordered[(widest + 1) % len(ordered)]
    return start, _DAY - gaps[widest]


def on_arc(hour: float, arc: tuple[float, float], margin: float = CLOCK_MARGIN) -> bool:
    """Whether ``hour`` is on ``arc`` widened by ``margin`` either side.

    >>> on_arc(6.5, (23.0, 2.0)), on_arc(2.0, (23.0, 2.0)), on_arc(22.0, (23.0, 2.0))
    (False, True, True)
    """
    start, length = arc
    if length + 2 * margin >= _DAY:
        return True
    return (hour - (start - margin)) % _DAY <= length + 2 * margin


@dataclass(frozen=True)
class Hull:
    """Per context feature, what the agreeing examples showed: the atoms seen, the span of the
    numeric ones and, for the clock, the arc of the readings."""

    atoms: tuple[frozenset[object], ...]
    spans: tuple[tuple[float, float] | None, ...]
    arcs: tuple[tuple[float, float] | None, ...]

    @classmethod
    def of(
        cls,
        examples: Iterable[tuple[Sequence[float | None], Sequence[object]]],
        *,
        clock: frozenset[int],
        numeric: frozenset[int],
    ) -> Hull:
        """The hull of examples given as (readings, context atoms)."""
        seen: list[set[object]] = []
        hours: list[list[float]] = []
        for readings, atoms in examples:
            if not seen:
                seen = [set() for _ in atoms]
                hours = [[] for _ in atoms]
            for j, atom in enumerate(atoms):
                seen[j].add(atom)
                if j in clock and readings[j] is not None:
                    hours[j].append(float(readings[j]))  # type: ignore[arg-type]
        spans = []
        for j, values in enumerate(seen):
            floats = [a for a in values if isinstance(a, float)]
            spans.append((min(floats), max(floats)) if j in numeric and j not in clock and floats else None)
        arcs = tuple(clock_arc(h) if h else None for h in hours)
        return cls(tuple(frozenset(s) for s in seen), tuple(spans), arcs)

    def holds(self, readings: Sequence[float | None], atoms: Sequence[object]) -> bool:
        """Whether a context (its readings and context atoms) is within the hull."""
        if not self.atoms:
            return False
        for j, atom in enumerate(atoms):
            arc, span = self.arcs[j], self.spans[j]
            if arc is None and len(self.atoms[j]) >= FREE:
                continue
            if arc is not None and readings[j] is not None:
                inside = on_arc(float(readings[j]), arc)  # type: ignore[arg-type]
            elif span is not None and isinstance(atom, float):
                inside = span[0] <= atom <= span[1]
            else:
                inside = atom in self.atoms[j]
            if not inside:
                return False
        return True
