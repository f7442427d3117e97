"""The planning domain of a home and a request as HDDL (the hierarchical PDDL of the IPC 2020
HTN track), so that other planners (unified-planning with Aries, PANDA, ...) read the same
problem that :func:`homecog.planning.plan_services` solves.

The HDDL domain is written from the very data the planner's functions are generated from
(:mod:`homecog.planning.domain`), for one home. Where the two differ, it is for HDDL's sake,
and :func:`actions_from_hddl` maps a plan back:

* an action is written as its *variants* (``move p p`` is ``stay p``, since Aries takes the
  delete and add of ``(robot-at p)`` for a conflict; ``switch_iot d on`` is
  ``switch-iot-on d``, since the HTN track has no conditional effects), and a method with such
  an action among its subtasks as one method per variant, with the equalities that choose it
  (``goto-move`` and ``goto-stay``);
* an action's lets are parameters too: ``hand-over`` and ``switch-by-hand-*`` carry the place
  where they happen;
* our methods are tried in order, HDDL's are a free choice: a method gets the negation of the
  precondition of each earlier method of its task (``by-hand-*`` needs ``(not (iot ?device))``,
  ``fill-at-source`` needs the robot elsewhere), so an HDDL planner finds the plan we find;
* ``object`` is PDDL's root type, so movable objects are of type ``item``; the user is a
  ``person`` and the sentences the robot says are ``message`` constants;
* names are HDDL identifiers (:mod:`homecog.planning.hddl_names`).

>>> from homecog.home import load_home
>>> from homecog.planning import initial_state
>>> home = load_home("paper")
>>> print(domain_hddl(home).splitlines()[0])
(define (domain paper)
>>> problem = problem_hddl(home, ["SendDrinks", "CloseWindow"], initial_state(home, user="sofa"))
>>> print(problem[problem.index("(:htn"):].splitlines()[2].strip())
:ordered-subtasks (and (send-drinks) (close-window))
>>> actions_from_hddl(home, [("move", ["charger", "dispenser"]), ("hand-over", ["cup", "user", "sofa"]),
...                          ("switch-iot-off", ["window"]), ("speak", ["remind-to-sleep-msg"])])
[('move', 'charger', 'dispenser'), ('hand_over', 'cup', 'user'), ('switch_iot', 'window', 'off'), \
('speak', 'It is late; time to go to sleep.')]

``benchmarks/bench_planning.py`` compares our planner with unified-planning and Aries on these
files.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.planning.domain import ACTIONS, METHOD_SCHEMAS, TASKS, service_methods, tables
from homecog.planning.hddl_names import Names, home_names, identifier, method_names
from homecog.planning.planner import Task
from homecog.planning.schema import (
    PREDICATES,
    SETTINGS,
    TYPES,
    ActionSchema,
    Atom,
    Literal,
    MethodSchema,
    TaskSchema,
    Term,
    Variant,
    When,
    is_variable,
)
from homecog.planning.state import HELD, USER, State

__all__ = ["actions_from_hddl", "domain_hddl", "hddl_name", "problem_hddl"]

_ACTIONS = {a.name: a for a in ACTIONS}
_TASKS = {t.name: t for t in TASKS}


def hddl_name(home: Home, kind: str, name: str) -> str:
    """The HDDL name of one of a home's things: ``kind`` is ``task`` (a service), ``place``,
    ``item``, ``device``, ``person`` or ``setting``.

    >>> from homecog.home import load_home
    >>> home = load_home("paper")
    >>> [hddl_name(home, k, n) for k, n in [("task", "TurnOnTVL"), ("device", "lamp"), ("place", "lamp")]]
    ['turn-on-tvl', 'lamp', 'lamp-place']
    """
    try:
        return home_names(home)(kind, name)
    except KeyError:
        raise PlanningError(f"no {kind} {name!r} in home {home.name!r}") from None


def _and(parts: Sequence[str], empty: str = "") -> str:
    if len(parts) == 1:
        return parts[0]
    return f"(and {' '.join(parts)})" if parts else empty


def _typed(params: Iterable[tuple[str, str]]) -> str:
    return " ".join(f"?{name} - {kind}" for name, kind in params)


def _let_type(atom: Atom) -> str:
    return PREDICATES[atom.predicate].types[-1]


# -- actions ----------------------------------------------------------------------------------
def _literal(lit: Literal, terms: Callable[[Term, str], str]) -> str:
    kinds = PREDICATES[lit.atom.predicate].types
    args = tuple(terms(t, k) for t, k in zip(lit.atom.args, kinds, strict=True))
    text = str(Atom(lit.atom.predicate, args))
    return text if lit.positive else f"(not {text})"


def _action_variant(a: ActionSchema, variant: Variant, terms: Callable[[Term, str], str]) -> list[str]:
    """The lines of one HDDL action: ``a`` with the variant's parameters bound."""
    bind = dict(variant.bind)

    def term(t: Term, kind: str) -> str:
        return terms(bind.get(t, t), kind)

    params = [(p, k) for p, k in a.params if f"?{p}" not in bind]
    params += [(let.variable[1:], _let_type(let.atom)) for let in a.lets]
    pre = [_literal(Literal(let.atom), term) for let in a.lets] + [_literal(p.literal, term) for p in a.pre]
    effects: list[str] = []
    for effect in a.effects:
        if isinstance(effect, When):
            value = bind.get(effect.variable)
            if value is None or is_variable(value):
                raise ValueError(f"action {a.name}: HDDL needs a variant that binds {effect.variable}")
            if value == effect.value:
                effects.append(_literal(effect.effect, term))
        else:
            effects.append(_literal(effect, term))
    # an atom deleted and added at once (move p p) is left as it was
    effects = [e for e in effects if (e[5:-1] if e.startswith("(not ") else f"(not {e})") not in effects]
    lines = [f"  (:action {variant.name}", f"    :parameters ({_typed(params)})"]
    lines += [f"    :precondition {_and(pre)}"] if pre else []
    return [*lines, f"    :effect {_and(effects, '(and)')})"]


