"""Warnings about what arrives from outside, at most so many a minute: a broker can send a message
a millisecond, and each must not be a line of the log.

>>> import logging
>>> times = iter([0.0, 1.0, 2.0, 61.0])
>>> warnings = LimitedWarnings(logging.getLogger("doctest"), per_minute=2, clock=lambda: next(times))
>>> [warnings.warning("bad %s", n) for n in range(4)]
[True, True, False, True]
>>> warnings.suppressed
0
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

#: the most warnings of one kind a minute (per source)
PER_MINUTE = 10
WINDOW = 60.0  # seconds


class LimitedWarnings:
    """A logger's warnings, at most ``per_minute`` in each minute (a fixed window from the first
    of it); the others are counted, and the next one logged says how many were left out."""

    def __init__(
        self,
        logger: logging.Logger,
        *,
        per_minute: int = PER_MINUTE,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.logger = logger
        self.per_minute = per_minute
        self.clock = clock
        self.suppressed = 0  # left out since the last one logged
        self._start = -WINDOW
        self._sent = 0
        self._lock = threading.Lock()

    def warning(self, message: str, *args: object) -> bool:
        """Log ``message % args`` unless this minute's are used up; whether it was logged."""
        with self._lock:
            now = self.clock()
            if now - self._start >= WINDOW:
                self._start, self._sent = now, 0
            if self._sent >= self.per_minute:
                self.suppressed += 1
                return False
            self._sent += 1
            left_out, self.suppressed = self.suppressed, 0
        if left_out:
            message, args = message + " (and %d more such warnings not logged)", (*args, left_out)
        self.logger.warning(message, *args)
        return True
