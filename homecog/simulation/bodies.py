"""The robot's bodies by name, and a plan carried out by one: what ``homecog
simulate --robot`` and ``homecog up --robot`` choose between.

===============  ===================================================================
``builtin``      homecog's own 2D simulator (:class:`~homecog.simulation.body.SimulatedRobot`)
``pyrobosim``    pyrobosim, with its path planners
                 (:class:`~homecog.simulation.pyrobosim_body.PyRoboSimBody`; the
                 ``[pyrobosim]`` extra)
===============  ===================================================================

>>> from homecog.home import load_home
>>> from homecog.planning import plan_services
>>> home = load_home("paper")
>>> plan = plan_services(home, ["CloseWindow", "ChargeItSelf"], user="sofa")
>>> acting, run = carry_out(make_body("builtin", home), plan)
>>> acting.achieved, [row["action"][0] for row in run.timeline], run.devices["window"]
(True, ['switch_iot', 'dock'], False)
"""

from __future__ import annotations

import threading
from typing import Unpack

from homecog.errors import PlanningError, UsageProblemError
from homecog.home.model import Home
from homecog.planning import Acting, Plan, State, act
from homecog.simulation.interface import Body, BodyOptions
from homecog.simulation.simulate import SimulationResult

BODIES = ("builtin", "pyrobosim")
"""The bodies by name, homecog's own first."""


def make_body(
    kind: str,
    home: Home,
    world: State | None = None,
    *,
    planner: str | None = None,
    **options: Unpack[BodyOptions],
) -> Body:
    """The body ``kind`` in ``home`` (which needs a layout), from ``world``, with ``options``
    (:class:`~homecog.simulation.interface.Body`'s); ``planner`` is pyrobosim's path planner
    (its A* by default). :class:`UsageProblemError` for an unknown body,
    :class:`~homecog.errors.DependencyNotInstalledError` for pyrobosim without its extra."""
    if kind == "builtin":
        if planner is not None:
            raise UsageProblemError(
                "--planner chooses pyrobosim's path planner; it goes with --robot pyrobosim"
            )
        from homecog.simulation.body import SimulatedRobot

        return SimulatedRobot(home, world, **options)
    if kind == "pyrobosim":
        from homecog.simulation.pyrobosim_body import PyRoboSimBody
        from homecog.simulation.pyrobosim_world import PLANNERS

        if planner is not None and planner not in PLANNERS:
            raise UsageProblemError(
                f"--planner: unknown path planner {planner!r}; expected one of {', '.join(PLANNERS)}"
            )

        return PyRoboSimBody(home, world, planner=planner or "astar", **options)
    raise UsageProblemError(f"--robot: unknown body {kind!r}; expected one of {', '.join(BODIES)}")


def carry_out(body: Body, plan: Plan, *, max_tries: int = 3) -> tuple[Acting, SimulationResult]:
    """Carry out the requested tasks of ``plan`` from its start with ``body``: acting plans them
    (the same plan first), and when an action fails it observes the body's world and plans the
    rest again. What acting did, and the body's run."""
    body.start(plan.start)
    tasks = [node.task for node in plan.tree]
    acting = act(body.domain, plan.start, tasks, body.commands(), observe=body.observe, max_tries=max_tries)
    return acting, body.result()


class Preview:
    """Plans carried out by a body of the kind ``kind`` kept for the purpose, one at a time (the
    HMI's plan, while the robot's own body acts in the home): made at the first run.

    >>> from homecog.home import load_home
    >>> from homecog.planning import plan_services
    >>> home = load_home("paper")
    >>> run = Preview(home).run(plan_services(home, ["ChargeItSelf"], user="sofa"))
    >>> run.actions
    [('dock', 'charger')]
    """

    def __init__(self, home: Home, kind: str = "builtin") -> None:
        self.home = home
        self.kind = kind
        self._body: Body | None = None
        self._lock = threading.Lock()

    def run(self, plan: Plan) -> SimulationResult:
        """``plan`` carried out from its start; :class:`PlanningError` when it could not be."""
        with self._lock:
            if self._body is None:
                self._body = make_body(self.kind, self.home, plan.start)
            acting, run = carry_out(self._body, plan)
        if not acting.achieved:
            raise PlanningError(f"the {self._body.name} robot could not carry the plan out: {acting.reason}")
        return run
