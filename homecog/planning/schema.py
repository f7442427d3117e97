"""The language the planning domain is written in: actions and methods as data, in HDDL's
notation, over the predicates of the planning state (:class:`~homecog.planning.state.State`).

The domain is written once, here as data, and both its forms are generated from it: the
Python actions and methods the planner runs (:mod:`homecog.planning.compile`) and the HDDL text
other planners read (:mod:`homecog.planning.hddl`).

* A **predicate** (:data:`PREDICATES`) is declared as in HDDL and says how the Python state
  reads it (a test), and, for a functional one, the value of its last argument given the
  others (``(robot-at ?p)``: ``s.robot``) and how an action's effect writes it.
* An **action** has typed parameters, *lets* (a variable bound by a functional predicate,
  ``(device-at ?device ?where)``: where the device is switched by hand), preconditions with
  the reason given when one does not hold, effects (literals, and ``when`` on the value of a
  parameter), and the HDDL actions it is written as (*variants*: HDDL has no conditional
  effects in the HTN track and Aries refuses to delete and add one atom, so ``switch_iot d s``
  is ``switch-iot-on d`` or ``switch-iot-off d``, and ``move p p`` is ``stay p``).
* A **method** decomposes a compound task: lets, preconditions and ordered subtasks.

Variables start with ``?``; anything else in a subtask is a constant.

>>> pick = action(
...     "pick", "?obj - item ?place - place",
...     pre=[("(robot-at ?place)", "the robot is at {s.robot!r}, not at {place!r}"),
...          ("(hand-empty)", "the robot already holds {s.holding!r}")],
...     effects=["(holding ?obj)", "(not (hand-empty))"])
>>> pick.params, [str(p.literal) for p in pick.pre], [str(e) for e in pick.effects]
((('obj', 'item'), ('place', 'place')), ['(robot-at ?place)', '(hand-empty)'], \
['(holding ?obj)', '(not (hand-empty))'])
>>> str(parse_effect("(when (= ?setting on) (is-on ?device))"))
'(when (= ?setting on) (is-on ?device))'
"""

from __future__ import annotations

import functools
import keyword
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

Term = str  # "?name" (a variable) or a constant


def is_variable(term: Term) -> bool:
    return term.startswith("?")


@dataclass(frozen=True)
class Atom:
    predicate: str
    args: tuple[Term, ...] = ()

    def __str__(self) -> str:
        return f"({' '.join((self.predicate, *self.args))})"


@dataclass(frozen=True)
class Literal:
    atom: Atom
    positive: bool = True

    def __str__(self) -> str:
        return str(self.atom) if self.positive else f"(not {self.atom})"


@dataclass(frozen=True)
class When:
    """An effect that happens when a parameter has a value: ``(when (= ?setting on) (is-on ?d))``."""

    variable: Term
    value: str
    effect: Literal

    def __str__(self) -> str:
        return f"(when (= {self.variable} {self.value}) {self.effect})"


Effect = Literal | When


@dataclass(frozen=True)
class Implied:
    """An effect the Python state needs no statement for, because another effect of the same
    action writes the same variable: one of ``by``, as (predicate, positive)."""

    by: tuple[tuple[str, bool], ...]


@dataclass(frozen=True)
class Predicate:
    """A predicate, as HDDL declares it and as the Python state reads and writes it.

    Templates: ``{0}``, ``{1}``, … are the arguments as Python expressions, ``s`` the state; the
    names of :mod:`homecog.planning.compile`'s namespace (``HELD``, ``USER``, ``IOT``,
    ``DEVICE_PLACE``, ``SOURCE``) are the home's constants and tables."""

    declaration: str
    test: str
    value: str | None = None
    """A functional predicate: its last argument given the others (``None``: none such)."""
    undefined: str = "{v} is None"
    add: str | Implied | None = None
    delete: str | Implied | None = None
    """Statements that make the atom hold (``add``) or not; ``None``: no action may change it."""

    @property
    def types(self) -> tuple[str, ...]:
        return tuple(re.findall(r"- (\S+?)\b", self.declaration))


