"""Where a home file comes from and how its YAML is read.

A home is named (a built-in one, shipped in ``homecog.home.homes``) or is a path. Its text is
read with YAML 1.2 booleans (only true/false; a bare ``on``, ``off``, ``yes`` or ``no`` stays a
string), without base-60 numbers (``19:00`` stays a string, not 1140) and with an error on a
duplicate key, where PyYAML would silently keep the last.

A home file is bounded (docs/design.md, "Hostile input"): at most 1 MiB, read only where it is
a regular file (:mod:`homecog.text_files`); at most :data:`MAX_DEPTH` levels deep and
:data:`MAX_NODES` values, aliases counted as what they stand for, so an alias bomb is refused
before it is expanded, and an alias inside the node it names too. Every number in it lies
within ±:data:`MAX_NUMBER` and every date is one, checked before a value is made (a 5,000-digit
integer passed Python's limit on converting text to an integer), and refused with its key path.

>>> "paper" in builtin_homes()
True
>>> read_yaml("window: on\\nat: 19:00", "den.yaml")
{'window': 'on', 'at': '19:00'}
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from yaml.composer import Composer, ComposerError
from yaml.constructor import SafeConstructor
from yaml.events import AliasEvent
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode
from yaml.resolver import Resolver

from homecog.errors import HomeFileError
from homecog.names import shown
from homecog.text_files import HOME_FILE_LIMIT, read_text, size_text

try:  # libyaml's parser where PyYAML has it: twice as fast as the pure Python one
    from yaml._yaml import CParser as _Parser
except ImportError:  # pragma: no cover - PyYAML without libyaml

    class _Parser(yaml.reader.Reader, yaml.scanner.Scanner, yaml.parser.Parser):  # type: ignore[no-redef]
        def __init__(self, stream: str) -> None:
            yaml.reader.Reader.__init__(self, stream)
            yaml.scanner.Scanner.__init__(self)
            yaml.parser.Parser.__init__(self)


BUILTIN_PACKAGE = "homecog.home.homes"
MAX_DEPTH = 32  # levels of nesting; a home file needs 8
MAX_NODES = 100_000  # values, aliases expanded; the 1,002-device home has 56,162
MAX_NUMBER = 10**15  # the largest size of a number in a home file (lux, minutes, metres, weights)
_NUMBER_CHARS = 40  # a longer number is out of range whatever it says: never converted
_INT, _FLOAT, _DATE = (f"tag:yaml.org,2002:{t}" for t in ("int", "float", "timestamp"))
_CHECKED = frozenset((_INT, _FLOAT, _DATE))


class _BadValueError(Exception):
    """A scalar of a home file that cannot be a value: ``(key path, what is wrong)``."""

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(path, problem)
        self.path, self.problem = path, problem


def number_out_of_range(text: str) -> str:
    """What :class:`HomeFileError` says of a number outside ±:data:`MAX_NUMBER`.

    >>> number_out_of_range("1" * 50)
    "number 11111111111111111111… (50 characters) is out of range; a home file's numbers lie within ±1e15"
    """
    shown_text = text if len(text) <= 24 else f"{text[:20]}… ({len(text):,} characters)"
    return f"number {shown_text} is out of range; a home file's numbers lie within ±1e15"


def number_in_range(value: float, text: str) -> bool:
    """Whether ``value``, read from ``text``, lies within ±:data:`MAX_NUMBER`; an infinity only
    where the text says one (``.inf``), never a number past a float's range (``1e400``).

    >>> number_in_range(1e15, "1e15"), number_in_range(float("inf"), ".inf")
    (True, True)
    >>> number_in_range(float("inf"), "1e400"), number_in_range(10**16, "10000000000000000")
    (False, False)
    """
    if value != value:  # NaN: the shape checks say what they make of it
        return True
    if value in (float("inf"), float("-inf")):
        return "inf" in text.lower()
    return abs(value) <= MAX_NUMBER


def _step(path: str, key: object) -> str:
    return f"{path}[{key}]" if isinstance(key, int) else (f"{path}.{key}" if path else str(key))


class _BoundedComposer(Composer):
    """PyYAML's composer, refusing a document nested deeper than :data:`MAX_DEPTH` or of more
    than :data:`MAX_NODES` values once its aliases are expanded, as it composes it."""

    def __init__(self) -> None:
        super().__init__()
        self._depth = self._deepest = self._count = 0
        self._sizes: dict[int, tuple[int, int]] = {}  # id(node) -> (values, height), aliases expanded

    def compose_node(self, parent: Node | None, index: object) -> Node:
        if self.check_event(AliasEvent):
            mark = self.peek_event().start_mark
            node = super().compose_node(parent, index)
            size = self._sizes.get(id(node))
            if size is None:
                raise ComposerError(None, None, "an alias inside the node it names", mark)
            self._grow(size[0], self._depth + size[1], mark)
            return node
        mark = self.peek_event().start_mark
        self._depth += 1
        outer, start = self._deepest, self._count
        self._grow(1, self._depth, mark)
        node = super().compose_node(parent, index)
        self._sizes[id(node)] = (self._count - start, self._deepest - self._depth + 1)
        self._deepest = max(outer, self._deepest)
        self._depth -= 1
        return node

    def _grow(self, values: int, depth: int, mark: Any) -> None:
        self._count += values
        self._deepest = max(self._deepest, depth)
        if depth > MAX_DEPTH:
            raise ComposerError(None, None, f"nested deeper than {MAX_DEPTH} levels", mark)
        if self._count > MAX_NODES:
            raise ComposerError(None, None, f"more than {MAX_NODES:,} values (aliases expanded)", mark)


class _Loader(_BoundedComposer, _Parser, SafeConstructor, Resolver):
    """A safe loader with YAML 1.2 booleans, an error on duplicate keys, and bounds."""

    def __init__(self, stream: str) -> None:
        _Parser.__init__(self, stream)
        _BoundedComposer.__init__(self)
        SafeConstructor.__init__(self)
        Resolver.__init__(self)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[Any] = set()
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        return super().construct_mapping(node, deep=deep)

    def construct_document(self, node: Node) -> Any:
        self._check_values(node, [], set())
        return super().construct_document(node)

    def _check_values(self, node: Node, keys: list[object], seen: set[int]) -> None:
        """Refuse a number outside ±:data:`MAX_NUMBER` or a date that is none, naming its key
        path, before any value is made (a node an alias names again is checked once; the path
        is written only for a refusal)."""
        if id(node) in seen:
            return
        seen.add(id(node))
        if isinstance(node, ScalarNode):
            if node.tag in _CHECKED:
                self._check_scalar(node, keys)
        elif isinstance(node, SequenceNode):
            for i, item in enumerate(node.value):
                keys.append(i)
                self._check_values(item, keys, seen)
                keys.pop()
        elif isinstance(node, MappingNode):
            for key, value in node.value:
                keys.append(str(key.value)[:_NUMBER_CHARS] if isinstance(key, ScalarNode) else "?")
                self._check_values(key, keys, seen)
                self._check_values(value, keys, seen)
                keys.pop()

    def _check_scalar(self, node: ScalarNode, keys: list[object]) -> None:
        text = str(node.value)
        problem = None
        try:
            if node.tag != _DATE:
                if len(text) > _NUMBER_CHARS:
                    problem = number_out_of_range(text)
                else:
                    construct = self.construct_yaml_int if node.tag == _INT else self.construct_yaml_float
                    if not number_in_range(construct(node), text):
                        problem = number_out_of_range(text)
            else:
                self.construct_yaml_timestamp(node)
        except (ValueError, OverflowError):
            problem = f"{text[:_NUMBER_CHARS]!r} is not a date"
        if problem is not None:
            path = ""
            for key in keys:
                path = _step(path, key)
            raise _BadValueError(path, problem)


# YAML 1.2 has no base-60 numbers: keep an unquoted clock time (19:00) a string, not 1140.
_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")
_Loader.yaml_implicit_resolvers = {
    first: [
        (tag, re.compile(r"(?!.*:)" + rx.pattern, rx.flags) if tag in _NUMBER_TAGS else rx)
        for tag, rx in resolvers
        if tag != "tag:yaml.org,2002:bool"
    ]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:bool", re.compile(r"^(?:true|True|TRUE|false|False|FALSE)$"), list("tTfF")
)


def builtin_homes() -> list[str]:
    """Names of the homes shipped with homecog."""
    files = resources.files(BUILTIN_PACKAGE).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".yaml"))


def resolve_home(name_or_path: str | Path) -> tuple[str, str]:
    """``(source name, YAML text)`` of a built-in home name or a path."""
    text = str(name_or_path)
    if text in builtin_homes():
        res = resources.files(BUILTIN_PACKAGE).joinpath(f"{text}.yaml")
        return f"{text}.yaml", res.read_text(encoding="utf-8")
    path = Path(name_or_path)
    looks_like_path = path.suffix in (".yaml", ".yml") or "/" in text or _exists(path)
    if not looks_like_path:
        raise HomeFileError(
            f"unknown home {shown(text)}; built-in homes: {', '.join(builtin_homes())}, "
            "or give the path of a YAML file"
        )
    return text, read_text(path, limit=HOME_FILE_LIMIT, what="a home file", error=HomeFileError)


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name too long, or with a NUL
        return False


def read_yaml(text: str, source: str) -> Any:
    """The parsed YAML of a home file; :class:`HomeFileError` naming ``source`` and the line.

    >>> read_yaml("a: &a [x, x, x]\\nb: &b [*a, *a, *a]\\nc: [*b, *b]", "den.yaml")["c"][1][2]
    ['x', 'x', 'x']
    >>> read_yaml("[" * 40 + "]" * 40, "den.yaml")
    Traceback (most recent call last):
    ...
    homecog.errors.HomeFileError: den.yaml: line 1: not valid YAML: nested deeper than 32 levels
    """
    if len(text) > HOME_FILE_LIMIT:
        raise HomeFileError(f"{source}: over the {size_text(HOME_FILE_LIMIT)} a home file may have")
    if "\0" in text:
        raise HomeFileError(f"{source}: a NUL character; a home file is text")
    try:
        return yaml.load(text, Loader=_Loader)  # a safe loader: plain data only
    except _BadValueError as e:
        raise HomeFileError(f"{source}: {e.path + ': ' if e.path else ''}{e.problem}") from None
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise HomeFileError(f"{source}: {where}not valid YAML: {problem}") from None
