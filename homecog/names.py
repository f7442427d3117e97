"""What a name is: a home's, and a household member's (a user's). One rule each, used by every
edge that takes one: home files, the command line, event and log files, the HTTP API, the
fleet's URLs, and the database keys they become.

A **home name** is an identifier: 1 to 64 ASCII letters, digits, ``_`` and ``-``, beginning with
a letter or a digit. It names files under the data directory and rows of the database, and is a
segment of the fleet's URLs, so it is never a path (no ``/``, no ``.``), never needs quoting, and
has one spelling: the fleet serves a home under its name as written, and any other spelling is
no home (404).

A **user name** is text a person types: 1 to 64 characters, printable (no control characters,
line breaks, surrogates or invisible formatting characters), neither beginning nor ending with
white space (so never only spaces). Edges that read typed cells (a CSV file, the page's field)
strip the space around a value first; the command line and the API take the name as given.

>>> home_name("paper_2"), user_name("Anna Lena")
('paper_2', 'Anna Lena')
>>> home_name_problem("../../x")
"'../../x' is not a home name: 1 to 64 letters, digits, _ or -, beginning with a letter or digit"
>>> user_name_problem("kim\\n")
"'kim\\\\n' is not a user name: it contains '\\\\n', which is not printable"
>>> user_name_problem("   ")
"'   ' is not a user name: it is only white space"
"""

from __future__ import annotations

import re

MAX_NAME = 64
HOME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"
# Characters no user name holds: C0 and C1 controls, DEL, line and paragraph separators,
# zero-width and bidirectional formatting characters, the byte order mark; and surrogates
# (text the command line could not decode), which JSON text cannot carry.
_UNPRINTABLE = r"\x00-\x1f\x7f-\x9f\u200b-\u200f\u2028-\u202e\u2060-\u206f\ufeff"
_SURROGATES = r"\ud800-\udfff"
# White space a name neither begins nor ends with, beyond the controls: every character
# ``str.isspace`` knows, written out, so that the rule reads the same to any regex engine.
_SPACE = r" \xa0\u1680\u2000-\u200a\u202f\u205f\u3000"
#: The user rule as the API's schema states it (its length as ``maxLength``).
USER_PATTERN = rf"^[^{_SPACE}{_UNPRINTABLE}](?:[^{_UNPRINTABLE}]*[^{_SPACE}{_UNPRINTABLE}])?$"
_HOME = re.compile(HOME_PATTERN)
_USER = re.compile(USER_PATTERN)
_BAD_CHAR = re.compile(f"[{_UNPRINTABLE}{_SURROGATES}]")
HOME_RULE = "1 to 64 letters, digits, _ or -, beginning with a letter or digit"
USER_RULE = "1 to 64 printable characters, neither beginning nor ending with white space"


def shown(value: object, limit: int = 40) -> str:
    """A value as a message shows it: its ``repr``, cut to ``limit`` characters.

    >>> shown("x" * 100, 12)
    "'xxxxxxxxxx…"
    """
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


def home_name_problem(value: object) -> str | None:
    """Why ``value`` is not a home name, or ``None`` where it is one."""
    if isinstance(value, str) and _HOME.fullmatch(value):  # fullmatch: "$" would take a final \n
        return None
    return f"{shown(value)} is not a home name: {HOME_RULE}"


def user_name_problem(value: object) -> str | None:
    """Why ``value`` is not a user name, or ``None`` where it is one."""
    if (
        isinstance(value, str)
        and len(value) <= MAX_NAME
        and _USER.fullmatch(value)
        and not _BAD_CHAR.search(value)
    ):
        return None
    if not isinstance(value, str):
        return f"{shown(value)} is not a user name: expected text"
    if not value:
        return "the user name is empty"
    why = f"{shown(value)} is not a user name: "
    if len(value) > MAX_NAME:
        return why + f"longer than {MAX_NAME} characters"
    bad = _BAD_CHAR.search(value)
    if bad is not None:
        return why + f"it contains {shown(bad.group())}, which is not printable"
    if not value.strip():
        return why + "it is only white space"
    return why + "it begins or ends with white space"


def home_name(value: object) -> str:
    """``value`` as a home name; :class:`ValueError` saying why it is not one."""
    problem = home_name_problem(value)
    if problem is not None:
        raise ValueError(problem)
    return value  # type: ignore[return-value]


def user_name(value: object) -> str:
    """``value`` as a user name; :class:`ValueError` saying why it is not one."""
    problem = user_name_problem(value)
    if problem is not None:
        raise ValueError(problem)
    return value  # type: ignore[return-value]
