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

from collections.abc import Callable

from homecog.errors import PlanningError
from homecog.home.model import Home
from homecog.planning import Domain, State, make_domain
from homecog.simulation.interface import Body, Outcome
from homecog.simulation.robot import DiffDrive
from homecog.simulation.simulate import Simulation, SimulationResult


class SimulatedRobot(Body):
    """A robot on a home's floor plan, homecog's own simulator: a differential drive on A* paths.

    Parameters
    ----------
    home
        The home; it needs a layout.
    world
        Where the robot and the objects are (default: the home's initial state).
    switch
        ``switch(device, on)``: how a switch reaches the home (a context source's
        :meth:`switch`); without it, the devices live in the simulation alone.
    robot, domain
        The robot's limits and the planning domain (default: made from the home).
    """

    name = "builtin"
    planner = "astar"  # homecog's own A* on the occupancy grid (homecog.simulation.grid)

    def __init__(
        self,
        home: Home,
        world: State | None = None,
        *,
        switch: Callable[[str, bool], object] | None = None,
        robot: DiffDrive | None = None,
        domain: Domain | None = None,
    ) -> None:
        self.home = home
        self.switch = switch
        self.domain = domain or make_domain(home)
        self.simulation = Simulation(home, world, robot=robot, domain=self.domain)

    @property
    def world(self) -> State:
        """The state of the world as it is (the simulation's), not as the robot believes it."""
        return self.simulation.state

    def start(self, world: State) -> None:
        self.simulation = Simulation(self.home, world, robot=self.simulation.robot, domain=self.domain)

    def observe(self) -> State:
        """What the robot sees of the world: all of it."""
        return self.simulation.state.copy()

    def result(self) -> SimulationResult:
        return self.simulation.result()

    def move(self, origin: str, target: str) -> Outcome:
        return self._run(("move", origin, target))

    def pick(self, obj: str, place: str) -> Outcome:
        return self._run(("pick", obj, place))

    def pour(self, obj: str, place: str) -> Outcome:
        return self._run(("pour", obj, place))

    def hand_over(self, obj: str, who: str) -> Outcome:
        return self._run(("hand_over", obj, who))

    def speak(self, text: str) -> Outcome:
        return self._run(("speak", text))

    def switch_iot(self, device: str, setting: str) -> Outcome:
        return self._run(("switch_iot", device, setting))

    def switch_by_hand(self, device: str, setting: str) -> Outcome:
        return self._run(("switch_by_hand", device, setting))

    def dock(self, place: str) -> Outcome:
        return self._run(("dock", place))

    def _run(self, action: tuple[str, ...]) -> Outcome:
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