# -- methods ----------------------------------------------------------------------------------
class _Method:
    """One of our methods as HDDL methods: variables, preconditions, subtasks."""

    def __init__(self, m: MethodSchema, task: TaskSchema, term: Callable[[Term, str], str]):
        self.m, self.term = m, term
        self.params: list[tuple[str, str]] = list(task.params)
        self.lets: dict[tuple[str, tuple[str, ...]], str] = {}  # (predicate, given args) -> variable
        self.pre: list[str] = []
        for let in m.lets:
            self.let(let.atom, rename=False)
        self.pre += [self.literal(p) for p in m.pre]

    def literal(self, lit: Literal) -> str:
        return _literal(lit, self.term)

    def let(self, atom: Atom, *, rename: bool = True) -> str:
        """The variable bound by ``atom`` here, bound anew (with its precondition) if need be."""
        key = (atom.predicate, atom.args[:-1])
        if key not in self.lets:
            variable = atom.args[-1]
            taken = {f"?{p}" for p, _ in self.params}
            n = 1
            while rename and variable in taken:
                n += 1
                variable = f"{atom.args[-1]}{n}"
            self.params.append((variable[1:], _let_type(atom)))
            self.lets[key] = variable
            self.pre.append(self.literal(Literal(Atom(atom.predicate, (*atom.args[:-1], variable)))))
        return self.lets[key]

    def unless(self, earlier: MethodSchema) -> None:
        """Apply only where ``earlier`` (tried before, on the same task) does not."""
        if len(earlier.pre) != 1:
            raise ValueError(
                f"method {self.m.name}: HDDL needs the earlier method {earlier.name} to have exactly "
                "one precondition, to negate"
            )
        rename = {let.variable: self.let(let.atom) for let in earlier.lets}
        lit = earlier.pre[0]
        atom = Atom(lit.atom.predicate, tuple(rename.get(t, t) for t in lit.atom.args))
        self.pre.append(self.literal(Literal(atom, not lit.positive)))

    def variants(self, base: str, task_names: dict[str, str]) -> list[list[str]]:
        """The lines of each HDDL method, one per consistent choice of action variants."""
        subtasks = self.m.subtasks
        several = [i for i, t in enumerate(subtasks) if len(_variants(t[0])) > 1]
        combos = itertools.product(*(_variants(subtasks[i][0]) for i in several))
        out = []
        for name, combo in zip(method_names(self.m, base), combos, strict=True):
            choice = dict(zip(several, combo, strict=True))
            tests = [self.choose(subtasks[i], choice[i]) for i in several]
            if any(test is None for test in tests):
                continue  # constants that this variant does not fit
            written = [self.subtask(t, choice.get(i), task_names) for i, t in enumerate(subtasks)]
            pre = self.pre + [x for test in tests for x in test or []]
            task = " ".join([task_names.get(self.m.task, self.m.task), *self.task_args()])
            lines = [f"  (:method {name}", f"    :parameters ({_typed(self.params)})", f"    :task ({task})"]
            lines += [f"    :precondition {_and(pre)}"] if pre else []
            out.append([*lines, f"    :ordered-subtasks {_and(written, '()')})"])
        return out

    def task_args(self) -> list[str]:
        return [f"?{p}" for p, _ in _TASKS[self.m.task].params] if self.m.task in _TASKS else []

    def args_of(self, subtask: tuple[Term, ...]) -> dict[str, tuple[Term, str]]:
        """The action's parameters as (our term, type)."""
        a = _ACTIONS[subtask[0]]
        return {f"?{p}": (t, k) for (p, k), t in zip(a.params, subtask[1:], strict=True)}

    def choose(self, subtask: tuple[Term, ...], variant: Variant) -> list[str] | None:
        """The equalities that choose ``variant`` for ``subtask`` (``None``: its constants do not
        fit); a variant that binds nothing is chosen where none of the others is."""
        args = self.args_of(subtask)

        def equal(p: Term, value: Term) -> str | bool:
            (left, kind), right = args[p], args[value][0] if is_variable(value) else value
            if not is_variable(left) and not is_variable(right):
                return left == right
            return f"(= {self.term(left, kind)} {self.term(right, kind)})"

        if variant.bind:
            tests = [equal(p, v) for p, v in variant.bind]
            return None if False in tests else [t for t in tests if isinstance(t, str)]
        out = []
        for other in _variants(subtask[0]):
            tests = [equal(p, v) for p, v in other.bind]
            if not tests or False in tests:
                continue  # the other variant is never chosen here
            left = [t for t in tests if isinstance(t, str)]
            if not left:
                return None  # the other variant always is
            if len(left) > 1:
                raise ValueError(f"method {self.m.name}: cannot negate the variant {other.name} in HDDL")
            out.append(f"(not {left[0]})")
        return out

    def subtask(self, subtask: tuple[Term, ...], variant: Variant | None, task_names: dict[str, str]) -> str:
        name = subtask[0]
        if name not in _ACTIONS:
            params = _TASKS[name].params if name in _TASKS else ()
            args = [self.term(t, k) for t, (_, k) in zip(subtask[1:], params, strict=True)]
            return f"({' '.join([task_names.get(name, name), *args])})"
        a = _ACTIONS[name]
        variant = variant or a.variants[0]
        args = self.args_of(subtask)
        bound = dict(variant.bind)
        out = [self.term(t, k) for p, (t, k) in args.items() if p not in bound]
        for let in a.lets:
            if PREDICATES[let.atom.predicate].add is not None:
                # the method finds the value when it is decomposed, the action when it runs
                raise ValueError(f"action {name}: HDDL needs its lets over facts no action changes")
            given = tuple(args[t][0] if t in args else t for t in let.atom.args[:-1])
            out.append(self.let(Atom(let.atom.predicate, (*given, let.variable))))
        return f"({' '.join([variant.name, *out])})"


