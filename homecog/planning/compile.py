"""The Python form of a domain written as data (:mod:`homecog.planning.schema`): each action
becomes a function ``(state, *args) -> state | None`` and each method a function
``(state, *args) -> subtasks | None``, as one would write them by hand in GTPyhop's style.

They are generated as Python source and compiled once per distinct source, so that the
planner runs plain attribute tests and assignments, as fast as hand-written functions. Each
action also gets a *reason* function ``(state, *args) -> str | None``: whether the arguments
have the action's shape and types, and which precondition fails (its reason text), for those
who carry plans out (the simulator, acting).

>>> from homecog.planning.schema import action
>>> dock = action("dock", "?place - place",
...               pre=[("(robot-at ?place)", "the robot is at {s.robot!r}, not at {place!r}")],
...               effects=["(docked)"])
>>> print(action_source(dock))
def dock(s, place):
    if not (s.robot == place):
        return None
    s.docked = True
    return s
"""

from __future__ import annotations

import functools
import hashlib
import keyword
import linecache
import sys
from collections.abc import Callable, Mapping, Sequence
from types import CodeType
from typing import Any

from homecog.planning.planner import Domain, Method
from homecog.planning.schema import (
    PREDICATES,
    ActionSchema,
    Atom,
    Implied,
    Let,
    Literal,
    MethodSchema,
    TaskSchema,
    Term,
    When,
    is_variable,
)

Tables = Mapping[str, Any]
"""The home's constants and tables the generated code reads: ``HELD``, ``USER``, ``IOT``,
``DEVICE_PLACE``, ``SOURCE``, and ``CHECK`` (per type, ``value -> reason | None``)."""


def _term(term: Term, scope: Sequence[str], where: str) -> str:
    if not is_variable(term):
        return repr(term)
    if term[1:] not in scope:
        raise ValueError(f"{where}: {term} is neither a parameter nor bound by a let before it")
    return term[1:]


def _args(atom: Atom, scope: Sequence[str], where: str) -> list[str]:
    return [_term(a, scope, where) for a in atom.args]


def _test(literal: Literal, scope: Sequence[str], where: str) -> str:
    text = PREDICATES[literal.atom.predicate].test.format(*_args(literal.atom, scope, where))
    return text if literal.positive else f"not ({text})"


def _let(let: Let, scope: list[str], where: str) -> tuple[str, str]:
    """(the assignment, the test that there is no value); adds the variable to ``scope``."""
    predicate = PREDICATES[let.atom.predicate]
    variable = let.variable[1:]
    value = str(predicate.value).format(*_args(Atom(let.atom.predicate, let.atom.args[:-1]), scope, where))
    scope.append(variable)
    return f"{variable} = {value}", predicate.undefined.format(v=variable)


def _effect(effect: Literal | When, scope: Sequence[str], where: str) -> list[str]:
    literal = effect.effect if isinstance(effect, When) else effect
    predicate = PREDICATES[literal.atom.predicate]
    how = predicate.add if literal.positive else predicate.delete
    if how is None or isinstance(how, Implied):
        return []  # another effect of the action writes the same variable (schema checks it)
    lines = how.format(*_args(literal.atom, scope, where)).splitlines()
    if isinstance(effect, When):
        return [
            f"if {_term(effect.variable, scope, where)} == {effect.value!r}:",
            *("    " + x for x in lines),
        ]
    return lines


def action_source(schema: ActionSchema) -> str:
    """The Python source of an action: lets, one test of every precondition, the effects."""
    where = f"action {schema.name}"
    scope = [name for name, _ in schema.params]
    lines = [
        f"def {schema.name}({', '.join(['s', *scope])}):",
        *_guards(schema.lets, [p.literal for p in schema.pre], scope, where),
    ]
    for effect in schema.effects:
        lines += ["    " + line for line in _effect(effect, scope, where)]
    lines.append("    return s")
    return "\n".join(lines)


def _guards(lets: Sequence[Let], pre: Sequence[Literal], scope: list[str], where: str) -> list[str]:
    """The lines that return ``None`` unless every let has a value and every precondition holds;
    each let adds its variable to ``scope``."""
    lines = []
    for let in lets:
        assign, undefined = _let(let, scope, where)
        lines += [f"    {assign}", f"    if {undefined}:", "        return None"]
    if pre:
        tests = " and ".join(_test(p, scope, where) for p in pre)
        lines += [f"    if not ({tests}):", "        return None"]
    return lines


def _format(template: str, scope: Sequence[str]) -> str:
    fields = ", ".join(["s=s", *(f"{v}={v}" for v in scope)])
    return f"{template!r}.format({fields})"


