"""Planning: services decomposed into robot actions by an HTN planner.

>>> from homecog.home import load_home
>>> plan = plan_services(load_home("paper"), ["CloseWindow", "ChargeItSelf"], user="sofa")
>>> print(plan.outline())
CloseWindow
  switch window off
    1 switch_iot window off
ChargeItSelf
  goto charger
  2 dock charger
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.planning.acting import Acting, act
from homecog.planning.domain import make_domain
from homecog.planning.planner import Domain, Plan, TaskNode, find_plan
from homecog.planning.state import State, initial_state

__all__ = [
    "Acting",
    "Domain",
    "Plan",
    "State",
    "TaskNode",
    "act",
    "find_plan",
    "initial_state",
    "make_domain",
    "plan_services",
]


def plan_services(
    home: Home,
    services: Sequence[str],
    *,
    context: Mapping[str, object] | None = None,
    user: str | None = None,
    state: State | None = None,
    domain: Domain | None = None,
) -> Plan:
    """One plan for ``services`` in the given (priority) order, with its decomposition tree."""
    known = set(home.service_names)
    for name in services:
        if name not in known:
            raise PlanningError(f"unknown service {name!r}; the home has {', '.join(home.service_names)}")
    state = state if state is not None else initial_state(home, context, user=user)
    return find_plan(domain or make_domain(home), state, [(name,) for name in services])