def _variants(name: str) -> tuple[Variant, ...]:
    return _ACTIONS[name].variants if name in _ACTIONS else ()


def _written(home: Home, names: Names) -> tuple[list[str], list[str], dict[str, list[str]]]:
    """The lines of every HDDL method and action, and the constants they name, by type."""
    constants: dict[str, list[str]] = {"setting": [names("setting", s) for s in SETTINGS]}

    def constant(t: Term, kind: str) -> str:
        if is_variable(t):
            return t
        name = names(kind, t)
        if name not in constants.setdefault(kind, []):
            constants[kind].append(name)
        return name

    methods: list[str] = []
    for m in METHOD_SCHEMAS:
        method = _Method(m, _TASKS[m.task], constant)
        siblings = [x for x in METHOD_SCHEMAS if x.task == m.task]
        for earlier in siblings[: siblings.index(m)]:
            method.unless(earlier)
        for lines in method.variants(identifier(m.name.replace("_", "-")), names.tasks):
            methods += lines
    for service, m in zip(home.services, service_methods(home), strict=True):
        for lines in _Method(m, TaskSchema(service.name), constant).variants(
            names.methods[service.name], names.tasks
        ):
            methods += lines
    actions = [line for a in ACTIONS for v in a.variants for line in _action_variant(a, v, constant)]
    return methods, actions, constants


def _typed_groups(groups: dict[str, list[str]], indent: str) -> str:
    return "\n".join(f"{indent}{' '.join(objs)} - {kind}" for kind in TYPES if (objs := groups.get(kind)))