PREDICATES: dict[str, Predicate] = {
    "robot-at": Predicate(
        "(robot-at ?p - place)",
        test="s.robot == {0}",
        value="s.robot",
        add="s.robot = {0}",
        delete=Implied((("robot-at", True),)),
    ),
    "at": Predicate(
        "(at ?i - item ?p - place)",
        test="s.objects.get({0}) == {1}",
        value="s.objects.get({0})",
        undefined="{v} is None or {v} == HELD",
        add="s.objects[{0}] = {1}",
        delete=Implied((("holding", True), ("at", True))),
    ),
    "holding": Predicate(
        "(holding ?i - item)",
        test="s.holding == {0}",
        value="s.holding",
        add="s.holding = {0}\ns.objects[{0}] = HELD",
        delete="s.holding = None",
    ),
    "hand-empty": Predicate(
        "(hand-empty)",
        test="s.holding is None",
        add=Implied((("holding", False),)),
        delete=Implied((("holding", True),)),
    ),
    "user-at": Predicate(
        "(user-at ?u - person ?p - place)",
        test="({0} == USER and s.user == {1})",
        value="(s.user if {0} == USER else None)",
    ),
    "is-on": Predicate(
        "(is-on ?d - device)",
        test="s.devices.get({0}, False)",
        add="s.devices[{0}] = True",
        delete="s.devices[{0}] = False",
    ),
    "iot": Predicate("(iot ?d - device)", test="{0} in IOT"),
    "device-at": Predicate(
        "(device-at ?d - device ?p - place)",
        test="DEVICE_PLACE.get({0}) == {1}",
        value="DEVICE_PLACE.get({0})",
    ),
    "source": Predicate(
        "(source ?i - item ?p - place)", test="SOURCE.get({0}) == {1}", value="SOURCE.get({0})"
    ),
    "docked": Predicate("(docked)", test="s.docked", add="s.docked = True", delete="s.docked = False"),
}

TYPES = ("place", "item", "device", "person", "message", "setting")
SETTINGS = ("on", "off")


@dataclass(frozen=True)
class Let:
    """A variable bound by a functional predicate: the last argument of ``atom``."""

    atom: Atom
    reason: str = ""
    """Why an action does not apply when there is no such value (a format template)."""

    @property
    def variable(self) -> Term:
        return self.atom.args[-1]


@dataclass(frozen=True)
class Precondition:
    literal: Literal
    reason: str = ""
    """Why the action does not apply when this does not hold: a ``str.format`` template of
    ``s`` (the state) and the parameters and lets by name."""


@dataclass(frozen=True)
class Variant:
    """An HDDL action that is the action with some parameters bound: to a constant, or to
    another parameter (``?origin``)."""

    name: str
    bind: tuple[tuple[Term, Term], ...] = ()


@dataclass(frozen=True)
class ActionSchema:
    name: str
    params: tuple[tuple[str, str], ...]
    lets: tuple[Let, ...]
    pre: tuple[Precondition, ...]
    effects: tuple[Effect, ...]
    variants: tuple[Variant, ...]


@dataclass(frozen=True)
class TaskSchema:
    """A compound task and its typed parameters."""

    name: str
    params: tuple[tuple[str, str], ...] = ()


@dataclass(frozen=True)
class MethodSchema:
    name: str
    task: str
    lets: tuple[Let, ...] = ()
    pre: tuple[Literal, ...] = ()
    subtasks: tuple[tuple[Term, ...], ...] = ()


# -- reading the notation -------------------------------------------------------------------
_TOKEN = re.compile(r"\(|\)|[^\s()]+")


def _tree(text: str) -> object:
    tokens = _TOKEN.findall(text)
    stack: list[list[object]] = [[]]
    for token in tokens:
        if token == "(":
            stack.append([])
        elif token == ")":
            if len(stack) == 1:
                raise ValueError(f"unbalanced parentheses in {text!r}")
            done = stack.pop()
            stack[-1].append(done)
        else:
            stack[-1].append(token)
    if len(stack) != 1 or len(stack[0]) != 1:
        raise ValueError(f"expected one expression in {text!r}")
    return stack[0][0]


def _atom(tree: object, text: str) -> Atom:
    if not isinstance(tree, list) or not tree or not all(isinstance(t, str) for t in tree):
        raise ValueError(f"expected an atom like (robot-at ?p) in {text!r}")
    name, *args = tree
    predicate = PREDICATES.get(str(name))
    if predicate is None:
        raise ValueError(f"unknown predicate {name!r} in {text!r}; expected one of {', '.join(PREDICATES)}")
    if len(args) != len(predicate.types):
        raise ValueError(f"{name} takes {len(predicate.types)} arguments, got {len(args)} in {text!r}")
    return Atom(str(name), tuple(str(a) for a in args))


