"""Progress said as text, with its counts where it has them.

Long work reports progress through a plain callable that takes one line of text (``print``,
``list.append`` and a logger's method all do). Where the work knows how far it is, it says so
with a :class:`Counted` message: still that line of text for whoever only reads text, and the
counts for whoever draws a bar (the command line's progress on a terminal).

>>> m = Counted.of("events", 1500, 6000)
>>> str(m), m.done, m.total, isinstance(m, str)
('1,500 of 6,000 events', 1500, 6000, True)
"""

from __future__ import annotations

from collections.abc import Callable

#: what long work is given to report its progress: one line of text at a time
Progress = Callable[[str], object]


class Counted(str):
    """A progress message that also carries how much of how much is done."""

    done: int
    total: int

    def __new__(cls, text: str, done: int, total: int) -> Counted:
        message = super().__new__(cls, text)
        message.done, message.total = done, total
        return message

    @classmethod
    def of(cls, what: str, done: int, total: int) -> Counted:
        """``"1,500 of 6,000 events"``, with its counts."""
        return cls(f"{done:,} of {total:,} {what}", done, total)
