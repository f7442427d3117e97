"""Load and validate home definitions.

Every error names the file, the key path and what was expected::

    paper.yaml: comfort.lamp[2].when.behavior: unknown value 'nap'; expected one of read, ...

YAML 1.1 readers turn a bare ``on``/``off``/``yes``/``no`` into booleans; this loader
reads YAML with YAML 1.2 booleans (only true/false), so category names such as
``yes`` stay strings, and device states accept on/off, true/false and yes/no.

>>> home = load_home("paper")
>>> home.name, len(home.services), home.context_count
('paper', 20, 2592)

The work is done by modules of one concept each: where the file comes from and how its YAML is
read (:mod:`~homecog.home.home_file`), the validation (:mod:`~homecog.home.validator`, made of
:mod:`~homecog.home.shapes`, :mod:`~homecog.home.context_section` and
:mod:`~homecog.home.rule_sections`) and what learning depends on (:mod:`~homecog.home.content`).
Their public names are importable from here too.
"""

from __future__ import annotations

from pathlib import Path

from homecog.home.content import canonical, content_hash, is_compatible
from homecog.home.home_file import BUILTIN_PACKAGE, builtin_homes, read_yaml, resolve_home
from homecog.home.model import Home
from homecog.home.shapes import parse_device_state
from homecog.home.validator import HomeValidator

__all__ = [
    "BUILTIN_PACKAGE",
    "builtin_homes",
    "canonical",
    "content_hash",
    "is_compatible",
    "load_home",
    "load_home_text",
    "parse_device_state",
    "resolve_home",
]


def load_home(name_or_path: str | Path) -> Home:
    """Load a home by built-in name (``paper``) or path, validated."""
    source, text = resolve_home(name_or_path)
    return load_home_text(text, source)


def load_home_text(text: str, source: str = "<home>") -> Home:
    """Parse and validate the YAML text of a home; ``source`` names it in errors."""
    return HomeValidator(source).home(read_yaml(text, source))
