"""Where a home file comes from and how its YAML is read.

A home is named (a built-in one, shipped in ``homecog.home.homes``) or is a path. Its text is
read with YAML 1.2 booleans (only true/false; a bare ``on``, ``off``, ``yes`` or ``no`` stays a
string), without base-60 numbers (``19:00`` stays a string, not 1140) and with an error on a
duplicate key, where PyYAML would silently keep the last.

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

from homecog.errors import HomeFileError

BUILTIN_PACKAGE = "homecog.home.homes"


class _Loader(yaml.SafeLoader):
    """SafeLoader with YAML 1.2 booleans and an error on duplicate keys."""

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
    looks_like_path = path.suffix in (".yaml", ".yml") or "/" in text or path.exists()
    if not looks_like_path:
        raise HomeFileError(
            f"unknown home {text!r}; built-in homes: {', '.join(builtin_homes())}, "
            "or give the path of a YAML file"
        )
    try:
        return str(name_or_path), path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise HomeFileError(f"{text}: no such file") from None
    except IsADirectoryError:
        raise HomeFileError(f"{text}: is a directory, not a home file") from None
    except (OSError, UnicodeDecodeError) as e:
        reason = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        raise HomeFileError(f"{text}: cannot read: {reason}") from None


def read_yaml(text: str, source: str) -> Any:
    """The parsed YAML of a home file; :class:`HomeFileError` naming ``source`` and the line."""
    try:
        return yaml.load(text, Loader=_Loader)  # _Loader is a SafeLoader
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
        where = f"line {mark.line + 1}: " if mark is not None else ""
        problem = getattr(e, "problem", None) or str(e).splitlines()[0]
        raise HomeFileError(f"{source}: {where}not valid YAML: {problem}") from None
