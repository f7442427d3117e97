"""The simulated robot's body: homecog's own 2D simulator behind the body
interface (:mod:`homecog.simulation.interface`), whose commands carry a plan's actions out on
the floor plan, for acting (:mod:`homecog.planning.acting`).

The world is a :class:`~homecog.simulation.Simulation`: where the robot and the objects really
are, which may differ from what the robot believes. An action is checked against the
world (the planning domain's reason when it does not apply: the cup is not where the robot
thought), switches the device in the home through ``switch`` for a switch (a context source's,
so that the simulated home sees it), and runs in the simulation, which takes its time and drives
its path; it answers with an :class:`~homecog.simulation.interface.Outcome`.

>>> from homecog.home import load_home
>>> from homecog.planning import act, initial_state
>>> home = load_home("paper")
>>> body = SimulatedRobot(home, initial_state(home, user="sofa"))
>>> body.world.objects["cup"] = "table"          # someone moved the cup
>>> result = act(body.domain, initial_state(home, user="sofa"), [("SendDrinks",)], body.commands(),
...              observe=body.observe)
>>> print(result.failures[0])
plan 1: ('pick', 'cup', 'dispenser') failed: 'cup' is not at 'dispenser'
>>> result.done, result.replans, result.achieved     # planned again from where the cup is
([('move', 'charger', 'dispenser'), ('move', 'dispenser', 'table'), ('pick', 'cup', 'table'), \
('move', 'table', 'dispenser'), ('pour', 'cup', 'dispenser'), ('move', 'dispenser', 'sofa'), \
('hand_over', 'cup', 'user')], 1, True)
"""

from __future__ import annotations

from homecog.errors import PlanningError
from homecog.planning import State
from homecog.simulation.interface import Body, Outcome
from homecog.simulation.simulate import Simulation, SimulationResult


class SimulatedRobot(Body):
    """A robot on a home's floor plan, homecog's own simulator: a differential drive on A* paths.
    Its parameters are :class:`~homecog.simulation.interface.Body`'s."""

    name = "builtin"
    planner = "astar"  # homecog's own A* on the occupancy grid (homecog.simulation.grid)
    simulation: Simulation

    @property
    def world(self) -> State:
        """The state of the world as it is (the simulation's), not as the robot believes it."""
        return self.simulation.state

    def start(self, world: State | None = None) -> None:
        self.simulation = Simulation(self.home, world, robot=self.diffdrive, domain=self.domain)

    def observe(self) -> State:
        """What the robot sees of the world: all of it."""
        return self.simulation.state.copy()

    def result(self) -> SimulationResult:
        return self.simulation.result()

    def _act(self, action: tuple[str, ...]) -> Outcome:
        """Check ``action`` against the world, switch the home for a switch, then simulate it."""
        why = self.domain.why_not(self.simulation.state, action)
        if why is not None:
            return Outcome.failed(why)
        if action[0] in ("switch_iot", "switch_by_hand"):
            switched = self._switch(action[1], action[2])
            if not switched.success:
                return switched
        try:
            self.simulation.run(action)
        except PlanningError as e:  # a path that cannot be driven
            return Outcome.failed(str(e))
        return Outcome.done()
