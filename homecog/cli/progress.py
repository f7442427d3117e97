"""A long command's progress on stderr, the same for every command.

On a terminal, a live bar (rich), once the command has run a second: what is being done, how
much of how much where that is known (a pulsing bar where it is not), and the time elapsed; it
is gone when the command ends. Where
stderr is no terminal (a file, a pipe, a CI log), a line every few seconds once the command has
run that long, so a short command prints nothing and a long one shows it is alive::

    homecog: replay: 3,000 of 12,000 events (25 %), 10 s

The seconds between lines are ``$HOMECOG_PROGRESS_SECONDS`` (default 5; 0: no lines). Either
way, stdout stays the command's own: ``--json`` prints one object there, whatever its progress.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from types import TracebackType
from typing import TextIO

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from homecog.errors import UsageProblemError
from homecog.progress import Counted

#: the environment variable of the seconds between lines off a terminal
SECONDS_VARIABLE = "HOMECOG_PROGRESS_SECONDS"
#: seconds between lines off a terminal, by default
SECONDS = 5.0
#: seconds a command runs before its bar appears on a terminal (none flashes for a quick one)
BAR_AFTER = 1.0


def line_seconds() -> float:
    """Seconds between progress lines off a terminal (0: none): ``$HOMECOG_PROGRESS_SECONDS``."""
    return parse_seconds(os.environ.get(SECONDS_VARIABLE, ""))


def parse_seconds(text: str) -> float:
    """The seconds between lines as the environment gives them (empty: the default).

    >>> parse_seconds("2.5"), parse_seconds(""), parse_seconds("0")
    (2.5, 5.0, 0.0)
    >>> parse_seconds("often")
    Traceback (most recent call last):
    homecog.errors.UsageProblemError: $HOMECOG_PROGRESS_SECONDS: expected seconds from 0 to 86400, got 'often'
    """
    text = text.strip()
    if not text:
        return SECONDS
    try:
        seconds = float(text)
    except ValueError:
        seconds = -1.0
    if not 0 <= seconds <= 86400:
        raise UsageProblemError(f"${SECONDS_VARIABLE}: expected seconds from 0 to 86400, got {text!r}")
    return seconds


class CommandProgress:
    """The progress of one command (a context manager): call it with what is being done (a
    :class:`~homecog.progress.Counted` message fills the bar), or :meth:`update` it with counts.

    ``stream`` is where it writes (default: stderr when entered); ``terminal`` whether that is a
    terminal (default: as the stream says); ``seconds`` between lines off a terminal (default:
    :func:`line_seconds`); ``bar_after`` the seconds before the bar appears on a terminal.
    """

    def __init__(
        self,
        what: str,
        *,
        stream: TextIO | None = None,
        terminal: bool | None = None,
        seconds: float | None = None,
        bar_after: float = BAR_AFTER,
    ) -> None:
        self.what = what
        self.stream = stream
        self.terminal = terminal
        self.seconds = seconds
        self.bar_after = bar_after
        self._message: str = ""
        self._counts: tuple[int, int] | None = None
        self._lock = threading.Lock()
        self._started = time.monotonic()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._bar: Progress | None = None
        self._task = None
        self._stream: TextIO | None = None

    def __call__(self, message: str) -> None:
        """What is being done now; a :class:`Counted` message also says how far."""
        with self._lock:
            self._message = message
            self._counts = (message.done, message.total) if isinstance(message, Counted) else None
        self._draw()

    def update(self, done: int, total: int) -> None:
        """How much of how much is done, under the current message."""
        with self._lock:
            self._counts = (done, total)
        self._draw()

    def say(self, text: str, *, style: str | None = None) -> None:
        """A line of the command's own on stderr (above the bar on a terminal), as it happens."""
        if self._bar is not None:
            self._bar.console.print(text, style=style, highlight=False, markup=False)
            return
        print(text, file=self._stream or sys.stderr, flush=True)

    def line(self) -> str:
        """The progress as one line: ``homecog: WHAT: MESSAGE (COUNTS), SECONDS s``."""
        with self._lock:
            message, counts = self._message, self._counts
        parts = [f"homecog: {self.what}"]
        if message:
            parts.append(f": {message.removesuffix(' ...')}")
        if counts is not None and not isinstance(message, Counted) and counts[1] > 0:
            parts.append(f"{' ' if message else ': '}{counts[0]:,} of {counts[1]:,}")
        if counts is not None and counts[1] > 0:
            parts.append(f" ({100 * counts[0] // counts[1]} %)")
        parts.append(f", {time.monotonic() - self._started:.0f} s")
        return "".join(parts)

    def __enter__(self) -> CommandProgress:
        self._started = time.monotonic()
        stream = self._stream = self.stream if self.stream is not None else sys.stderr
        terminal = self.terminal if self.terminal is not None else _is_terminal(stream)
        if terminal:
            self._thread = threading.Thread(target=self._show_bar, args=(stream,), daemon=True)
        else:
            seconds = self.seconds if self.seconds is not None else line_seconds()
            if seconds > 0:
                self._thread = threading.Thread(target=self._lines, args=(stream, seconds), daemon=True)
        if self._thread is not None:
            self._thread.start()
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
        if self._bar is not None:
            self._bar.stop()

    def _show_bar(self, stream: TextIO) -> None:
        """On a terminal: the bar, once the command has run ``bar_after`` seconds."""
        if self._stop.wait(self.bar_after):
            return
        bar = _bar(stream)
        bar.start()
        self._task = bar.add_task(self.what, total=None, counts="")
        self._bar = bar
        self._draw()

    def _lines(self, stream: TextIO, seconds: float) -> None:
        """Off a terminal: a line every ``seconds``, until the command ends."""
        while not self._stop.wait(seconds):
            try:
                print(self.line(), file=stream, flush=True)
            except (OSError, ValueError):
                return  # stderr closed: the command goes on without its progress

    def _draw(self) -> None:
        """On a terminal: the bar as the progress is now."""
        if self._bar is None or self._task is None:
            return
        with self._lock:
            message, counts = self._message, self._counts
        described = f"{self.what}: {message}" if message else self.what
        if counts is None:
            self._bar.update(self._task, description=described, total=None, counts="")
        else:
            done, total = counts
            shown = "" if isinstance(message, Counted) else f"{done:,}/{total:,}"
            self._bar.update(self._task, description=described, completed=done, total=total, counts=shown)


def _is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def _bar(stream: TextIO) -> Progress:
    """A transient rich bar on ``stream``: what, the bar, the counts, the time elapsed."""
    console = Console(file=stream, force_terminal=True, highlight=False)
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[counts]}"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    )
