"""Device states: one vocabulary for all of homecog. ``on``/``off``, and the words
people and tools also write for them: true/false, yes/no, 1/0 and, for covers, open/closed.

>>> parse_state("on"), parse_state(False), parse_state("OFF"), parse_state("closed")
(True, False, False, False)
>>> STATE_WORDS["yes"], state_word(True)
(True, 'on')
"""

from __future__ import annotations

from homecog.errors import ContextError

STATE_WORDS = {
    "on": True,
    "off": False,
    "true": True,
    "false": False,
    "yes": True,
    "no": False,
    "1": True,
    "0": False,
    "open": True,
    "closed": False,
}


def parse_state(value: object, what: str = "device") -> bool:
    """A device state from on/off (or true/false, yes/no, 1/0, open/closed); ContextError
    naming ``what`` for anything else."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    word = str(value).strip().lower()
    if word in STATE_WORDS:
        return STATE_WORDS[word]
    raise ContextError(f"{what}: unknown state {value!r}; expected on or off")


def state_word(on: bool) -> str:
    """A state as the context writes it: ``on`` or ``off``."""
    return "on" if on else "off"