def _literal(tree: object, text: str) -> Literal:
    if isinstance(tree, list) and tree[:1] == ["not"] and len(tree) == 2:
        return Literal(_atom(tree[1], text), positive=False)
    return Literal(_atom(tree, text))


@functools.lru_cache(maxsize=1024)  # a home's services parse the same few texts again
def parse_literal(text: str) -> Literal:
    return _literal(_tree(text), text)


def parse_effect(text: str) -> Effect:
    tree = _tree(text)
    if isinstance(tree, list) and tree[:1] == ["when"]:
        test = tree[1] if len(tree) == 3 else None
        if not (isinstance(test, list) and len(test) == 3 and test[0] == "=" and is_variable(str(test[1]))):
            raise ValueError(f"expected (when (= ?parameter value) effect) in {text!r}")
        return When(str(test[1]), str(test[2]), _literal(tree[2], text))
    return _literal(tree, text)


def parse_params(text: str) -> tuple[tuple[str, str], ...]:
    """``"?obj - item ?place - place"`` as ``(("obj", "item"), ("place", "place"))``."""
    parts = text.split()
    if len(parts) % 3 or any(p != "-" for p in parts[1::3]) or not all(is_variable(p) for p in parts[::3]):
        raise ValueError(f"expected parameters like '?p - place ?d - device', got {text!r}")
    out = tuple((name[1:], kind) for name, kind in zip(parts[::3], parts[2::3], strict=True))
    for name, kind in out:
        if kind not in TYPES:
            raise ValueError(f"unknown type {kind!r} of ?{name}; expected one of {', '.join(TYPES)}")
        _check_variable(name)
    return out


def _check_variable(name: str) -> None:
    # variables become names of the generated Python functions (s is the state; upper-case
    # names are the home's tables)
    if not name.isidentifier() or keyword.iskeyword(name) or name == "s" or not name.islower():
        raise ValueError(f"variable ?{name}: expected a lowercase Python name, not a keyword or s")


def _let(spec: str | tuple[str, str]) -> Let:
    text, reason = (spec, "") if isinstance(spec, str) else spec
    literal = parse_literal(text)
    if not literal.positive or PREDICATES[literal.atom.predicate].value is None:
        raise ValueError(f"a let binds the last argument of a functional predicate, not {text!r}")
    if not is_variable(literal.atom.args[-1]):
        raise ValueError(f"a let binds a variable: {text!r}")
    _check_variable(literal.atom.args[-1][1:])
    return Let(literal.atom, reason)


def action(
    name: str,
    params: str,
    *,
    lets: Iterable[str | tuple[str, str]] = (),
    pre: Iterable[tuple[str, str]] = (),
    effects: Iterable[str] = (),
    variants: Iterable[tuple[str, dict[str, str]]] = (),
) -> ActionSchema:
    """An action schema from the notation; checks that the Python state can carry its effects
    out as HDDL says them."""
    schema = ActionSchema(
        name,
        parse_params(params),
        tuple(_let(spec) for spec in lets),
        tuple(Precondition(parse_literal(text), reason) for text, reason in pre),
        tuple(parse_effect(text) for text in effects),
        tuple(Variant(n, tuple(bind.items())) for n, bind in variants) or (Variant(name.replace("_", "-")),),
    )
    _check_effects(schema)
    return schema


def method(
    name: str,
    task: str,
    *,
    lets: Iterable[str] = (),
    pre: Iterable[str] = (),
    subtasks: Iterable[Sequence[Term]] = (),
) -> MethodSchema:
    """A method schema from the notation."""
    return MethodSchema(
        name,
        task,
        tuple(_let(spec) for spec in lets),
        tuple(parse_literal(text) for text in pre),
        tuple(tuple(t) for t in subtasks),
    )


def _check_effects(schema: ActionSchema) -> None:
    done = {
        (e.atom.predicate, e.positive)
        for e in (x.effect if isinstance(x, When) else x for x in schema.effects)
    }
    for effect in schema.effects:
        literal = effect.effect if isinstance(effect, When) else effect
        predicate = PREDICATES[literal.atom.predicate]
        how = predicate.add if literal.positive else predicate.delete
        if how is None:
            raise ValueError(f"action {schema.name}: no action may change {literal.atom.predicate}")
        if isinstance(how, Implied) and not done & set(how.by):
            raise ValueError(f"action {schema.name}: {literal} needs one of {how.by} beside it")
