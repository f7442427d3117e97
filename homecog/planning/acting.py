"""Acting: a plan carried out through *commands*, with replanning when one fails,
as GTPyhop's ``run_lazy_lookahead`` (Ghallab, Nau and Traverso, *Automated Planning and
Acting*, 2016).

Planning and acting are separate. An action of a plan is a model: what the robot expects. A
command carries it out in the world and may fail — an IoT switch whose broker is gone, a door
that is closed, an object that is not where the state says. A command is a function
``(state, *args) -> state`` like the action it carries out: it gets a copy of the state the
robot believes, acts, and returns the state after it (usually the action's own effect on that
state, :meth:`Domain.apply`); it raises :class:`~homecog.errors.CommandError` (or returns
``None``) when it could not. An action without a command is carried out on the model alone, as
GTPyhop does.

When a command fails, :func:`act` observes the world again (``observe``; without it, the state
the robot believed before the command) and plans the remaining tasks from there: the requested
task the failed action belongs to and every one after it (the tasks before it are done). It
plans at most ``max_tries`` times.

>>> from homecog.home import load_home
>>> from homecog.planning import initial_state, make_domain
>>> home = load_home("paper")
>>> domain = make_domain(home)
>>> broker = {"up": False}
>>> def switch(device, on):
...     if not broker["up"]:
...         broker["up"] = True  # it is back for the next try
...         raise ConnectionError("the broker is gone")
>>> result = act(domain, initial_state(home), [("CloseWindow",)], iot_commands(domain, switch))
>>> result.done, result.replans, result.achieved
([('switch_iot', 'window', 'off')], 1, True)
>>> print(result.failures[0])
plan 1: ('switch_iot', 'window', 'off') failed: ConnectionError: the broker is gone
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from homecog.errors import CommandError, PlanningError
from homecog.planning.planner import Domain, Plan, Task, find_plan

__all__ = ["Acting", "Command", "Failure", "act", "iot_commands"]

log = logging.getLogger(__name__)

Command = Callable[..., Any]
"""``(state, *args) -> state``: carries an action out in the world; raises
:class:`~homecog.errors.CommandError` (or returns ``None``) when it could not."""


@dataclass(frozen=True)
class Failure:
    """A command that failed: its action, why, and in which plan (1 is the first)."""

    action: Task
    reason: str
    plan: int

    def __str__(self) -> str:
        return f"plan {self.plan}: {self.action} failed: {self.reason}"


@dataclass
class Acting:
    """What acting did: the actions carried out in order, the commands that failed, every plan
    made (the first and the replans), whether the tasks were achieved (``reason`` says why not)
    and the state at the end."""

    tasks: list[Task]
    done: list[Task] = field(default_factory=list)
    failures: list[Failure] = field(default_factory=list)
    plans: list[Plan] = field(default_factory=list)
    achieved: bool = False
    reason: str | None = None
    state: Any = None

    @property
    def replans(self) -> int:
        return max(len(self.plans) - 1, 0)

    def as_dict(self) -> dict[str, Any]:
        return {
            "tasks": [list(t) for t in self.tasks],
            "done": [list(a) for a in self.done],
            "failures": [
                {"action": list(f.action), "reason": f.reason, "plan": f.plan} for f in self.failures
            ],
            "replans": self.replans,
            "achieved": self.achieved,
            "reason": self.reason,
        }


def act(
    domain: Domain,
    state: Any,
    tasks: Sequence[Task],
    commands: Mapping[str, Command] | None = None,
    *,
    observe: Callable[[], Any] | None = None,
    max_tries: int = 3,
) -> Acting:
    """Plan ``tasks`` from ``state`` and carry the plan out through ``commands`` (by action
    name); when a command fails, observe the world, plan the remaining tasks again and go on,
    planning at most ``max_tries`` times.

    Raises :class:`PlanningError` for a task the domain does not know; a request that cannot
    be planned (at first, or from what was observed) is an outcome, not an error: ``achieved``
    is false and ``reason`` says why.
    """
    if max_tries < 1:
        raise ValueError(f"max_tries must be at least 1, got {max_tries}")
    for task in tasks:
        if task[0] not in domain.actions and task[0] not in domain.methods:
            raise PlanningError(f"unknown task {task[0]!r} in domain {domain.name}")
    commands = commands or {}
    result = Acting(tasks=[tuple(t) for t in tasks], state=state)
    todo = list(result.tasks)
    for attempt in range(1, max_tries + 1):
        try:
            plan = find_plan(domain, state, todo)
        except PlanningError as e:
            log.warning("acting: %s", e)
            result.reason, result.state = str(e), state
            return result
        result.plans.append(plan)
        log.info("plan %d for %s: %d actions", attempt, _names(todo), len(plan.actions))
        failed, position = None, 0
        for position in range(len(plan.actions)):
            action = plan.actions[position]
            after, reason = _carry_out(domain, commands, state, action)
            if after is None:
                failed = Failure(action, reason, attempt)
                break
            log.debug("done: %s", " ".join(action))
            result.done.append(action)
            state = after
        if failed is None:
            log.info("achieved %s after %d replans", _names(result.tasks), result.replans)
            result.achieved, result.state = True, state
            return result
        result.failures.append(failed)
        log.warning("%s", failed)
        if observe is not None:
            state = observe()
        # the task the failed action belongs to is planned again, from the start: its methods
        # read the state, so what was done of it is not done twice (a cup held is not fetched)
        todo = [task for task, positions in plan.roots() if positions.stop > position]
    result.reason = f"gave up after {max_tries} plans; the last: {result.failures[-1]}"
    result.state = state
    log.warning("acting: %s", result.reason)
    return result


def _carry_out(domain: Domain, commands: Mapping[str, Command], state: Any, action: Task) -> tuple[Any, str]:
    """(the state after ``action``, ``""``) or (``None``, why its command failed)."""
    command = commands.get(action[0])
    if command is None:  # no command: the model alone, as GTPyhop does
        after = domain.actions[action[0]](state.copy(), *action[1:])
        return after, "" if after is not None else (domain.why_not(state, action) or "it does not apply")
    try:
        after = command(state.copy(), *action[1:])
    except CommandError as e:
        return None, str(e)
    return after, "" if after is not None else "the command failed"


def _names(tasks: Sequence[Task]) -> str:
    return ", ".join(" ".join(t) for t in tasks)


def iot_commands(domain: Domain, switch: Callable[[str, bool], object]) -> dict[str, Command]:
    """The command of ``switch_iot``: ``switch(device, on)`` (a context source's IoT command:
    the simulated home, MQTT or Home Assistant); whatever the switch raises fails the command
    (a broker gone is the world, not a bug of ours)."""

    def switch_iot(state: Any, device: str, setting: str) -> Any:
        after = domain.apply(state, ("switch_iot", device, setting))  # PlanningError: our own bug
        try:
            switch(device, setting == "on")
        except Exception as e:
            raise CommandError(f"{type(e).__name__}: {e}") from e
        return after

    return {"switch_iot": switch_iot}