def domain_hddl(home: Home) -> str:
    """The home's HTN domain as an HDDL domain: types, constants, predicates, the actions, the
    compound tasks with their methods and one task (with one method) per service."""
    names = home_names(home)
    methods, actions, constants = _written(home, names)
    out = [
        f"(define (domain {identifier(home.name)})",
        "  (:requirements :hierarchy :typing :negative-preconditions :method-preconditions :equality)",
        f"  (:types {' '.join(TYPES)})",
        "  (:constants",
        _typed_groups(constants, "    "),
        "  )",
        "  (:predicates",
        *(f"    {p.declaration}" for p in PREDICATES.values()),
        "  )",
    ]
    out += [f"  (:task {t.name} :parameters ({_typed(t.params)}))" for t in TASKS]
    out += [f"  (:task {names.tasks[s.name]} :parameters ())" for s in home.services]
    out += [*methods, *actions, ")"]
    return "\n".join(out) + "\n"


# -- problems ---------------------------------------------------------------------------------
Facts = Callable[[Home, State], Iterable[tuple[str, ...]]]
# The true atoms of each predicate in a state, in our names (a predicate without an entry here
# is a KeyError when the problem is written).
FACTS: dict[str, Facts] = {
    "robot-at": lambda home, s: [(s.robot,)],
    "at": lambda home, s: [(o, p) for o, p in s.objects.items() if p != HELD],
    "holding": lambda home, s: [(s.holding,)] if s.holding is not None else [],
    "hand-empty": lambda home, s: [()] if s.holding is None else [],
    "user-at": lambda home, s: [(USER, s.user)],
    "is-on": lambda home, s: [(d,) for d, on in s.devices.items() if on],
    "iot": lambda home, s: [(d.name,) for d in home.devices if d.iot],
    "device-at": lambda home, s: list(tables(home)["DEVICE_PLACE"].items()),
    "source": lambda home, s: list(tables(home)["SOURCE"].items()),
    "docked": lambda home, s: [()] if s.docked else [],
}


def problem_hddl(
    home: Home, services: Sequence[str], state: State | None = None, *, name: str = "request"
) -> str:
    """A request as an HDDL problem: the objects the domain does not name, the initial state
    from ``state`` (default: the home's initial state) and the services, in order, as the
    initial task network."""
    from homecog.planning.state import initial_state

    state = state if state is not None else initial_state(home)
    known = {s.name for s in home.services}
    for service in services:
        if service not in known:
            raise PlanningError(f"unknown service {service!r}; the home has {', '.join(sorted(known))}")
    names = home_names(home, state)
    constants = {c for group in _written(home, names)[2].values() for c in group}
    objects: dict[str, list[str]] = {}
    for (kind, _), hddl in names.of.items():
        if kind not in ("task", "method", "message") and hddl not in constants:
            objects.setdefault(kind, []).append(hddl)
    init = []
    for predicate, p in PREDICATES.items():
        for args in FACTS[predicate](home, state):
            init.append(str(Atom(predicate, tuple(names(k, a) for k, a in zip(p.types, args, strict=True)))))
    htn = " ".join(f"({names.tasks[s]})" for s in services)
    lines = [
        f"(define (problem {identifier(name)})",
        f"  (:domain {identifier(home.name)})",
        "  (:objects",
        _typed_groups(objects, "    "),
        "  )",
        "  (:htn",
        "    :parameters ()",
        f"    :ordered-subtasks (and {htn})",
        "  )",
        "  (:init",
        *(f"    {fact}" for fact in init),
        "  )",
        ")",
    ]
    return "\n".join(lines) + "\n"


def actions_from_hddl(home: Home, steps: Iterable[tuple[str, Sequence[str]]]) -> list[Task]:
    """The plan of an HDDL planner, as ``(action name, argument names)`` pairs, in our
    planner's terms (the tuples of :attr:`homecog.planning.Plan.actions`)."""
    back = home_names(home).back
    variants = {v.name: (a, v) for a in ACTIONS for v in a.variants}
    out: list[Task] = []
    for name, args in steps:
        if name not in variants:
            raise PlanningError(f"unknown HDDL action {name!r}")
        a, variant = variants[name]
        bound = dict(variant.bind)
        free = [f"?{p}" for p, _ in a.params if f"?{p}" not in bound]
        values = {p: back.get(str(x), str(x)) for p, x in zip(free, args, strict=False)}
        for p, v in bound.items():
            values[p] = values[v] if is_variable(v) else v
        out.append((a.name, *(values[f"?{p}"] for p, _ in a.params)))
    return out
