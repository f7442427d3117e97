"""The error hierarchy of homecog.

Every error a user can cause derives from :class:`HomecogError`; the command line
prints its message as one line and exits non-zero, never with a traceback.
"""

from __future__ import annotations

#: the most characters of an error's message the command line prints
LINE = 1000


class HomecogError(Exception):
    """Base class of every error homecog raises on bad input or state."""


def one_line(message: str, limit: int = LINE) -> str:
    r"""A message as the command line prints it: one line, of at most ``limit`` characters (a
    value quoted from a hostile file is not echoed back whole).

    >>> one_line("a.csv: line 2:\nbad"), one_line("x" * 20, limit=8)
    ('a.csv: line 2: bad', 'xxxxxxx…')
    """
    text = message.replace("\r", " ").replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 1] + "…"


class HomeFileError(HomecogError, ValueError):
    """A home definition that cannot be read or is inconsistent.

    The message names the file, the key path and what was expected, e.g.
    ``paper.yaml: comfort.lamp[2].when.behavior: unknown value 'nap'; expected one of read, ...``.
    """


class NameProblemError(HomecogError, ValueError):
    """A home or user name that is not one (:mod:`homecog.names`)."""


class ContextError(HomecogError, ValueError):
    """A context (readings and device states) that does not fit the home."""


class QTableError(HomecogError):
    """A Q table that cannot be read, or that was made for another home."""


class HomeTooLargeError(HomecogError):
    """A home whose state space does not fit a tabular Q table."""


class PlanningError(HomecogError):
    """A request that cannot be planned or carried out: an unknown service, a home without a
    layout, a place inside a wall or out of the robot's reach."""


class HomeAssistantError(HomecogError):
    """A Home Assistant instance that cannot be used: a bad URL, one that cannot be reached, a
    refused token, entities it does not have, or a recorder database of a schema we cannot read."""


class StoreError(HomecogError):
    """A knowledge database that cannot be used: a bad URL, a server that cannot be reached, a
    database made for another home, or a log that does not fit."""


class UsageProblemError(HomecogError):
    """A bad command-line argument."""


class EvaluationError(HomecogError):
    """Bad evaluation input: an incompatible truth home, a broken scenario or event file."""


class RealDataError(HomecogError):
    """A data folder that cannot be read as the format of its data set (the MIT home-activity
    data, van Kasteren's houses)."""


class LogFileError(HomecogError):
    """A log of state changes that cannot be read: a missing column, a bad timestamp, a file
    that is not UTF-8 text, or a home without a ``log`` section."""


class MqttError(ContextError):
    """A broker URL that cannot be used, or a broker that cannot be reached."""


class ConflictError(StoreError):
    """A transaction the database aborted for a deadlock or a serialization failure: retry it."""


class FixedContextError(HomecogError):
    """The context comes from a source that cannot be set by hand (a broker, Home Assistant)."""


class NotPendingError(HomecogError):
    """An answer (yes or no) to a proposal the robot no longer puts to that user there: another
    context since, answered already, or never proposed (:mod:`homecog.robot.review`)."""


class SettingsError(HomecogError):
    """A setting of the server that is out of range."""


class CommandError(HomecogError):
    """A command that could not carry an action out in the world: a switch whose broker is
    gone, a door that is closed, an object that is not where the robot believed it. Acting
    observes the world again and plans anew when one fails."""


class FleetError(HomecogError):
    """A fleet that cannot be learned or served: a folder without home files, Ray that cannot be
    had or reached, a database that holds no home."""


class UnknownHomeError(HomecogError):
    """A home the fleet's database does not hold (the message names those it does)."""


class DependencyNotInstalledError(HomecogError):
    """An optional part of homecog whose extra is not installed (the pyrobosim body): the message
    says what to install, as gymnasium's ``DependencyNotInstalled`` does."""
