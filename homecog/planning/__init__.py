"""Planning: services decomposed into robot actions by an HTN planner (SPEC §8).

>>> from homecog.home import load_home
>>> plan = plan_services(load_home("paper"), ["CloseWindow", "ChargeItSelf"], user="sofa")
>>> print(plan.outline())
CloseWindow
  switch window off
    1 switch_iot window off
ChargeItSelf
  goto charger
    2 move charger charger
  3 dock charger
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from homecog.errors import PlanningError
from homecog.home.model import Home, parse_state
from homecog.planning.domain import State, make_domain
from homecog.planning.planner import Domain, Plan, TaskNode, find_plan

__all__ = [
    "Domain",
    "Plan",
    "State",
    "TaskNode",
    "find_plan",
    "initial_state",
    "make_domain",
    "plan_services",
]


def initial_state(
    home: Home, context: Mapping[str, object] | None = None, *, user: str | None = None
) -> State:
    """The planning state of a home: the robot at its start place, objects where the layout
    puts them, devices as the context says (off where it says nothing), and the user at the
    place named by ``user``, else by the context's ``location``, else at the first place
    that is a value of a context feature."""
    layout = home.layout
    if layout is None:
        raise PlanningError(f"home {home.name!r} has no layout; add a layout section to plan (SPEC §8)")
    context = context or {}
    devices = {}
    for d in home.devices:
        value = context.get(d.name, False)
        devices[d.name] = value if isinstance(value, bool) else parse_state(value)
    if user is None and "location" in context:
        user = str(context["location"])
        if not layout.has_place(user):
            raise PlanningError(f"the user's location {user!r} is not a place or room of the layout")
    if user is None:
        values = [v for f in home.features if f.is_discrete for v in f.values]
        user = next((v for v in values if layout.has_place(v)), layout.robot)
    elif not layout.has_place(user):
        raise PlanningError(f"unknown place {user!r} for the user; the layout has {', '.join(layout.places)}")
    return State(robot=layout.robot, user=user, objects=dict(layout.objects), devices=devices)


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
