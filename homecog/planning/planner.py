"""A small total-order HTN planner in the style of SHOP and GTPyhop.

A :class:`Domain` is plain data: actions ``(state, *args) -> state | None`` that change a copy
of the state (``None``: not applicable), and per compound task a list of methods
``(state, *args) -> subtasks | None`` tried in order (``None``: not applicable; ``[]``:
nothing to do). Tasks are tuples ``(name, *args)``. Subtasks are decomposed left to right on
the state their predecessors leave, with backtracking over methods. Unlike GTPyhop 2.x on
PyPI, an action that leaves the state as it was stays in the plan, and the domain is passed
explicitly rather than held in a global.

>>> from dataclasses import dataclass, replace
>>> @dataclass
... class S:
...     at: str
...     def copy(self): return replace(self)
>>> def walk(s, a, b):
...     if s.at != a:
...         return None
...     s.at = b
...     return s
>>> def go(s, b):
...     return [("walk", s.at, b)]
>>> domain = Domain("toy", actions={"walk": walk}, methods={"go": [go]})
>>> plan = find_plan(domain, S("home"), [("go", "park"), ("go", "park")])
>>> plan.actions
[('walk', 'home', 'park'), ('walk', 'park', 'park')]
>>> print(plan.outline())
go park
  1 walk home park
go park
  2 walk park park
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from homecog.errors import PlanningError

Task = tuple[str, ...]


class PlanState(Protocol):
    def copy(self) -> Any: ...


Action = Callable[..., Any]
Method = Callable[..., "list[Task] | None"]
Reason = Callable[..., "str | None"]


@dataclass(frozen=True)
class Domain:
    """Actions and methods by task name; methods in the order they are tried. ``reasons``
    (optional, per action) say why an action does not apply, for those who carry plans out:
    ``(state, *args) -> str | None``."""

    name: str
    actions: Mapping[str, Action]
    methods: Mapping[str, Sequence[Method]]
    reasons: Mapping[str, Reason] = field(default_factory=dict)

    def __post_init__(self) -> None:
        both = set(self.actions) & set(self.methods)
        if both:
            raise ValueError(f"names both an action and a compound task: {', '.join(sorted(both))}")

    def why_not(self, state: Any, action: Sequence[str]) -> str | None:
        """Why ``action`` does not apply in ``state``; ``None`` when it does.

        >>> domain = Domain("toy", actions={"wait": lambda s: s, "stop": lambda s: None}, methods={})
        >>> [domain.why_not({}, action) for action in [("wait",), ("stop",), ("fly", "home")]]
        [None, 'it does not apply', "unknown kind 'fly'; expected one of wait, stop"]
        """
        kind = action[0] if len(action) else ""
        if kind not in self.actions:
            return f"unknown kind {kind!r}; expected one of {', '.join(self.actions)}"
        reason = self.reasons.get(kind)
        if reason is not None:
            return reason(state, *action[1:])
        return None if self.actions[kind](state.copy(), *action[1:]) is not None else "it does not apply"

    def apply(self, state: Any, action: Sequence[str]) -> Any:
        """``action`` carried out on a copy of ``state``: the state after it. Raises
        :class:`PlanningError` saying why when it does not apply."""
        why = self.why_not(state, action)
        after = None if why is not None else self.actions[action[0]](state.copy(), *action[1:])
        if after is None:
            raise PlanningError(why or "it does not apply")
        return after


@dataclass
class TaskNode:
    """A node of the decomposition tree: a compound task and the method that decomposed it,
    or an action with its position in the plan (1-based)."""

    task: Task
    method: str | None = None
    children: list[TaskNode] = field(default_factory=list)
    index: int | None = None

    @property
    def is_action(self) -> bool:
        return self.index is not None

    def as_dict(self) -> dict[str, Any]:
        if self.is_action:
            return {"action": list(self.task), "index": self.index}
        return {
            "task": list(self.task),
            "method": self.method,
            "children": [c.as_dict() for c in self.children],
        }


@dataclass
class Plan:
    """The actions in order, the decomposition tree (one root per requested task), the state
    the plan leaves and the state it starts from."""

    actions: list[Task]
    tree: list[TaskNode]
    state: Any
    start: Any = None

    def roots(self) -> list[tuple[Task, range]]:
        """Each requested task with the (0-based) positions of its actions in :attr:`actions`."""
        out, begin = [], 0
        for root in self.tree:
            end = begin + sum(1 for _ in _leaves([root]))
            out.append((root.task, range(begin, end)))
            begin = end
        return out

    def outline(self, indent: str = "  ") -> str:
        """The tree indented by level, actions numbered in order (as the paper's Fig. 13c)."""
        lines: list[str] = []

        def walk(node: TaskNode, depth: int) -> None:
            text = " ".join(node.task)
            lines.append(indent * depth + (f"{node.index} {text}" if node.is_action else text))
            for child in node.children:
                walk(child, depth + 1)

        for root in self.tree:
            walk(root, 0)
        return "\n".join(lines)


def find_plan(domain: Domain, state: PlanState, tasks: Sequence[Task]) -> Plan:
    """The first plan (depth first, methods in order) for ``tasks`` from ``state``.

    Raises :class:`PlanningError` naming the task when there is none.
    """
    for task in tasks:
        if task[0] not in domain.actions and task[0] not in domain.methods:
            raise PlanningError(f"unknown task {task[0]!r} in domain {domain.name}")
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10_000))
    try:
        for end, actions, nodes in _solve(domain, state, list(tasks)):
            for i, node in enumerate(_leaves(nodes), start=1):
                node.index = i
            return Plan(actions=actions, tree=nodes, state=end, start=state.copy())
    finally:
        sys.setrecursionlimit(limit)
    raise PlanningError(f"no plan for {', '.join(' '.join(t) for t in tasks)} in domain {domain.name}")


def _leaves(nodes: list[TaskNode]) -> Iterator[TaskNode]:
    for node in nodes:
        if not node.children and node.method is None:
            yield node
        else:
            yield from _leaves(node.children)


def _solve(domain: Domain, state: Any, tasks: list[Task]) -> Iterator[tuple[Any, list[Task], list[TaskNode]]]:
    if not tasks:
        yield state, [], []
        return
    first, rest = tasks[0], tasks[1:]
    for after, actions, node in _decompose(domain, state, first):
        for end, more, nodes in _solve(domain, after, rest):
            yield end, actions + more, [node, *nodes]


def _decompose(domain: Domain, state: Any, task: Task) -> Iterator[tuple[Any, list[Task], TaskNode]]:
    name, args = task[0], task[1:]
    action = domain.actions.get(name)
    if action is not None:
        after = action(state.copy(), *args)
        if after is not None:
            yield after, [task], TaskNode(task)
        return
    methods = domain.methods.get(name)
    if methods is None:
        raise PlanningError(f"unknown task {name!r} in domain {domain.name}")
    for method in methods:
        subtasks = method(state, *args)
        if subtasks is None:
            continue
        for end, actions, nodes in _solve(domain, state, list(subtasks)):
            yield end, actions, TaskNode(task, method=method.__name__, children=nodes)