def reason_source(schema: ActionSchema) -> str:
    """The Python source of an action's reason function: the shape, the types, then each let
    and precondition in order, with its reason."""
    where = f"action {schema.name}"
    scope = [name for name, _ in schema.params]
    n = len(scope)
    lines = [
        f"def _why_{schema.name}(s, *args):",
        f"    if len(args) != {n} or not all(isinstance(a, str) for a in args):",
        f"        return {f'expected {n + 1} strings for {schema.name}'!r}",
    ]
    if scope:
        lines.append(f"    {', '.join(scope)}{',' if n == 1 else ''} = args")
        checks = " or ".join(f"CHECK[{kind!r}]({name})" for name, kind in schema.params)
        lines += [f"    why = {checks}", "    if why:", "        return why"]
    for let in schema.lets:
        fields = list(scope)
        assign, undefined = _let(let, scope, where)
        reason = let.reason or f"no value for {let.atom}"
        lines += [f"    {assign}", f"    if {undefined}:", f"        return {_format(reason, fields)}"]
    for p in schema.pre:
        reason = p.reason or f"{p.literal} does not hold"
        lines += [
            f"    if not ({_test(p.literal, scope, where)}):",
            f"        return {_format(reason, scope)}",
        ]
    lines.append("    return None")
    return "\n".join(lines)


def method_source(schema: MethodSchema, task: TaskSchema, name: str | None = None) -> str:
    """The Python source of a method: lets and preconditions (``None`` when one fails), then
    the subtasks."""
    where = f"method {schema.name} of {task.name}"
    scope = [p for p, _ in task.params]
    lines = [
        f"def {name or schema.name}({', '.join(['s', *scope])}):",
        *_guards(schema.lets, schema.pre, scope, where),
    ]
    subtasks = []
    for subtask in schema.subtasks:
        items = [repr(subtask[0]), *(_term(t, scope, where) for t in subtask[1:])]
        subtasks.append(f"({', '.join(items)}{',' if len(items) == 1 else ''})")
    lines.append(f"    return [{', '.join(subtasks)}]")
    return "\n".join(lines)


# Sources by the identity of the schemas they are made of: the domain's schemas are module
# constants and a home's service methods are made once (domain.py caches them), so that a
# second home costs a dictionary lookup, not a deep hash or a new source, per schema.
_SOURCES: dict[tuple[int, ...], tuple[tuple[object, ...], str]] = {}


def _source(make: Callable[..., str], *args: Any) -> str:
    key = (id(make), *map(id, args))
    hit = _SOURCES.get(key)
    if hit is not None and hit[0] == args:  # the same objects: == stops at identity
        return hit[1]
    if len(_SOURCES) > 4096:
        _SOURCES.clear()
    source = make(*args)
    _SOURCES[key] = (args, source)  # holds the schemas, so that their ids stay theirs
    return source


@functools.lru_cache(maxsize=64)
def _compiled(source: str) -> CodeType:
    # a file name per source, known to linecache, so that a traceback shows the generated line
    filename = f"<homecog domain {hashlib.sha1(source.encode()).hexdigest()[:12]}>"
    linecache.cache[filename] = (len(source), None, source.splitlines(keepends=True), filename)
    return compile(source, filename, "exec")


def compile_domain(
    name: str,
    actions: Sequence[ActionSchema],
    tasks: Sequence[TaskSchema],
    methods: Sequence[MethodSchema],
    tables: Tables,
) -> Domain:
    """The planner's :class:`Domain` (actions, methods in the order given, reasons) of a domain
    written as data, reading the home's ``tables``."""
    by_name = {t.name: t for t in tasks}
    taken = {a.name for a in actions}  # names of the generated functions
    parts, method_defs = [], []
    for a in actions:
        parts += [_source(action_source, a), _source(reason_source, a)]
    for i, m in enumerate(methods):
        if m.task not in by_name:
            raise ValueError(f"method {m.name}: unknown task {m.task!r}")
        free = m.name.isidentifier() and not keyword.iskeyword(m.name) and m.name.islower()
        def_name = m.name if free and m.name not in taken else sys.intern(f"_method_{i}")  # see _source
        taken.add(m.name)
        method_defs.append((m, def_name))
        parts.append(_source(method_source, m, by_name[m.task], def_name))
    namespace: dict[str, Any] = {"__name__": "homecog.planning.domain", **tables}
    exec(_compiled("\n\n\n".join(parts) + "\n"), namespace)
    by_task: dict[str, list[Method]] = {}
    for m, def_name in method_defs:
        function = namespace[def_name]
        function.__name__ = function.__qualname__ = m.name  # the name the tree shows
        by_task.setdefault(m.task, []).append(function)
    return Domain(
        name=name,
        actions={a.name: namespace[a.name] for a in actions},
        methods=by_task,
        reasons={a.name: namespace[f"_why_{a.name}"] for a in actions},
    )
